"""Read a mesh file with trimesh into parts in POV-Ray's frame, in millimetres.

This module touches files (the model and what it names: MTL, textures, glTF
buffers); the frame change itself is the pure ``to_pov_frame``.

Handedness: the formats are right-handed, ``+y`` up, the viewer on ``+z``
looking toward ``-z``.  POV-Ray (docs/geometry.md) is left-handed, ``+y`` up, the
viewer on ``-z`` looking toward ``+z``.  Negating ``z`` maps one onto the other
so that the viewer sees the same picture (x stays right, y stays up: nothing is
mirrored) and the model's front, which faced its viewer, faces ours.  A
reflection turns the numeric winding around, so each face's last two indices
are swapped to keep ``(b - a) x (c - a)`` pointing outward, the same way as the
vertex normals.
"""

from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import cast

import numpy as np

from ..errors import InputError, param
from .formats import FORMATS, UNITS, MeshFormat

_FLIP = np.array([1.0, 1.0, -1.0])
_DEFAULT_BASE = np.array([204, 204, 204, 255], dtype=np.uint8)  # light neutral grey
#: An OBJ split into more objects and groups than this is read by material only (some exporters write
#: a group per face; object masks tell at most 1000 ids apart anyway).
MAX_SPLIT_PARTS = 1000


@dataclass(frozen=True, eq=False)
class Part:
    """One triangle mesh of a model, in POV-Ray's frame (mm).

    Attributes
    ----------
    name : str
    vertices : (n, 3) float64, mm
    faces : (m, 3) int64, indices into ``vertices``; ``(b-a) x (c-a)`` points outward
    normals : (n, 3) float64 or None      unit vertex normals (from the file, or None)
    uv : (n, 2) float64 or None           texture coordinates, (0, 0) = image bottom left
    vertex_colors : (n, 4) uint8 or None  RGBA
    face_colors : (m, 4) uint8 or None    RGBA
    texture : (h, w, 3|4) uint8 or None   the image the UVs look up
    base_color : (4,) uint8               RGBA where there is no texture or colours
    colour_space : {'srgb', 'linear'}     encoding of the 8-bit colours
    texture_missing : str                 name of a texture the file names but that is missing
    """

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None = None
    uv: np.ndarray | None = None
    vertex_colors: np.ndarray | None = None
    face_colors: np.ndarray | None = None
    texture: np.ndarray | None = None
    base_color: np.ndarray = field(default_factory=lambda: _DEFAULT_BASE.copy())
    colour_space: str = "srgb"
    texture_missing: str = ""

    def __post_init__(self) -> None:
        n, m = len(self.vertices), len(self.faces)
        checks = [("vertices", self.vertices, (n, 3)), ("faces", self.faces, (m, 3)),
                  ("normals", self.normals, (n, 3)), ("uv", self.uv, (n, 2)),
                  ("vertex_colors", self.vertex_colors, (n, 4)), ("face_colors", self.face_colors, (m, 4)),
                  ("base_color", self.base_color, (4,))]
        for label, array, shape in checks:
            if array is not None and np.shape(array) != shape:
                raise ValueError(f"Part {self.name!r}: {label} must have shape {shape}, got {np.shape(array)}")
        if self.colour_space not in ("srgb", "linear"):
            raise ValueError(f"colour_space must be 'srgb' or 'linear', got {self.colour_space!r}")

    @property
    def triangles(self) -> int:
        return len(self.faces)


@dataclass
class LoadedModel:
    """What a file held: its parts (POV frame, mm) and what the loader noticed."""

    parts: list[Part]
    format: MeshFormat
    files: list[Path]                 # every file read: the model first, then MTL, textures, buffers
    missing: list[str]                # names the model refers to that are not there
    mm_per_unit: float
    warnings: list[str] = field(default_factory=list)


def to_pov_frame(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray | None,
                 mm_per_unit: float) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Right-handed model coordinates -> POV-Ray's left-handed frame, in mm.

    Parameters
    ----------
    vertices : (n, 3) float, model units
    faces : (m, 3) int
    normals : (n, 3) float or None
    mm_per_unit : float

    Returns
    -------
    vertices : (n, 3) float64, mm, ``z`` negated
    faces : (m, 3) int64, winding reversed (columns 0, 2, 1)
    normals : (n, 3) float64 or None, ``z`` negated
    """
    # + 0.0 turns the -0.0 of a negated 0 into 0.0 (same value, plainer text).
    v = np.asarray(vertices, dtype=np.float64) * (_FLIP * mm_per_unit) + 0.0
    f = np.asarray(faces, dtype=np.int64)[:, [0, 2, 1]]
    n = None if normals is None else np.asarray(normals, dtype=np.float64) * _FLIP + 0.0
    return v, f, n


def _recording_resolver(model: Path):
    """trimesh's file resolver, noting every file it reads and every name it cannot find."""
    import trimesh

    class RecordingResolver(trimesh.resolvers.FilePathResolver):
        def __init__(self, source: str) -> None:
            super().__init__(source)
            self.read: list[Path] = []
            self.missing: list[str] = []

        def get(self, name: str) -> bytes:
            try:
                data = super().get(name)
            except Exception:
                self.missing.append(name)
                raise
            self.read.append((model.parent / name).resolve())
            return data

    return RecordingResolver(str(model))


def _check_stl(path: Path, data: bytes) -> None:
    """trimesh reads a truncated binary STL as an empty mesh without a word: catch it here."""
    head = data[:512].lstrip().lower()
    if head.startswith(b"solid") and b"facet" in data[:4096].lower():
        return  # ASCII STL: trimesh's parser reports its own errors
    if len(data) < 84:
        raise InputError(f"{str(path)!r} is not an STL file: {len(data)} bytes, shorter than the 84-byte header")
    count = int.from_bytes(data[80:84], "little")
    expected = 84 + 50 * count
    if len(data) < expected:
        raise InputError(f"{str(path)!r} is a truncated binary STL: its header counts {count} triangles "
                         f"({expected} bytes) but the file has {len(data)} bytes; export it again")


_STL_RECORD = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attributes", "<u2")])


def _binary_stl(path: Path, data: bytes, fmt: MeshFormat, unit: str | None) -> LoadedModel | None:
    """A plain binary STL read straight into a part (what trimesh gives, without its import and
    copies); None for anything else (ASCII, colour attributes, trailing bytes): trimesh reads it."""
    count = int.from_bytes(data[80:84], "little") if len(data) >= 84 else -1
    if count <= 0 or len(data) != 84 + _STL_RECORD.itemsize * count or \
            (data[:5].lower() == b"solid" and b"facet" in data[:4096].lower()):
        return None
    records = np.frombuffer(data, dtype=_STL_RECORD, count=count, offset=84)
    if records["attributes"].any():  # per-face colours in some exporters' dialects
        return None
    faces = np.arange(3 * count, dtype=np.int64).reshape(-1, 3)
    mm = UNITS[unit] if unit is not None else UNITS[fmt.unit]
    v, f, _ = to_pov_frame(records["corners"].reshape(-1, 3), faces, None, mm)
    part = Part(name=path.name, vertices=v, faces=f, colour_space=fmt.colour_space)
    return LoadedModel([part], fmt, [path.resolve()], [], mm, [])


_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
              "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
              "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}


def _binary_ply(path: Path, data: bytes, fmt: MeshFormat, unit: str | None) -> LoadedModel | None:
    """The common binary PLY (a ``vertex`` element of scalar x, y, z [nx, ny, nz] and a ``face``
    element of triangles only) read with NumPy; None for anything else (ASCII, colours, polygons,
    other elements): trimesh reads it (its import alone took 0.8 s)."""
    end = data.find(b"end_header\n", 0, 65536)
    if not data.startswith(b"ply\n") or end < 0:
        return None
    lines = [line.split() for line in data[:end].decode("ascii", "replace").splitlines()[1:]]
    lines = [w for w in lines if w and w[0] not in ("comment", "obj_info")]
    if not lines or lines[0][:2] not in (["format", "binary_little_endian"], ["format", "binary_big_endian"]):
        return None
    order = "<" if lines[0][1] == "binary_little_endian" else ">"
    elements: list[tuple[str, int, list[list[str]]]] = []
    for words in lines[1:]:
        if words[0] == "element" and len(words) == 3 and words[2].isdigit():
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property" and elements:
            elements[-1][2].append(words[1:])
        else:
            return None
    if [(name, len(props) > 0) for name, _, props in elements] != [("vertex", True), ("face", True)]:
        return None
    (_, n, vprops), (_, m, fprops) = elements
    if any(len(p) != 2 or p[0] not in _PLY_TYPES for p in vprops) or len(fprops) != 1:
        return None
    names = [p[1] for p in vprops]
    face = fprops[0]
    normal = {"nx", "ny", "nz"} & set(names)
    if not {"x", "y", "z"} <= set(names) or set(names) - {"x", "y", "z", "nx", "ny", "nz"} or normal and len(normal) != 3 or \
            len(face) != 4 or face[0] != "list" or face[3] not in ("vertex_indices", "vertex_index") or \
            _PLY_TYPES.get(face[1]) not in ("u1", "i1") or _PLY_TYPES.get(face[2]) not in ("i4", "u4"):
        return None
    vertex_type = np.dtype([(p[1], order + _PLY_TYPES[p[0]]) for p in vprops])
    face_type = np.dtype([("count", "u1"), ("index", order + _PLY_TYPES[face[2]], 3)])
    start = end + len(b"end_header\n")
    if len(data) != start + n * vertex_type.itemsize + m * face_type.itemsize:
        return None  # polygons other than triangles, or a damaged file: trimesh says which
    vertex = np.frombuffer(data, dtype=vertex_type, count=n, offset=start)
    records = np.frombuffer(data, dtype=face_type, count=m, offset=start + n * vertex_type.itemsize)
    if (records["count"] != 3).any():
        return None
    faces = records["index"].astype(np.int64)
    if faces.size and (faces.min() < 0 or faces.max() >= n):
        raise InputError(f"{str(path)!r} is corrupt: it has face indices outside its {n} vertices")
    corners = np.stack([vertex["x"], vertex["y"], vertex["z"]], axis=1)
    normals = np.stack([vertex["nx"], vertex["ny"], vertex["nz"]], axis=1) if "nz" in names else None
    mm = UNITS[unit] if unit is not None else UNITS[fmt.unit]
    v, f, nrm = to_pov_frame(corners, faces, normals, mm)
    part = Part(name=path.name, vertices=v, faces=f, normals=nrm, colour_space=fmt.colour_space)
    return LoadedModel([part], fmt, [path.resolve()], [], mm, [])


def _units(scene, fmt: MeshFormat, unit: str | None) -> float:
    if unit is not None:
        return UNITS[unit]
    if getattr(scene, "units", None) and fmt.unit != "m":  # glTF: trimesh assumes metres, as the spec says
        try:
            import trimesh

            return float(trimesh.units.unit_conversion(scene.units, "millimeters"))
        except Exception:  # an unit name trimesh does not know: fall back to the format's
            pass
    return UNITS[fmt.unit]


def _colours(visual, fmt: MeshFormat, faces: int, missing: list[str]) -> dict:
    """Vertex or face colours, UVs, texture and base colour of one trimesh visual."""
    out: dict = {"colour_space": fmt.colour_space}
    kind = getattr(visual, "kind", None)
    if kind == "texture":
        material = visual.material
        base = getattr(material, "baseColorFactor", None)
        if base is None:
            base = getattr(material, "diffuse", None)
        if base is not None:
            out["base_color"] = np.asarray(base, dtype=np.uint8).reshape(4)
        image = getattr(material, "baseColorTexture", None) or getattr(material, "image", None)
        if visual.uv is not None and image is not None:
            im = image if image.mode in ("RGB", "RGBA") else image.convert("RGBA" if "A" in image.getbands() else "RGB")
            out["texture"] = np.asarray(im, dtype=np.uint8)
            out["uv"] = np.asarray(visual.uv, dtype=np.float64)
        elif visual.uv is not None and missing:
            out["texture_missing"] = missing[-1]
    elif kind == "vertex":
        out["vertex_colors"] = np.asarray(visual.vertex_colors, dtype=np.uint8)
    elif kind == "face":
        out["face_colors"] = np.asarray(visual.face_colors, dtype=np.uint8)[:faces]
    return out


def load_model(path: str | Path, *, unit: str | None = None) -> LoadedModel:
    """Read every triangle mesh of ``path``, transforms applied, in POV-Ray's frame (mm).

    Raises
    ------
    InputError
        Missing or unreadable file, unknown extension, corrupt or truncated content.
    ConfigError
        Unknown unit.
    """
    from ..errors import ConfigError

    path = Path(path)
    fmt = FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise InputError(f"{str(path)!r} has the unknown mesh extension {path.suffix!r}; "
                         f"povh3d reads {', '.join(FORMATS)}")
    if unit is not None and unit not in UNITS:
        raise ConfigError(f"{param('unit')} must be one of {', '.join(UNITS)}, got {unit!r}")
    if not path.is_file():
        raise InputError(f"model file {str(path)!r} does not exist; check the path")
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read {str(path)!r}: {exc.strerror}") from None
    if not data.strip():
        raise InputError(f"{str(path)!r} is empty; export the model again")
    if fmt.file_type == "stl":
        _check_stl(path, data)

    if fmt.file_type == "stl" and (fast := _binary_stl(path, data, fmt, unit)) is not None:
        return fast
    if fmt.file_type == "ply" and (fast := _binary_ply(path, data, fmt, unit)) is not None:
        return fast

    if fmt.file_type == "3mf":  # trimesh reads 3MF with lxml and networkx: the mesh group
        from ..extras import require

        for module in ("lxml", "networkx"):
            require(module, "mesh", "a 3MF model")
    import trimesh

    resolver = _recording_resolver(path)
    # trimesh logs (not raises) what it skips; povh3d reports through its own messages.
    logger = logging.getLogger("trimesh")
    level = logger.level
    logger.setLevel(logging.CRITICAL)
    # OBJ: one part per object (o) and group (g) as well as per material, so that each is its own id
    # in object masks; trimesh merges them by material unless asked.
    split = {"split_objects": True, "split_groups": True} if fmt.file_type == "obj" else {}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            # cast: force="scene" makes trimesh.load return a Scene (typed as any Geometry)
            scene = cast(trimesh.Scene, trimesh.load(str(path), file_type=fmt.file_type, resolver=resolver,
                                                     force="scene", process=False, **split))
            if split and len(scene.geometry) > MAX_SPLIT_PARTS:   # a group per face: by material as before
                scene = cast(trimesh.Scene, trimesh.load(str(path), file_type=fmt.file_type, resolver=resolver,
                                                         force="scene", process=False))
    except Exception as exc:  # trimesh raises anything from ValueError to struct.error on bad bytes
        reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"cannot read {str(path)!r} as {fmt.name}: {reason}") from None
    finally:
        logger.setLevel(level)

    mm = _units(scene, fmt, unit)
    parts: list[Part] = []
    notes: list[str] = []
    for node in scene.graph.nodes_geometry:
        transform, geometry_name = scene.graph[node]
        mesh = scene.geometry[geometry_name]
        if not isinstance(mesh, trimesh.Trimesh):
            notes.append(f"skipped {geometry_name!r}: a {type(mesh).__name__}, not a triangle mesh")
            continue
        faces = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
        vertices = np.asarray(mesh.vertices, dtype=np.float64).reshape(-1, 3)
        if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
            raise InputError(f"{str(path)!r} is corrupt: part {geometry_name!r} has face indices outside "
                             f"its {len(vertices)} vertices")
        normals = np.asarray(mesh._cache["vertex_normals"], dtype=np.float64) \
            if "vertex_normals" in mesh._cache else None  # only normals the file itself carries
        transform = np.asarray(transform, dtype=np.float64)
        if not np.array_equal(transform, np.eye(4)):
            vertices = vertices @ transform[:3, :3].T + transform[:3, 3]
            if normals is not None:
                normals = normals @ np.linalg.inv(transform[:3, :3])  # inverse transpose, row vectors
                with np.errstate(invalid="ignore", divide="ignore"):
                    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
            if np.linalg.det(transform[:3, :3]) < 0:
                faces = faces[:, [0, 2, 1]]  # a mirroring node transform turns the winding around
        extra = _colours(mesh.visual, fmt, len(faces), resolver.missing)
        v, f, n = to_pov_frame(vertices, faces, normals, mm)
        parts.append(Part(name=str(node), vertices=v, faces=f, normals=n, **extra))
    files = [path.resolve(), *dict.fromkeys(resolver.read)]
    return LoadedModel(parts, fmt, files, list(dict.fromkeys(resolver.missing)), mm, notes)

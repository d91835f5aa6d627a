"""View stacks on disk: ``views/v_{l:03d}_{k:03d}.png`` (row l, column k of the
camera bank) with ``views.json``; interleaving a views folder into an H3D image and
extracting one from it."""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import re
import shutil
import tempfile
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import ConfigError, InputError, OutputError, param, plain, raw_message
from ...geometry.axes import to_edge
from ...geometry.lens_array import LensArray
from ...image.elemental import extract_views, view_grid
from ...image.interleave import extract, interleave
from ...image.io import (check_output_folder, check_writable, file_mode, file_sha256, read_png, read_sidecar,
                         read_sidecar_record,
                         with_sidecar, write_png)
from ...system import sweep_orphans
from ...display.display import Display
from ..records import base_record, png_output, write_image
from ...image.sidecar import Sidecar
from ...jsontext import JSONValue

VIEW_NAME = "v_{l:03d}_{k:03d}.png"
_VIEW_RE = re.compile(r"^v_(\d{3,})_(\d{3,})\.png$")


# The views are written into a hidden sibling folder and swapped in whole (``replaced_whole``).
_VIEWS_FILES = ("views.json",)


def _folder_to_replace(folder: str | Path, what: str) -> Path:
    """``folder`` with its parent made; refused in one line where the parent cannot be made or the
    folder is a file."""
    folder = Path(folder)
    try:
        folder.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create {str(folder.parent)!r}: {exc.strerror}") from None
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"{what} {str(folder)!r} is a file; give a folder name")
    return folder


def check_views_dir(views_dir: str | Path) -> Path:
    """Check, before any work, that ``views_dir`` can be written: its parent is writable, and the
    folder is new, empty or holds one views stack (it is replaced whole, so nothing else in it
    may be lost)."""
    folder = _folder_to_replace(views_dir, "the views folder")
    if folder.is_dir():
        others = sorted(p.name for p in folder.iterdir()
                        if not (_VIEW_RE.match(p.name) or p.name in _VIEWS_FILES or p.name.endswith(".part")))
        if others:
            raise OutputError(f"the views folder {str(folder)!r} holds other files ({others[0]!r} ...), and a "
                              "views folder is replaced whole; give a new or empty folder")
    check_writable(folder.parent / f".{folder.name}.write-test")
    return folder


def check_replaced_dir(folder: str | Path, manifest: str, is_ours: Callable[[Mapping[str, JSONValue]], bool],
                       what: str) -> Path:
    """Check, before any work, a folder that is replaced whole (``replaced_whole``): its parent can be
    written, and it is new, empty or one povh3d wrote (its ``manifest`` a JSON object ``is_ours``
    accepts), so that nothing povh3d did not make is deleted."""
    folder = _folder_to_replace(folder, what)
    if folder.is_dir() and any(folder.iterdir()):
        try:
            record = json.loads((folder / manifest).read_text(encoding="utf-8"))
        except (OSError, ValueError, RecursionError):
            record = None
        if not (isinstance(record, dict) and is_ours(record)):
            raise OutputError(f"{what} {str(folder)!r} holds files but no povh3d {manifest}, and it is replaced "
                              "whole; give a new or empty folder")
    check_writable(folder.parent / f".{folder.name}.write-test")
    return folder


def write_views(views_dir: str | Path, views: np.ndarray, lens_array: LensArray | None,
                source: Sidecar | Mapping[str, JSONValue] | None = None) -> None:
    """Write a ``(Ny, Nx, Ly, Lx, C)`` view stack as ``v_{l:03d}_{k:03d}.png`` plus ``views.json``.

    A views folder holds one render, complete, or the previous one untouched: the views and
    ``views.json`` (a render id and each view's SHA-256) are written into a hidden sibling folder,
    which then takes the folder's place by one rename (an exchange).  A lock on the parent folder
    keeps two writers from swapping at once; a kill leaves only the sibling, which the next write
    removes.
    """
    import secrets

    folder = check_views_dir(views_dir)
    ny, nx = views.shape[:2]
    try:
        with replaced_whole(folder, "views") as tmp:
            hashes = {}
            for l in range(ny):
                for k in range(nx):
                    name = VIEW_NAME.format(l=l, k=k)
                    write_png(tmp / name, views[l, k])
                    hashes[name] = file_sha256(tmp / name)
            record = base_record("views", lens_array, views=[nx, ny], view_size_px=[views.shape[3], views.shape[2]],
                                 source=(source.to_json() if isinstance(source, Sidecar) else source) or {},
                                 render_id=secrets.token_hex(8), view_sha256=hashes)
            (tmp / "views.json").write_text(json.dumps(plain(record.to_json()), indent=2) + "\n", encoding="utf-8")
    except OSError as exc:
        raise OutputError(f"cannot write the views in {str(folder)!r}: {exc.strerror or exc}; "
                          "the previous views, if any, are unchanged") from None


@contextlib.contextmanager
def replaced_whole(folder: Path, kind: str) -> Iterator[Path]:
    """A new hidden sibling of ``folder`` to fill; when the block ends without an error it takes
    ``folder``'s place in one rename (an exchange) and the previous folder is removed, so the
    folder holds one output, complete, or the previous one untouched: never old files beside new
    ones.  A lock on the parent keeps two writers from swapping at once; a kill leaves only the
    sibling (``.NAME.KIND-PID-...``), which the next write removes.  ``kind``: ``views``, ``objects``,
    ``depth-maps``."""
    with _parent_lock(folder.parent):
        prefix = f".{folder.name}.{kind}-"
        sweep_orphans(folder.parent, prefix)
        tmp = Path(tempfile.mkdtemp(prefix=f"{prefix}{os.getpid()}-", dir=folder.parent))
        try:
            yield tmp
            for p in (tmp, *tmp.rglob("*")):
                os.chmod(p, 0o777 & ~_umask() if p.is_dir() else file_mode())
            _swap_in(tmp, folder, prefix)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)  # after the swap: the previous folder


def _umask() -> int:
    return 0o666 & ~file_mode()


@contextlib.contextmanager
def _parent_lock(parent: Path) -> Iterator[None]:
    """An exclusive ``flock`` on the views folder's parent, for the time of one swap."""
    fd = os.open(parent, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # closing releases the lock


def _swap_in(new: Path, folder: Path, prefix: str) -> None:
    """Put ``new`` where ``folder`` is, in one step; ``new`` then holds the previous folder."""
    if not folder.exists():
        os.rename(new, folder)
        return
    if _exchange(new, folder):
        return
    # No RENAME_EXCHANGE (an old kernel, a file system without it): two renames, the old kept aside.
    aside = Path(tempfile.mkdtemp(prefix=f"{prefix}{os.getpid()}-", dir=folder.parent))
    os.rmdir(aside)
    os.rename(folder, aside)
    os.rename(new, folder)
    os.rename(aside, new)


def _exchange(a: Path, b: Path) -> bool:
    """``renameat2(a, b, RENAME_EXCHANGE)``: swap two paths atomically (Linux >= 3.15)."""
    import ctypes

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd, rename_exchange = -100, 2
    if renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    if ctypes.get_errno() in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP):
        return False
    raise OSError(ctypes.get_errno(), os.strerror(ctypes.get_errno()), str(b))


def _view_files(folder: Path) -> dict[tuple[int, int], Path]:
    found = {}
    for p in folder.iterdir():
        m = _VIEW_RE.match(p.name)
        if m:
            found[(int(m.group(1)), int(m.group(2)))] = p
    return found


def read_views(views_dir: str | Path) -> np.ndarray:
    """Read ``v_{l}_{k}.png`` files into a ``(Ny, Nx, Ly, Lx, C)`` stack; every view must be there.

    With a ``views.json`` that lists each view's SHA-256 (povh3d writes one), every view must be
    one of that render's: a folder whose views belong to two renders is refused.
    """
    folder = Path(views_dir)
    if not folder.is_dir():
        raise InputError(f"views folder {str(folder)!r} does not exist; check the path")
    found = _view_files(folder)
    if not found:
        raise InputError(f"no view images (v_LLL_KKK.png) in {str(folder)!r}; render with {param('views_dir')} first")
    ny = max(l for l, _ in found) + 1
    nx = max(k for _, k in found) + 1
    absent = [(l, k) for l in range(ny) for k in range(nx) if (l, k) not in found]
    if absent:
        l, k = absent[0]
        raise InputError(f"{len(absent)} views missing in {str(folder)!r}, first {VIEW_NAME.format(l=l, k=k)}; "
                         "the stack must be a full Ny x Nx grid")
    manifest = _manifest(folder)
    grid = manifest.get("views")
    if grid is not None and list(grid) != [nx, ny]:
        raise InputError(f"{str(folder)!r} holds {nx}x{ny} views but its views.json describes {grid[0]}x{grid[1]}: "
                         "views of two renders are mixed; render again into an empty folder")
    _check_one_render(folder, found, manifest.get("view_sha256"))
    images = [read_png(found[(l, k)]) for l in range(ny) for k in range(nx)]
    shapes = {img.shape for img in images}
    if len(shapes) != 1:
        raise InputError(f"the views in {str(folder)!r} differ in size or channels: {sorted(shapes)}")
    size = manifest.get("view_size_px")
    if size is not None and images and list(size) != to_edge(images[0].shape[:2]):
        raise InputError(f"the views in {str(folder)!r} are {images[0].shape[1]}x{images[0].shape[0]} but views.json "
                         f"describes {size[0]}x{size[1]}; render again into an empty folder")
    dtypes = {img.dtype for img in images}
    if len(dtypes) != 1:
        raise InputError(f"the views in {str(folder)!r} mix 8-bit and 16-bit images")
    return np.stack(images).reshape(ny, nx, *images[0].shape)


def _manifest(folder: Path) -> dict[str, Any]:
    """``views.json`` ({} without one), its fields checked: a damaged one is one ``InputError``."""
    manifest = read_sidecar(folder / "views.json") or {}
    bad = InputError(f"the views.json of {str(folder)!r} is damaged; render the views again "
                     "(or delete views.json to interleave the views as they are)")
    for key in ("views", "view_size_px"):
        value = manifest.get(key)
        if value is not None and not (isinstance(value, list) and len(value) == 2
                                      and all(isinstance(v, int) and not isinstance(v, bool) for v in value)):
            raise bad
    hashes = manifest.get("view_sha256")
    if hashes is not None and not (isinstance(hashes, dict) and all(isinstance(v, str) for v in hashes.values())):
        raise bad
    if manifest.get("lens_array") is not None and not isinstance(manifest["lens_array"], dict):
        raise bad
    return manifest


def _check_one_render(folder: Path, found: dict[tuple[int, int], Path], hashes: dict[str, str] | None) -> None:
    if hashes is None:
        return  # a folder of views made by hand, or by an older povh3d
    names = {p.name for p in found.values()}
    if names != set(hashes):
        extra = sorted(names ^ set(hashes))
        raise InputError(f"the views in {str(folder)!r} are not those its views.json lists ({extra[0]} ...): "
                         "views of two renders are mixed; render again into an empty folder")
    for path in found.values():
        if file_sha256(path) != hashes[path.name]:
            raise InputError(f"{path.name} in {str(folder)!r} is not the view its views.json lists (it was "
                             "replaced): views of two renders are mixed; render again into an empty folder")


def interleave_dir(views_dir: str | Path, output: str | Path) -> dict[str, Any]:
    """Interleave a folder of views into an H3D PNG with its sidecar."""
    folder = Path(views_dir)
    output = png_output(output, inputs=[*folder.iterdir()] if folder.is_dir() else ())
    views = read_views(views_dir)
    h3d = interleave(views)
    source = _manifest(Path(views_dir))
    record = base_record("h3d", None, method="interleave", views=to_edge(views.shape[:2]),
                      views_dir=str(Path(views_dir).resolve()), size_px=to_edge(h3d.shape[:2]),
                      output_gamma="sRGB")
    if source.get("lens_array"):
        Display.from_record(source)  # a damaged lens array is one line here, not a bad sidecar later
        record = record.with_(lens_array=source["lens_array"])
    write_image(output, h3d, record)
    return record.to_json()


def extract_file(h3d_path: str | Path, ppl: tuple[int, int] | None, views_dir: str | Path) -> dict[str, Any]:
    """Extract the view stack of an H3D PNG into ``views_dir``; ``ppl`` is ``(Ny, Nx)``.

    Without ``ppl`` the lens array comes from the image's sidecar; a hex or
    fractional-PPL array is resampled lens by lens (``elemental.extract_views``)
    and ``views.json`` records the lens centres used.
    """
    check_output_folder(views_dir, with_sidecar(h3d_path), what="views folder")
    check_views_dir(views_dir)
    h3d = read_png(h3d_path)
    if ppl is None:
        return _extract_resampled(h3d, h3d_path, views_dir)
    try:
        views = extract(h3d, ppl)
    except ValueError as exc:
        raise ConfigError(raw_message(exc)) from None
    write_views(views_dir, views, None, {"h3d": str(Path(h3d_path).resolve())})
    return {"views": to_edge(ppl), "view_size_px": to_edge(views.shape[2:4])}


def sidecar_array(h3d: np.ndarray, h3d_path: str | Path, record: Sidecar | None = None) -> LensArray:
    """The lens array of an H3D image's sidecar (``record``, else read), checked against the image's size."""
    record = read_sidecar_record(h3d_path) if record is None else record
    if record is None or record.lens_array is None:
        raise ConfigError(f"{str(h3d_path)!r} has no sidecar with its lens array; give {param('ppl')} NxxNy")
    lens_array = Display.from_record(record.to_json()).lens_array
    if h3d.shape[:2] != (lens_array.panel.height, lens_array.panel.width):
        raise InputError(f"{str(h3d_path)!r} is {h3d.shape[1]}x{h3d.shape[0]} but its sidecar describes a "
                         f"{lens_array.panel.width}x{lens_array.panel.height} panel; re-render it")
    return lens_array


def sidecar_bank(h3d: np.ndarray, lens_array: LensArray) -> np.ndarray:
    """``(Ny, Nx, Ly, Lx, C)`` views of an image of ``lens_array``: the camera bank's region
    (an array narrower than its panel, e.g. 341 lenses of 6 px on 2048 px), or each lens
    resampled at the view offsets on a hex or fractional-PPL array."""
    if lens_array.views is None:
        return extract_views(h3d, lens_array, view_grid(lens_array))
    return extract(h3d[lens_array.bank_region], lens_array.views)


def image_views(h3d: np.ndarray, lens_array: LensArray) -> np.ndarray:
    """``(Ny, Nx, Ly, Lx, C)`` views of an image of ``lens_array`` (the Python API's): the whole
    panel as ``extract`` reads it (``sidecar_bank``: hex and fractional PPL resampled), or, on a
    camera bank, an image of whole lenses (the bank's region, or any whole number of them)."""
    panel = lens_array.panel
    if h3d.shape[:2] == (panel.height, panel.width):
        return sidecar_bank(h3d, lens_array)
    if lens_array.views is None:
        raise ConfigError(f"the image is {h3d.shape[1]}x{h3d.shape[0]} but its {lens_array.grid} lens array's "
                          f"panel is {panel.width}x{panel.height}; pass the image and lens array read_h3d gives")
    try:
        return extract(h3d, lens_array.views)
    except ValueError as exc:
        raise ConfigError(raw_message(exc)) from None


def h3d_views(h3d: np.ndarray, record: Sidecar | None, h3d_path: str | Path) -> tuple[np.ndarray, str]:
    """The ``(Ny, Nx, Ly, Lx, C)`` views of an H3D image through its sidecar's lens array, and its grid."""
    lens_array = sidecar_array(h3d, h3d_path, record)
    return sidecar_bank(h3d, lens_array), lens_array.grid


def _extract_resampled(h3d: np.ndarray, h3d_path: str | Path, views_dir: str | Path) -> dict[str, Any]:
    lens_array = sidecar_array(h3d, h3d_path)
    views = sidecar_bank(h3d, lens_array)
    ny, nx = views.shape[:2]
    source: dict[str, JSONValue] = {"h3d": str(Path(h3d_path).resolve()), "resampled": lens_array.views is None,
              "lens_centres_mm": lens_array.lens_centres().reshape(-1, 2).tolist()}
    write_views(views_dir, views, lens_array, source)
    return {"views": [nx, ny], "view_size_px": [views.shape[3], views.shape[2]]}

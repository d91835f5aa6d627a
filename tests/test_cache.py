"""The one cache module (povh3d/cache.py) and its damage policy, over every cache kind.

Each kind makes its entry through the code that owns it, then the entry is damaged
(truncated, its header replaced, its body changed at the same length: only the hash
tells) and read again through the same code: a miss, one "damaged" warning, the
entry removed and stored again whole, never an error."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from povh3d import cache
from povh3d.errors import InputError, Povh3dWarning
from tests.support.gallery_meshes import tower_ply

GALLERY = Path(__file__).resolve().parent / "support" / "gallery"


def _array():
    from povh3d.geometry.lens_array import LensArray, Panel

    return LensArray(grid="square", lenses_x=24, lenses_y=18, pitch_x=1.2, pitch_y=1.2, focal=2.0,
                     panel=Panel(144, 108, 0.2, 0.2))


# -- one reader per kind: make or read the entry, return whether it came from the cache ---------------
def _frame(root: Path) -> bool:
    from povh3d.renderer.shots.cache import ImageCache
    from povh3d.image.io import write_png

    images = ImageCache(root)
    if images.load("ab" * 32) is not None:
        return True
    source = root.parent / "frame.png"
    write_png(source, np.full((4, 6, 3), 7, np.uint8))
    images.store("ab" * 32, source)
    return False


def _frame_ppm(root: Path) -> bool:
    """A shot as POV-Ray writes it now (a PPM, ``image.ppm``), stored as it is; it reads back whole."""
    from povh3d.renderer.shots.cache import ImageCache
    from povh3d.image.ppm import encode_ppm

    images, image = ImageCache(root), np.arange(4 * 6 * 3, dtype=np.uint16).reshape(4, 6, 3) * 999
    found = images.load("ef" * 32)
    if found is not None:
        assert found.dtype == np.uint16 and np.array_equal(found, image)
        return True
    source = root.parent / "frame.ppm"
    source.write_bytes(encode_ppm(image))
    images.store("ef" * 32, source)
    return False


def _output(root: Path) -> bool:
    from povh3d.renderer import output_cache
    from povh3d.image.io import write_image_pair

    out = root.parent / "o.png"
    if output_cache.answer("cd" * 32, out, root) is not None:
        return True
    write_image_pair(out, np.full((4, 6, 3), 9, np.uint8), {"timings": {}})
    output_cache.keep("cd" * 32, out, "summary", [], root)
    return False


def _camera(root: Path) -> bool:
    from povh3d.renderer.placement.pose import PlacementOptions, resolve_pose
    from povh3d.scene.scene import load_scene

    _, record = resolve_pose(PlacementOptions(mode="camera"), load_scene(GALLERY / "inches.pov"), _array(),
                              cache_dir=root)
    return bool(record["evaluation_from_cache"])


def _camera_depth(root: Path) -> bool:
    from povh3d.renderer.placement.pose import PlacementOptions, resolve_pose_and_depth
    from povh3d.scene.scene import load_scene

    _, record, seen = resolve_pose_and_depth(PlacementOptions(), load_scene(GALLERY / "tilted.pov"), _array(),
                                              cache_dir=root, front_clearance=80.0)
    assert seen is not None
    return bool(record["evaluation_from_cache"])


def _mesh(root: Path) -> bool:
    from povh3d.renderer.content.model import cached_include

    folder = root.parent / "model"
    folder.mkdir(exist_ok=True)
    _, manifest = cached_include(tower_ply(folder), cache_dir=root)
    return bool(manifest["from_cache"])


def _volume(root: Path) -> bool:
    from povh3d.renderer.request import VolumeOptions
    from povh3d.renderer.content.volume import cached_surfaces, volume_digest
    from tests.support.volumes import asymmetric_phantom

    volume = asymmetric_phantom()
    options = VolumeOptions(labels="all")
    _, manifest = cached_surfaces(volume, volume_digest(volume), "labels", options, np.eye(3), 2000, root)
    return bool(manifest["from_cache"])


KINDS: dict[str, Callable[[Path], bool]] = {
    "frame": _frame, "frame-ppm": _frame_ppm, "output": _output, "camera": _camera, "camera-depth": _camera_depth,
    "mesh": _mesh, "volume": _volume,
}


def _damage(path: Path, how: str) -> None:
    data = path.read_bytes()
    if how == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif how == "wrong-header":
        path.write_bytes(b"not a povh3d entry\n" + data.partition(b"\n")[2])
    else:  # same size, body changed: only the hash can tell
        path.write_bytes(data[:-20] + bytes(b ^ 0xFF for b in data[-20:]))


@pytest.mark.parametrize("how", ["truncated", "wrong-header", "wrong-hash"])
@pytest.mark.parametrize("kind", [pytest.param(k, marks=pytest.mark.povray) if k.startswith("camera") else k
                                  for k in sorted(KINDS)])  # the camera entries are made by POV-Ray
def test_a_damaged_entry_is_a_miss_removed_and_made_again(tmp_path, kind, how):
    root, read = tmp_path / "cache", KINDS[kind]
    assert read(root) is False
    entries = [p for p in root.rglob("*") if p.is_file() and p.suffix in (".entry", ".output", ".camera")]
    assert len(entries) == 1, entries
    (entry,) = entries
    _damage(entry, how)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert read(root) is False   # a miss, not an error
    said = [str(w.message) for w in caught if issubclass(w.category, Povh3dWarning)]
    assert len(said) == 1 and "damaged" in said[0], said
    assert read(root) is True        # stored again, whole


def test_the_header_check_refuses_what_it_must():  # negative controls of the entry check
    data = cache.frame_body("k" * 64, b"body")
    assert cache.entry_body("k" * 64, data) == b"body"
    for wrong in (data[:-1], data + b"x", data.replace(b"povh3d", b"povh4d"), b""):
        with pytest.raises(InputError):
            cache.entry_body("k" * 64, wrong)
    with pytest.raises(InputError, match="another key"):
        cache.entry_body("j" * 64, data)


def test_content_key_is_canonical():
    assert cache.content_key({"a": 1, "b": 2.5}) == cache.content_key({"b": 2.5, "a": 1})
    assert cache.content_key(0.1 + 0.2) != cache.content_key(0.3)


def test_a_damaged_media_file_is_written_again(tmp_path):
    """The df3 of a volume medium is named by its content and reused: a same-size damaged one is
    found by its hash and written again, never handed to POV-Ray."""
    from povh3d.renderer.content.volume_media import media_stage
    from tests.support.volumes import asymmetric_phantom

    volume = asymmetric_phantom()
    media_stage(volume, np.eye(4), _array(), transfer="labels", folder=tmp_path)
    (df3,) = tmp_path.glob("*.df3")
    good = df3.read_bytes()
    df3.write_bytes(good[:-20] + bytes(b ^ 0xFF for b in good[-20:]))
    media_stage(volume, np.eye(4), _array(), transfer="labels", folder=tmp_path)
    assert df3.read_bytes() == good


@pytest.mark.povray
def test_a_damaged_camera_entry_is_a_warning_not_an_internal_error(tmp_path, cli):
    """From the command line: a damaged camera entry was ``internal error``, exit 70."""
    env = {"POVH3D_CACHE": str(tmp_path / "cache")}
    args = ("--preset", "demo", "--lenses", "6x4", "--ppl", "4", "--quality", "draft", "-q")
    assert cli("render", GALLERY / "tilted.pov", "-o", tmp_path / "a.png", *args, env=env).code == 0
    (entry,) = (tmp_path / "cache" / "cameras").rglob("*.camera")
    _damage(entry, "truncated")
    result = cli("render", GALLERY / "tilted.pov", "-o", tmp_path / "b.png", *args, env=env)
    assert result.code == 0, result.err
    assert "damaged" in result.err and "internal error" not in result.err


@pytest.mark.parametrize("order", ["C", "F"])
def test_volume_digest_sees_every_voxel_and_the_geometry(order):
    # The volume cache's data key, hashed in the voxels' own memory order (no C-ordered copy of a
    # Fortran-ordered volume): equal volumes agree, a change of one voxel or of the spacing does not.
    from povh3d.renderer.content.volume import volume_digest
    from povh3d.volume.grid import Volume
    from tests.support.volumes import asymmetric_phantom

    phantom = asymmetric_phantom()
    values = np.array(phantom.values, order=order)
    digest = volume_digest(Volume(values, phantom.spacing))
    assert digest == volume_digest(Volume(np.array(values, order=order), phantom.spacing))
    changed = values.copy(order=order)
    changed[23, 19, 15] = 2           # the last voxel in either order
    assert volume_digest(Volume(changed, phantom.spacing)) != digest
    changed = values.copy(order=order)
    changed[0, 0, 1] = 2
    assert volume_digest(Volume(changed, phantom.spacing)) != digest
    assert volume_digest(Volume(values, (1.0, 1.5, 2.5))) != digest
    # A view that is neither order is hashed through a copy: the same voxels, the same key as C order.
    every_other = np.zeros((24, 20, 32), dtype=values.dtype)
    every_other[:, :, ::2] = values
    view = every_other[:, :, ::2]
    assert not (view.flags.c_contiguous or view.flags.f_contiguous)
    assert volume_digest(Volume(view, phantom.spacing)) == volume_digest(Volume(np.ascontiguousarray(values),
                                                                              phantom.spacing))


def test_code_stamp_follows_the_code() -> None:
    """A source file touched gives another stamp; nothing touched, the same (the control)."""
    import os

    from povh3d import cache

    source = Path(cache.__file__).resolve().parent / "_version.py"
    before = os.stat(source)
    first = cache.code_stamp.__wrapped__()
    assert cache.code_stamp.__wrapped__() == first
    try:
        os.utime(source, ns=(before.st_atime_ns, before.st_mtime_ns + 1000))
        assert cache.code_stamp.__wrapped__() != first
    finally:
        os.utime(source, ns=(before.st_atime_ns, before.st_mtime_ns))


@pytest.mark.povray
def test_a_scene_cameras_evaluation_made_by_other_code_is_not_read(tmp_path: Path, monkeypatch) -> None:
    """The camera evaluation's entry is keyed by the code too: a depth pass whose POV-Ray options
    changed (a still's clock) must not come back from an older povh3d's cache."""
    from povh3d import cache
    from povh3d.renderer.passes.scene_camera import evaluate_camera
    from povh3d.display.presets import lens_array
    from povh3d.scene.camera_script import camera_script
    from povh3d.scene.scene import load_scene

    path = tmp_path / "s.pov"
    path.write_text("#version 3.7;\ncamera { location <0, 0, -5> look_at 0 }\nsphere { 0, 1 pigment { rgb 1 } }\n")
    scene, array = load_scene(path), lens_array("demo")
    script = camera_script(path.read_text(), scene.include_text)

    def cached() -> bool:
        return evaluate_camera(scene, script.script, array, script.cameras, tmp_path / "cache", True, script.lines)[2]

    assert not cached() and cached()   # the control: the same code reads its own entry
    monkeypatch.setattr(cache, "code_stamp", lambda: "other code")
    assert not cached()

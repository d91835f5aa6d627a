"""The inside-solid pass run beside the fallback's views (``renderer.render._settled_beside``): the image and
the sidecar are those of the pass run first, whichever method the pass finds, and a caller's cancel stops
both the views and the pass."""

from __future__ import annotations

import json
import threading
from pathlib import Path

import pytest

from povh3d.display.display import Display
from povh3d.errors import RenderCancelled
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.renderer.request import RenderRequest

SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
camera {{ location <0, 1, -10> angle 40 right x * image_width / image_height look_at <0, 0.3, 0> }}
light_source {{ <5, 10, -20> rgb 1 }}
plane {{ y, 0 pigment {{ checker rgb 1 rgb 0.2 }} {hollow} }}
sphere {{ <0, 1, 0>, 1 pigment {{ rgb <1, 0.2, 0.1> }} }}
fog {{ rgb <0.6, 0.7, 0.9> distance 30 }}
"""

#: What differs between two renders of one request: when and how long.
_TIMES = ("timings", "passes", "render_id", "total_seconds", "render_seconds")


def _array() -> LensArray:
    return LensArray(grid="square", lenses_x=16, lenses_y=12, pitch_x=0.6, pitch_y=0.6, focal=2.0,
                     panel=Panel(48, 36, 0.2, 0.2))   # 3x3 views


def _render(tmp_path: Path, name: str, hollow: str, settings: RenderSettings | None = None,
            depth_maps: bool = False) -> tuple[bytes, dict]:
    from povh3d.renderer.render import render

    scene = tmp_path / f"{name}.pov"
    scene.write_text(SCENE.format(hollow=hollow))
    out = tmp_path / f"{name}.png"
    render(RenderRequest(source=scene, display=Display(_array()), output=out, method_chosen=False,
                         settings=settings or RenderSettings(quality="draft", use_cache=False),
                         depth_maps=tmp_path / f"{name}-maps" if depth_maps else None))
    return out.read_bytes(), json.loads(out.with_suffix(".json").read_text())


def _same_but_times(a: dict, b: dict) -> None:
    for record in (a, b):
        for key in _TIMES:
            record.pop(key, None)
        for key in ("image_sha256", "scene", "scene_sha256"):   # the two scenes' files have their own names
            record.pop(key, None)
        record["placement"].pop("evaluation_seconds")
    assert a == b
    assert list(a) == list(b) and list(a["placement"]) == list(b["placement"])   # the same keys, the same order


@pytest.mark.povray
@pytest.mark.parametrize("hollow, method", [("", "multi-ortho-views"), ("hollow", "multi-ortho")])
def test_the_pass_beside_the_views_gives_the_image_and_sidecar_of_the_pass_first(tmp_path, monkeypatch, hollow, method):
    """A solid ground the lower rays start below: the fallback's views, as when the pass runs first; a hollow
    one: the pass finds the mesh camera right, whose image it is, as when the pass runs first (the control of
    each is the other: the two images differ)."""
    import povh3d.renderer.render as render_module

    image, beside = _render(tmp_path, "beside", hollow)
    monkeypatch.setattr(render_module, "fallback_beside_pass", lambda *args: False)   # the pass first
    first_image, first = _render(tmp_path, "first", hollow)
    assert beside["method"] == first["method"] == method
    assert [(p["name"], p.get("beside")) for p in beside["passes"]][-1] == ("origins-inside", True)
    assert [(p["name"], p.get("beside")) for p in first["passes"]][-1] == ("origins-inside", None)
    assert image == first_image
    _same_but_times(beside, first)


@pytest.mark.povray
def test_the_two_methods_differ_on_this_scene(tmp_path, monkeypatch):
    """The control of the test above: the views and the mesh camera, forced past the check, give different
    images of the solid ground's scene (its fog), so an image from the wrong method would be caught."""
    import povh3d.renderer.render as render_module

    views, record = _render(tmp_path, "views", "")
    assert record["method"] == "multi-ortho-views"
    monkeypatch.setattr(render_module, "fallback_beside_pass", lambda *args: False)
    monkeypatch.setattr(render_module, "settle_method", lambda request, scene, progress=None: (request, None))
    mesh, record = _render(tmp_path, "mesh", "")
    assert record["method"] == "multi-ortho" and mesh != views


@pytest.mark.povray
@pytest.mark.parametrize("hollow", ["", "hollow"])
def test_depth_maps_follow_the_method_the_pass_finds(tmp_path, monkeypatch, hollow):
    """With depth maps, the maps' pass runs beside whichever render is kept (the views', or the mesh camera's
    after the views were stopped): the maps of the pass run first, to the bit."""
    import numpy as np

    import povh3d.renderer.render as render_module

    _, beside = _render(tmp_path, "beside", hollow, depth_maps=True)
    monkeypatch.setattr(render_module, "fallback_beside_pass", lambda *args: False)
    _, first = _render(tmp_path, "first", hollow, depth_maps=True)
    maps = [np.stack([np.load(p) for p in sorted((tmp_path / f"{n}-maps").glob("d_*.npy"))]) for n in ("beside", "first")]
    assert beside["method"] == first["method"] and maps[0].shape == (9, 12, 16)
    np.testing.assert_array_equal(*maps)
    assert beside["quality"]["front_clearance_mm"] == first["quality"]["front_clearance_mm"]


@pytest.mark.povray
def test_a_cancel_stops_the_views_and_the_pass(tmp_path):
    """A caller's ``should_stop`` while the views and the pass run: the cancel, and no POV-Ray or thread left."""
    from povh3d.renderer.render import render

    from ..povray.test_process import povray_children

    scene = tmp_path / "s.pov"
    scene.write_text("#declare T = 0; #while (T < 3000000) #declare T = T + 1; #end\n" + SCENE.format(hollow=""))
    stop = threading.Event()
    threading.Timer(0.8, stop.set).start()
    with pytest.raises(RenderCancelled):
        render(RenderRequest(source=scene, display=Display(_array()), output=tmp_path / "s.png", method_chosen=False,
                             settings=RenderSettings(quality="draft", use_cache=False, should_stop=stop.is_set)))
    assert povray_children() == []
    assert not [t for t in threading.enumerate() if t.name == "povh3d-beside"]
    assert not (tmp_path / "s.png").exists()

"""The depth maps' pass run beside the render (``renderer.passes.beside``): the same maps as the pass
run after it, its cost said in the sidecar, and no POV-Ray or thread left when the render fails."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np
import pytest

from povh3d.errors import PovrayError
from povh3d.geometry.lens_array import LensArray, Panel

from ..povray.test_process import povray_children

SCENE = """#version 3.7;
global_settings { assumed_gamma 1 }
light_source { <5, 10, -20> rgb 1 }
plane { z, 6 pigment { checker rgb 1 rgb 0.2 scale 0.5 } hollow }
sphere { <0.5, 0.3, 1>, 1 pigment { rgb <1, 0.2, 0.1> } }
"""


def _array() -> LensArray:
    return LensArray(grid="square", lenses_x=16, lenses_y=12, pitch_x=0.6, pitch_y=0.6, focal=2.0,
                     panel=Panel(48, 36, 0.2, 0.2))   # 3x3 views


def _maps(folder: Path) -> np.ndarray:
    return np.stack([np.load(p) for p in sorted(folder.glob("d_*.npy"))])


@pytest.mark.povray
def test_depth_maps_beside_the_render_equal_the_pass_run_after_it(tmp_path, monkeypatch):
    """Cross-check: the maps of the pass run beside the render are those of the pass run after it, to the
    bit; the sidecar says which ran beside (the pass run after it, the control, does not say so)."""
    import povh3d
    import povh3d.renderer.render as render_module

    scene = tmp_path / "s.pov"
    scene.write_text(SCENE)

    def run(name: str) -> tuple[np.ndarray, list[dict]]:
        record = povh3d.render(scene, tmp_path / f"{name}.png", lens_array=_array(), quality="draft", use_cache=False,
                               depth_maps=tmp_path / name)
        return _maps(tmp_path / name), record["passes"]

    beside, passes = run("beside")
    monkeypatch.setattr(render_module, "depth_beside", lambda *args: None)   # the pass after the render
    after, control = run("after")
    assert beside.shape == (9, 12, 16) and np.isfinite(beside).mean() > 0.9
    np.testing.assert_array_equal(beside, after)
    assert [(p["name"], p.get("beside")) for p in passes] == [("depth-maps", True)], passes
    assert [(p["name"], p.get("beside")) for p in control] == [("depth-maps", None)], control


@pytest.mark.povray
def test_a_failed_render_stops_the_pass_beside_it(tmp_path, monkeypatch):
    """The render fails while the depth pass still parses (a scene of about 4 s of parse): the error comes
    at once, and no POV-Ray run and no thread of the pass is left; the control waits for the pass."""
    import povh3d
    import povh3d.renderer.methods.registry as registry

    scene = tmp_path / "slow.pov"
    scene.write_text("#declare T = 0; #while (T < 6000000) #declare T = T + 1; #end\n" + SCENE)

    def failing(*args, **kwargs):
        time.sleep(0.5)
        raise PovrayError("the render's own run failed")

    monkeypatch.setattr(registry, "render_shots", failing)
    start = time.perf_counter()
    with pytest.raises(PovrayError, match="the render's own run failed"):
        povh3d.render(scene, tmp_path / "o.png", lens_array=_array(), quality="draft", use_cache=False,
                      depth_maps=tmp_path / "maps")
    failed = time.perf_counter() - start
    assert povray_children() == []
    assert not [t for t in threading.enumerate() if t.name == "povh3d-beside"]
    assert not (tmp_path / "maps").exists() and not (tmp_path / "o.png").exists()
    # the control: the pass alone, run to its end, takes far longer than the failed render took
    from povh3d.renderer.methods.quality import RenderSettings
    from povh3d.renderer.passes.depth import view_depth_maps
    from povh3d.scene.scene import load_scene

    start = time.perf_counter()
    view_depth_maps(load_scene(scene), _array(), RenderSettings(quality="draft", use_cache=False), 20.0, 1.0)
    assert failed < 0.5 * (time.perf_counter() - start) + 0.5

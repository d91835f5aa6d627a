"""Golden POV-Ray text for every method's template on a tiny lens array.

Regenerate after an intended template change with:
    POVH3D_REGEN_GOLDEN=1 .venv/bin/python -m pytest tests/povray/test_templates.py
and review the diff of tests/golden/.
"""

import os
from pathlib import Path

import pytest

from povh3d.geometry.footprint import CENTRE
from povh3d.renderer.methods.registry import METHODS, display_header
from povh3d.renderer.shots.shots import build_script

from povh3d.geometry.lens_array import LensArray, Panel

from tests.support.arrays import square_array

GOLDEN = Path(__file__).resolve().parents[1] / "golden"  # tests/golden/


@pytest.mark.parametrize("name", list(METHODS))
def test_script_matches_golden(name):
    # subpixel renders lenticular sheets only: a slanted one.
    la = (LensArray("lenticular", 3, 2, 0.5, 0.25, 1.5, Panel(4, 2, 0.25, 0.25), 9.46) if name == "subpixel"
          else square_array(lx=2, ly=2, nx=2, ny=2, s=0.25, f=1.5))
    batch = METHODS[name].plan(la, 10.0, CENTRE, **METHODS[name].options).batch
    script = build_script(batch, batch.shots, method=name, scene_path="/scenes/tiny.pov",
                          add_assumed_gamma=True, header=display_header(la))
    script = script.replace(script.splitlines()[0], "// header line")  # carries the version
    path = GOLDEN / f"{name}.pov"
    if os.environ.get("POVH3D_REGEN_GOLDEN"):
        path.write_text(script)
    assert script == path.read_text()


def test_numbers_in_scripts_round_trip():
    la = square_array(lx=3, ly=1, nx=3, ny=1, s=0.1, f=1.7)
    batch = METHODS["multi-ortho-views"].plan(la, 10.0, CENTRE).batch
    script = build_script(batch, batch.shots, method="x", scene_path="/s.pov", add_assumed_gamma=False,
                          header=display_header(la))
    # u/f for the right view, written with repr: reads back as the same double
    assert repr(0.1 / 1.7) in script
    assert "assumed_gamma" not in script


def test_scene_with_quote_in_path_is_refused():
    from povh3d.errors import ConfigError
    la = square_array(lx=2, ly=1, nx=1, ny=1)  # POV-Ray needs two pixels across a mesh camera
    batch = METHODS["multi-ortho"].plan(la, 10.0, CENTRE).batch
    with pytest.raises(ConfigError, match="rename"):
        build_script(batch, batch.shots, method="x", scene_path='/a"b.pov', add_assumed_gamma=True,
                     header=display_header(la))

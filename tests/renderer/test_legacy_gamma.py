"""A scene written for an older POV-Ray language (``#version 3.6;``) without ``assumed_gamma``: POV-Ray 3.7
turns gamma correction off for it, and povh3d's header must leave it so (``incdemo/woods/teak.pov`` came
out 11 dB from plain POV-Ray).  Oracle: a plain ``povray`` render of the same scene text."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.povray

# A flat grey plane filling every view: its pixel value is the gamma handling, nothing else.
BODY = "plane { z, 0 pigment { rgb 0.5 } finish { ambient 1 diffuse 0 } }\n"


def _plain_value(scene: Path, tmp_path: Path) -> np.ndarray:
    """The plane's colour in a plain POV-Ray render of the scene's text with a camera of its own."""
    script = tmp_path / f"plain_{scene.stem}.pov"
    script.write_text(scene.read_text() + "camera { location <0, 0, -10> look_at 0 }\n")
    out = tmp_path / f"plain_{scene.stem}.png"
    subprocess.run(["povray", f"+I{script}", f"+O{out}", "+W8", "+H8", "-A", "-D"], check=True,
                   capture_output=True)
    from povh3d.image.io import read_png

    image = read_png(out)[..., :3].astype(float) / (65535 if read_png(out).dtype == np.uint16 else 255)
    return image.reshape(-1, 3).mean(axis=0)


def _povh3d_values(scene: Path, tmp_path: Path) -> np.ndarray:
    import povh3d
    from povh3d.geometry.lens_array import LensArray, Panel
    from povh3d.image.io import read_png

    array = LensArray("square", 4, 3, 1.0, 1.0, 2.0, Panel(16, 12, 0.25, 0.25))
    out = tmp_path / f"h3d_{scene.stem}.png"
    povh3d.render(scene, out, lens_array=array, quality="draft", use_cache=False)
    image = read_png(out)
    return image[..., :3].astype(float).reshape(-1, 3) / (65535 if image.dtype == np.uint16 else 255)


@pytest.mark.parametrize("version", ["3.6", "3.7"])
def test_every_pixel_has_plain_povrays_colour(tmp_path: Path, version: str) -> None:
    scene = tmp_path / f"v{version.replace('.', '')}.pov"
    scene.write_text(f"#version {version};\n" + BODY)
    plain = _plain_value(scene, tmp_path)
    # the oracle tells the two languages apart: 0.5 written as is (128/255), or encoded to sRGB (188/255)
    assert abs(plain[0] - (0.5 if version == "3.6" else 0.735)) < 0.01
    assert np.abs(_povh3d_values(scene, tmp_path) - plain).max() < 1 / 255


def test_control_a_header_that_adds_assumed_gamma_brightens_an_old_scene(tmp_path: Path, monkeypatch) -> None:
    """Negative control: the header's old rule (add assumed_gamma 1.0 wherever the scene sets none)."""
    from povh3d.scene.scene import Scene

    monkeypatch.setattr(Scene, "adds_assumed_gamma", property(lambda self: not self.sets_assumed_gamma))
    scene = tmp_path / "v36.pov"
    scene.write_text("#version 3.6;\n" + BODY)
    assert np.abs(_povh3d_values(scene, tmp_path) - _plain_value(scene, tmp_path)).max() > 0.2


def test_the_scenes_first_version_decides(tmp_path: Path) -> None:
    from povh3d.scene.scene import load_scene

    cases = {"#version 3.6;\n": False, "#version 3.7;\n": True, "": True, "// #version 3.5;\n#version 3.7;\n": True,
             "#version 3.5;\nglobal_settings { assumed_gamma 2.2 }\n": False}
    for head, adds in cases.items():
        path = tmp_path / "s.pov"
        path.write_text(head + BODY)
        assert load_scene(path).adds_assumed_gamma is adds, head

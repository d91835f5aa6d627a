"""Features a scene uses, and the header povh3d writes for it: nothing the scene does not need."""

from __future__ import annotations

import re

import pytest

from povh3d.renderer.methods.quality import QUALITY_LEVELS, Quality

from povh3d.scene.features import FEATURE_WORDS, SETTING_NEEDS, features_of_text, needed_settings
from povh3d.renderer.methods.quality import quality_settings
from povh3d.renderer.methods.registry import display_header
from povh3d.renderer.shots.shots import build_script, ShotBatch
from povh3d.scene.scene import load_scene

from tests.support.arrays import square_array

PLAIN = """#version 3.7;
global_settings { assumed_gamma 1.0 }
background { rgb 0.1 }
light_source { <-10, 10, -20> rgb 1 }
sphere { <0, 0, 2>, 1 pigment { rgb <1, 0.5, 0.2> } finish { specular 0.3 } }
// a comment naming radiosity, photons, media and fog does not count
/* nor does reflection { 0.5 } in a block comment */
"""

# One snippet per feature: what a scene that uses it contains.
USES = {
    "radiosity": "global_settings { radiosity { count 50 } }",
    "photons": "global_settings { photons { count 1000 } }",
    "media": "box { -1, 1 hollow pigment { rgbt 1 } interior { media { scattering { 1, 0.1 } } } }",
    "area_light": "light_source { <0, 9, -9> rgb 1 area_light x, y, 3, 3 }",
    "reflection": "plane { y, -2 pigment { rgb 1 } finish { reflection 0.4 } }",
    "refraction": "sphere { 0, 1 pigment { rgbf 0.9 } interior { ior 1.5 } }",
    "fog": "fog { distance 30 rgb 0.5 }",
    "ior": "sphere { 0, 1 pigment { rgb 1 } interior { ior 1.33 } }",
    "sky_sphere": "sky_sphere { pigment { gradient y color_map { [0 rgb 0] [1 rgb 1] } } }",
    "rainbow": "rainbow { angle 42 width 5 distance 100 direction <0, 0, 1> jitter 0.01 "
               "color_map { [0 rgbt 1] [1 rgbt 1] } }",
    "subsurface": "sphere { 0, 1 pigment { rgb 1 } finish { subsurface { translucency 0.5 } } }",
}


def test_every_feature_has_a_scene_that_uses_it():
    assert set(USES) == set(FEATURE_WORDS)


def test_plain_scene_uses_nothing():
    assert features_of_text([PLAIN]).used == frozenset()


@pytest.mark.parametrize("feature", list(USES))
def test_each_feature_is_found(feature):
    found = features_of_text([PLAIN + USES[feature] + "\n"]).used
    assert feature in found
    # refraction snippets say rgbt/ior; nothing else should appear from one snippet
    assert found <= {feature, "refraction", "ior"}


def test_features_in_included_and_system_files(tmp_path):
    (tmp_path / "glass.inc").write_text("#declare G = texture { finish { reflection 0.2 } }\n")
    scene = tmp_path / "s.pov"
    scene.write_text(PLAIN + '#include "glass.inc"\n#include "textures.inc"\n')
    used = load_scene(scene).features.used
    assert "reflection" in used          # from the scene's own include
    assert "refraction" in used          # textures.inc (POV-Ray's) declares glass with ior/filter
    assert "refraction" not in load_scene(scene, system_dirs=()).features.used


def test_background_constant_only_without_fog_media_sky_rainbow():
    assert features_of_text([PLAIN]).background_is_constant
    for f in ("fog", "media", "sky_sphere", "rainbow"):
        assert not features_of_text([PLAIN + USES[f]]).background_is_constant
    for f in ("radiosity", "photons", "area_light", "reflection", "refraction"):
        assert features_of_text([PLAIN + USES[f]]).background_is_constant


def test_settings_only_for_features_in_use():
    wanted = {"max_trace_level": "10", "radiosity": "{ count 200 }", "photons": "{ spacing 0.01 }",
              "adc_bailout": "0.001", "subsurface": "{ samples 0, 0 }", "noise_generator": "2"}
    assert needed_settings(features_of_text([PLAIN]), wanted) == {"noise_generator": "2"}
    for setting, needs in SETTING_NEEDS.items():
        for feature in needs:
            assert setting in needed_settings(features_of_text([PLAIN + USES[feature]]), wanted)


DEEP = Quality(antialias=0.05, aa_method=2, aa_depth=3, max_trace_level=10)  # asks for a global setting
QUALITIES = {**QUALITY_LEVELS, "deep": DEEP}


def _header(tmp_path, text: str, quality: str) -> str:
    """The generated script up to the camera: what povh3d adds around the scene."""
    path = tmp_path / "scene.pov"
    path.write_text(text)
    scene = load_scene(path)
    la = square_array()
    header = display_header(la)
    extra = quality_settings(scene.features, QUALITIES[quality])
    if extra:
        header["global_settings"] = extra
    script = build_script(ShotBatch("pinhole.pov.j2", {"direction": (0, 0, 1), "right": (1, 0, 0),
                                                        "up": (0, 1, 0)}, [{"centre": (0, 0, 0)}], 4, 4),
                          [{"centre": (0.0, 0.0, 0.0)}], method="pinhole", scene_path=str(scene.path),
                          add_assumed_gamma=not scene.sets_assumed_gamma, header=header)
    return script[:script.index("camera")]


@pytest.mark.parametrize("quality", list(QUALITIES))
def test_header_of_a_plain_scene_adds_nothing(tmp_path, quality):
    head = _header(tmp_path, PLAIN, quality)
    assert "global_settings" not in head
    assert not re.search(r"radiosity|photons|max_trace_level|media|area_light", head)
    # Without its own assumed_gamma the scene gets POV-Ray 3.7's linear default, and only that.
    head = _header(tmp_path, PLAIN.replace("global_settings { assumed_gamma 1.0 }", ""), quality)
    assert re.findall(r"global_settings \{[^}]*\}", head) == ["global_settings { assumed_gamma 1.0 }"]


@pytest.mark.parametrize("feature", list(USES))
def test_header_for_scenes_using_each_feature(tmp_path, feature):
    head = _header(tmp_path, PLAIN + USES[feature] + "\n", "deep")
    used = features_of_text([USES[feature]]).used   # a media box is transparent too (rgbt)
    asked = quality_settings(features_of_text([PLAIN + USES[feature]]), DEEP)
    expected = {k for k, needs in SETTING_NEEDS.items() if k == "max_trace_level" and used & set(needs)}
    assert set(asked) == expected
    for key in ("max_trace_level",):
        assert (key in head) == (key in expected), (feature, key, head)
    # draft asks for nothing: the header stays bare whatever the scene uses
    assert "global_settings" not in _header(tmp_path, PLAIN + USES[feature] + "\n", "draft")

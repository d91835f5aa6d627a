"""The names issue 36 replaced still work, each with a deprecation: the sidecar key
``display_frame`` (now ``placement``) of sidecars already on disk, ``RenderRequest(display_frame=)``,
``povh3d.render(display_frame=)``, ``RenderSettings(frame=)`` / ``render(frame=)`` (now ``pose``),
``povh3d.layout(frame_options=)`` and ``--display-frame``."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import povh3d
from povh3d.image import io
from povh3d.image.io import read_sidecar, write_png, write_sidecar
from povh3d.renderer.placement.pose import PlacementOptions
from povh3d.renderer.request import RenderRequest

MATRIX = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 5.0, 0.0, 0.0)
OLD_ENTRY = {"source": "camera", "centre": [1.0, 2.0, 3.0], "units_per_mm": 2.5}


def _old_sidecar(tmp_path):
    image = tmp_path / "old.png"
    write_png(image, np.zeros((4, 6, 3), np.uint8))
    write_sidecar(image, {"display_frame": OLD_ENTRY, "quality": {"front_clearance_mm": 4.0}})
    assert "display_frame" in json.loads(image.with_suffix(".json").read_text())   # as an older povh3d wrote it
    return image


def test_an_old_sidecar_reads_its_display_frame_as_placement(tmp_path):
    record = read_sidecar(_old_sidecar(tmp_path))
    assert record["placement"] == OLD_ENTRY and "display_frame" not in record


def test_without_the_alias_the_old_key_would_not_read(tmp_path, monkeypatch):
    # negative control: the test above passes because of RENAMED_KEYS, not by chance
    monkeypatch.setattr(io, "RENAMED_KEYS", {})
    record = read_sidecar(_old_sidecar(tmp_path))
    assert "placement" not in record and record["display_frame"] == OLD_ENTRY


def test_a_new_key_wins_over_an_old_one():
    record = io.renamed_keys({"placement": {"source": "native"}, "display_frame": OLD_ENTRY})
    assert record["placement"] == {"source": "native"}


def test_render_request_takes_display_frame_with_a_deprecation(tmp_path):
    display = povh3d.build_display("demo")
    options = PlacementOptions("native")
    with pytest.warns(DeprecationWarning, match="placement"):
        request = RenderRequest(tmp_path / "a.pov", display, tmp_path / "a.png", display_frame=options)
    assert request.placement == options
    assert dataclasses.replace(request, fps=12.0).placement == options   # replace() goes through __init__
    with pytest.warns(DeprecationWarning):
        assert request.display_frame == options
    plain = RenderRequest(tmp_path / "a.pov", display, tmp_path / "a.png")
    assert plain.placement == PlacementOptions() != options   # control: the default without it


def test_render_and_layout_take_the_old_keywords(tmp_path, monkeypatch):
    from povh3d.commands import layout as layout_module
    from povh3d.renderer import api

    seen: dict = {}
    monkeypatch.setattr(api, "_render", lambda *args: seen.update(args[9]) or {})
    monkeypatch.setattr(layout_module, "layout", lambda *args, **kw: seen.update(kw) or {})
    options = PlacementOptions("native")
    with pytest.warns(DeprecationWarning, match="placement="):
        povh3d.render(tmp_path / "a.pov", tmp_path / "a.png", display_frame=options, use_cache=False)
    assert seen["placement"] == options and "display_frame" not in seen
    seen.clear()
    with pytest.warns(DeprecationWarning, match="pose="):
        povh3d.render(tmp_path / "a.pov", tmp_path / "a.png", frame=MATRIX, use_cache=False)
    assert seen["pose"] == MATRIX and "frame" not in seen
    seen.clear()
    with pytest.warns(DeprecationWarning, match="placement="):
        povh3d.layout(tmp_path / "a.pov", tmp_path / "a.png", frame_options=options)
    assert seen["placement"] == options and "frame_options" not in seen


def test_render_settings_take_frame_as_pose():
    from povh3d.renderer.methods.quality import RenderSettings

    with pytest.warns(DeprecationWarning, match="pose"):
        settings = RenderSettings(frame=MATRIX)
    assert settings.pose == MATRIX and dataclasses.replace(settings, jobs=1).pose == MATRIX
    assert RenderSettings().pose is None   # control


@pytest.mark.parametrize("flag, warned", [("--display-frame", True), ("--placement", False)])
def test_the_old_flag_sets_placement_and_says_so(capsys, flag, warned):
    from povh3d.cli.main import build_parser

    args = build_parser().parse_args(["render", "scene.pov", "--preset", "demo", flag, "native"])
    assert args.placement == "native"
    err = capsys.readouterr().err
    assert ("--display-frame is deprecated; use --placement native" in err) is warned
    parser = build_parser()
    render = next(a for a in parser._actions if a.choices and "render" in a.choices).choices["render"]
    assert "--placement" in render.format_help() and "--display-frame" not in render.format_help()   # hidden

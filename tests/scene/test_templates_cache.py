"""Compiled templates kept in the cache (``scene.templates``): a later process loads Jinja's code instead of
parsing and compiling the template again."""

from __future__ import annotations

import numpy as np
import pytest

from povh3d.geometry.camera_mesh import tiled_views_mesh
from povh3d.scene import templates

_CONTEXT = {"version": "test", "method": "depth", "add_assumed_gamma": True, "panel_size": (4.0, 3.0),
            "lens_pitch": 0.5, "focal": 2.0, "scene_path": "s.pov", "fog_distance": 10.0,
            "shots": [{"fog": 0}, {"fog": 1}],
            "mesh": tiled_views_mesh(np.zeros((1, 2)), (1, 1), (4, 3), (1.0, 1.0), 10.0)}


@pytest.fixture
def fresh_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("POVH3D_CACHE", str(tmp_path / "cache"))
    templates.environment.cache_clear()
    yield tmp_path / "cache"
    templates.environment.cache_clear()


def _no_compiler(monkeypatch):
    import jinja2

    def refuse(*args, **kwargs):
        raise AssertionError("compiled again")
    monkeypatch.setattr(jinja2.Environment, "_parse", refuse)


def test_a_compiled_template_is_loaded_from_the_cache(fresh_environment, monkeypatch):
    first = templates.render_template("depth_mesh.pov.j2", **_CONTEXT)
    assert len(list(fresh_environment.glob("templates/*/*.template"))) == 3   # depth_mesh and the two it extends
    templates.environment.cache_clear()   # as a new process
    _no_compiler(monkeypatch)
    assert templates.render_template("depth_mesh.pov.j2", **_CONTEXT) == first


def test_without_its_entry_a_template_is_compiled(fresh_environment, monkeypatch):
    # negative control: the refusing compiler is called where the cache holds nothing
    _no_compiler(monkeypatch)
    with pytest.raises(AssertionError, match="compiled again"):
        templates.render_template("depth_mesh.pov.j2", **_CONTEXT)


def test_a_damaged_entry_is_compiled_again(fresh_environment):
    first = templates.render_template("depth_mesh.pov.j2", **_CONTEXT)
    for entry in fresh_environment.glob("templates/*/*.template"):
        entry.write_bytes(entry.read_bytes()[:-7])
    templates.environment.cache_clear()
    with pytest.warns(Warning, match="damaged"):
        assert templates.render_template("depth_mesh.pov.j2", **_CONTEXT) == first

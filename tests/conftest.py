"""Shared fixtures: small lens arrays and an isolated image cache per test."""

from __future__ import annotations

import pytest

from povh3d.geometry.lens_array import LensArray, Panel


def square_array(lx: int = 8, ly: int = 6, nx: int = 4, ny: int = 4, s: float = 0.1, f: float = 1.5) -> LensArray:
    return LensArray("square", lx, ly, nx * s, ny * s, f, Panel(lx * nx, ly * ny, s, s))


def lenticular_array(lx: int = 8, rows: int = 12, nx: int = 4, s: float = 0.1, f: float = 1.5) -> LensArray:
    return LensArray("lenticular", lx, rows, nx * s, s, f, Panel(lx * nx, rows, s, s))


@pytest.fixture(autouse=True)
def _isolated_cache(tmp_path_factory, monkeypatch):
    # Never touch the user's cache; each test starts cold unless it shares this folder.
    monkeypatch.setenv("POVH3D_CACHE", str(tmp_path_factory.mktemp("cache")))


@pytest.fixture
def workdir(tmp_path):
    """A folder for POV-Ray jobs' temporary folders (run_jobs(workdir=...))."""
    path = tmp_path / "work"
    path.mkdir()
    return path

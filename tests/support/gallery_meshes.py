"""Generated meshes in the style of real ones: z up, in metres (a CAD part on its build plate,
a planet), written as the files a user would have."""

from __future__ import annotations

from pathlib import Path

import trimesh


def tower_ply(folder: Path) -> Path:
    """A 0.4 x 0.4 x 1.6 m tower standing on z = 0 with a 0.8 m wide foot along +x: z up, metres."""
    stem = trimesh.creation.box(extents=(0.4, 0.4, 1.6))
    stem.apply_translation((0, 0, 0.8))
    foot = trimesh.creation.box(extents=(0.8, 0.4, 0.2))
    foot.apply_translation((0.2, 0, 0.1))
    mesh = trimesh.util.concatenate([stem, foot])
    path = folder / "tower.ply"
    mesh.export(path)
    return path


def planet_stl(folder: Path, radius: float = 6.371e6, centre: tuple = (1.5e11, 0.0, 0.0)) -> Path:
    """An Earth-sized sphere in metres, far from the origin (an orbit), as an STL."""
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=radius)
    mesh.apply_translation(centre)
    path = folder / "planet.stl"
    mesh.export(path)
    return path

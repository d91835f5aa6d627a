"""Small POV-Ray scenes written by the tests, and the NumPy oracles that go with them."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from povh3d.geometry.lens_array import LensArray

from povh3d.geometry.rays import pixel_rays

COLOUR_A = (1.0, 0.2, 0.0)
COLOUR_B = (0.0, 0.3, 1.0)


def write_checker_plane(folder: Path, z0: float, period: float) -> Path:
    """An emissive plane at ``z = z0`` with a two-colour checker of ``period`` mm."""
    path = folder / f"checker_{z0:+g}.pov"
    a = "<%r, %r, %r>" % COLOUR_A
    b = "<%r, %r, %r>" % COLOUR_B
    path.write_text(f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
#declare P = {period!r};
plane {{ z, {z0!r}
  pigment {{ function {{ 0.25 + 0.5 * ((floor(x/P) + floor(y/P)) - 2 * floor((floor(x/P) + floor(y/P)) / 2)) }}
            color_map {{ [0 rgb {a}] [0.5 rgb {a}] [0.5 rgb {b}] [1 rgb {b}] }} }}
  finish {{ emission 1 diffuse 0 ambient 0 }}
}}
""")
    return path


def write_wave_plane(folder: Path, depth: float, period: float) -> Path:
    """An emissive plane ``depth`` mm behind the screen whose grey level is
    ``0.5 + 0.25 (sin(2 pi x / period) + sin(2 pi y / period))`` in linear light."""
    path = folder / "wave.pov"
    path.write_text(f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
#declare P = {period!r};
plane {{ z, {depth!r}
  pigment {{ function {{ 0.5 + 0.25 * (sin(2 * pi * x / P) + sin(2 * pi * y / P)) }}
            color_map {{ [0 rgb 0] [1 rgb 1] }} }}
  finish {{ emission 1 diffuse 0 ambient 0 }}
}}
""")
    return path


def checker_oracle(lens_array: LensArray, z0: float, period: float,
                   pseudoscopic: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Expected checker parity (0 = A, 1 = B) of every pixel, and whether its footprint is clear of edges.

    The ray of a pixel (docs/geometry.md) meets ``z = z0`` at ``c + (u, v) z0 / f``.  The
    footprint spans the lens aperture times the pixel's angular width; on a rotated
    lattice the aperture's bounding box in panel axes.  ``pseudoscopic``: the parity
    the depth-reversed image would show (every ray's ``(u, v)`` negated), a negative control.
    """
    centres, dirs, inside = pixel_rays(lens_array)
    t = z0 / dirs[..., 2]
    sign = -1.0 if pseudoscopic else 1.0
    hit = centres + sign * dirs[..., :2] * t[..., None]
    parity = (np.floor(hit[..., 0] / period) + np.floor(hit[..., 1] / period)) % 2
    la = lens_array
    theta = np.radians(la.rotation)
    c, s_ = abs(np.cos(theta)), abs(np.sin(theta))
    if la.grid == "hex":
        ax = ay = la.pitch_x / np.sqrt(3)  # circumradius: bounds the hexagon at any angle
    elif la.grid == "lattice":  # the parallelogram c +- a1/2 +- a2/2
        (a1x, a1y), (a2x, a2y) = la.basis
        ax, ay = (abs(a1x) + abs(a2x)) / 2, (abs(a1y) + abs(a2y)) / 2
    else:
        # Lenticular: across the lenticule, and the pixel's own height along it.
        hy = la.panel.pitch_y / 2 if la.grid == "lenticular" else la.pitch_y / 2
        hx = la.pitch_x / 2
        ax, ay = c * hx + s_ * hy, s_ * hx + c * hy
    half_x = ax + abs(z0) * (la.panel.pitch_x / 2) / la.focal
    half_y = ay + abs(z0) * (la.panel.pitch_y / 2) / la.focal

    def clear(coord, half):
        return np.floor((coord - half) / period) == np.floor((coord + half) / period)

    parity = np.where(inside, parity, 0)  # no ray outside the lenses (NaN)
    return parity.astype(int), inside & clear(hit[..., 0], half_x) & clear(hit[..., 1], half_y)


def match(classes: np.ndarray, expected: np.ndarray, clear: np.ndarray) -> float:
    """The share of ``clear`` pixels whose class (``classify``) is the oracle's (``checker_oracle``)."""
    return float(np.mean(classes[clear] == expected[clear]))


def classify(image: np.ndarray) -> np.ndarray:
    """0 where a pixel is nearer colour A, 1 where nearer B (8-bit sRGB image)."""
    lin = (image[..., :3].astype(float) / 255.0) ** 2.2
    da = np.sum((lin - np.array(COLOUR_A)) ** 2, axis=-1)
    db = np.sum((lin - np.array(COLOUR_B)) ** 2, axis=-1)
    return (db < da).astype(int)


def write_textured_scene(folder: Path) -> Path:
    """A lit, textured scene wholly behind the screen (z > 1 mm)."""
    path = folder / "behind.pov"
    path.write_text("""#version 3.7;
global_settings { assumed_gamma 1.0 }
background { rgb <0.05, 0.05, 0.1> }
light_source { <-30, 40, -60> rgb 1 }
light_source { <40, 10, -30> rgb <0.3, 0.3, 0.4> shadowless }
// z/0.9 is not whole: the checker flips on whole z, so a plane there is noise.
plane { z, 9.2 pigment { checker rgb <0.9, 0.9, 0.85> rgb <0.2, 0.3, 0.6> scale 0.9 } finish { diffuse 0.8 } }
sphere { <-1.5, 0.3, 4>, 2.2
  pigment { marble turbulence 0.7 color_map { [0 rgb <0.9, 0.3, 0.1>] [1 rgb <1, 0.9, 0.5>] } scale 0.6 }
  finish { specular 0.4 roughness 0.02 } }
box { <-1, -1, -1>, <1, 1, 1> rotate <20, 35, 0> translate <2.5, -1, 3>
  pigment { bozo color_map { [0 rgb <0.1, 0.7, 0.2>] [1 rgb <0.8, 1, 0.6>] } scale 0.3 } }
""")
    return path

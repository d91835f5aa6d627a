"""Hit-point oracle: emissive planes whose colour encodes where each pixel's ray lands.

A plane at ``z0`` (in front of the screen for ``z0 < 0``, behind it for ``z0 > 0``) is
coloured ``((x + half) / 2 half, (y + half) / 2 half, 0)``; rendered point-sampled at
16 bits, every pixel's colour gives the point its ray hit to ``2 half / 65535`` mm.
The expected point is the conventions' ray of the pixel: the line through its lens
centre ``c`` with direction ``(u, v, f)``, which meets ``z = z0`` at ``c + (u, v) z0 / f``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from povh3d.renderer.methods.registry import run_method
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.geometry.capture_bank import border_margin
from povh3d.geometry.lens_array import LensArray
from povh3d.geometry.rays import pixel_rays
from povh3d.image.colour import decode
from povh3d.scene.scene import load_scene

#: Hit within this many mm counts as right (the issue's figure).
TOLERANCE_MM = 0.05
#: Pixels nearer a lens border than this many pixels are left out (their centre is ambiguous).
BORDER_PX = 0.1


def write_position_plane(folder: Path, z0: float, half: float, *, miss_blue: bool = True) -> Path:
    """An emissive plane at ``z0`` whose red and green encode x and y in ``-half..half`` mm;
    a ray that misses it reads blue (``miss_blue``) or black."""
    path = folder / f"hit_plane_{z0:+g}.pov"
    background = "background { rgb <0, 0, 1> }\n" if miss_blue else ""
    path.write_text(f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
{background}plane {{ z, {z0!r}
  pigment {{ average pigment_map {{
    [1 function {{ (x + {half!r}) / {2 * half!r} }} color_map {{ [0 rgb 0] [1 rgb <2, 0, 0>] }}]
    [1 function {{ (y + {half!r}) / {2 * half!r} }} color_map {{ [0 rgb 0] [1 rgb <0, 2, 0>] }}] }} }}
  finish {{ emission 1 diffuse 0 ambient 0 }} }}
""")
    return path


def expected_hits(lens_array: LensArray, z0: float) -> np.ndarray:
    """(H, W, 2) mm: where each pixel's conventions ray meets ``z = z0`` (NaN outside every lens)."""
    c, d, _ = pixel_rays(lens_array)
    return c + d[..., :2] * (z0 / d[..., 2:3])


def border_margin_px(lens_array: LensArray) -> np.ndarray:
    """(H, W): distance of each pixel centre from its lens cell's border, in pixels: which pixels
    count as clear of a border (a selection of pixels, not an oracle of the rays)."""
    return border_margin(lens_array) / lens_array.panel.pitch_x


def half_for(lens_array: LensArray, z0: float) -> float:
    """A code range covering every expected hit, with a margin, mm."""
    hits = expected_hits(lens_array, z0)
    return float(np.nanmax(np.abs(hits))) * 1.2 + 1.0


def render_hits(method: str, lens_array: LensArray, folder: Path, z0: float, half: float,
                **options) -> np.ndarray:
    """(H, W, 2) mm: where each pixel of ``method``'s point-sampled image hit the plane."""
    scene = load_scene(write_position_plane(folder, z0, half))
    # Rays start (single-stage: the virtual array sits) clear of a plane in front of the screen.
    front_clearance = max(0.0, -z0) + 2.0 if z0 < 0 else None
    settings = RenderSettings(quality="draft", use_cache=False, bit_depth=16, front_clearance=front_clearance)
    h3d = run_method(method, scene, lens_array, settings, **options).h3d
    lin = decode(h3d)
    return np.stack([lin[..., 0], lin[..., 1]], axis=-1) * (2 * half) - half


@dataclass(frozen=True)
class HitScore:
    """How many clear pixels land within ``TOLERANCE_MM`` of their ray, and the worst miss."""

    within: float          # share of clear pixels within tolerance
    worst_mm: float        # largest miss among clear pixels
    clear: int             # clear pixels scored
    border_within: float   # share of pixels on a lens border (margin < BORDER_PX) within tolerance

    def __str__(self) -> str:
        return (f"{100 * self.within:.2f} % of {self.clear} clear pixels within {TOLERANCE_MM} mm, "
                f"worst {self.worst_mm:.4f} mm, border pixels {100 * self.border_within:.1f} %")


def score(lens_array: LensArray, got: np.ndarray, z0: float) -> HitScore:
    """Compare rendered hits ``got`` with the conventions' rays of ``lens_array``."""
    want = expected_hits(lens_array, z0)
    miss = np.linalg.norm(got - want, axis=-1)
    margin = border_margin_px(lens_array)
    clear = margin > BORDER_PX
    border = (margin > -np.inf) & ~clear
    ok = miss <= TOLERANCE_MM
    return HitScore(float(ok[clear].mean()), float(np.nanmax(miss[clear])), int(clear.sum()),
                    float(ok[border].mean()) if border.any() else 1.0)

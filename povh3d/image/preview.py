"""What a viewer sees through the lens array while walking past it.

A far viewer whose line of sight has direction ``(tan ax, tan ay, 1)`` sees,
under each lens, the pixel whose ray (docs/geometry.md) points along it: the pixel
at offset ``(u, v) = f (tan ax, tan ay)`` from the lens centre.  A viewer
standing left of the screen looks rightward and so sees pixels right of the
lens centres.  Each preview frame takes, under every lens, the pixel nearest
that offset: one pixel per lens, like the eye.
"""

from __future__ import annotations

import numpy as np

from .interleave import extract


def viewer_angles(pitch: float, focal: float, frames: int) -> np.ndarray:
    """``frames`` viewer positions (degrees, + = right of the screen) across the viewing angle."""
    half = np.degrees(np.arctan(pitch / (2 * focal)))
    edges = np.linspace(-half, half, frames + 1)
    return (edges[:-1] + edges[1:]) / 2


def seen_view(angle_deg: float, ppl: int, pixel_pitch: float, focal: float) -> int:
    """Index k (left to right under the lens) of the pixel a viewer at ``angle_deg`` sees.

    The viewer right of the screen (angle > 0) looks leftward: line of sight
    ``tan = -tan(angle)``, so ``u = -f tan(angle)``.
    """
    u = -focal * np.tan(np.radians(angle_deg))
    k = int(np.floor(u / pixel_pitch + ppl / 2))
    return min(max(k, 0), ppl - 1)


def preview_frames(h3d: np.ndarray, ppl: tuple[int, int], pixel_pitch: float, focal: float,
                   angles_deg: np.ndarray, vertical_deg: float = 0.0) -> np.ndarray:
    """One frame per viewer angle: ``(F, Ly, Lx, C)``, each frame one pixel per lens.

    Parameters
    ----------
    h3d : (Ly*Ny, Lx*Nx, C) array
    ppl : (Ny, Nx)
    pixel_pitch : mm
    focal : mm
    angles_deg : (F,) horizontal viewer positions
    vertical_deg : the viewer's vertical position (omnidirectional arrays)
    """
    return bank_frames(extract(h3d, ppl), pixel_pitch, focal, angles_deg, vertical_deg)


def bank_frames(views: np.ndarray, pixel_pitch: float, focal: float, angles_deg: np.ndarray,
                vertical_deg: float = 0.0) -> np.ndarray:
    """The view each viewer angle sees, ``(F, Ly, Lx, C)``, out of a bank ``(Ny, Nx, Ly, Lx, C)``
    whose view ``(l, k)`` is every lens read at the offsets ``(u_k, v_l)`` (a camera bank, or the
    lens-by-lens resampled views of a hex or fractional-PPL array, ``elemental.extract_views``)."""
    ny, nx = views.shape[:2]
    l = ny - 1 - seen_view(vertical_deg, ny, pixel_pitch, focal)  # rows count down, v up
    return np.stack([views[l, seen_view(a, nx, pixel_pitch, focal)] for a in angles_deg])


def enlarge(frame: np.ndarray, scale: tuple[int, int]) -> np.ndarray:
    """Nearest-neighbour enlargement by whole factors ``(rows, cols)`` (to show lens-sized pixels)."""
    return np.repeat(np.repeat(frame, scale[0], axis=0), scale[1], axis=1)

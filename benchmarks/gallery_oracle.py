"""The gallery's oracle and its verdict on a view (benchmarks/gallery.py judges each render with them).

A view is set against a plain POV-Ray render of the scene through an oblique orthographic camera
placed by the frame (``oracle_view``), point-sampled, and passes at ``MIN_DB``.  Two kinds of scene
fall under that bar on differences that are no fault of the render, and each is judged against a
floor measured on the scene itself: stochastic lighting against POV-Ray's own renders of the same
rays on shifted image grids, and a chaotic pigment (fractalzoom's ``mandel`` zoom) against the
oracle moved by the render's own precision (``chaotic_floor``).  ``view_verdict`` turns the
figures into the outcome.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

EXAMPLES = Path("/usr/share/doc/povray/examples")
MIN_DB = 35.0
#: dB a stochastic scene's view may fall below the gap between two of POV-Ray's own realizations
STOCHASTIC_MARGIN_DB = 3.0
#: dB a chaotic scene's view may fall below the gap between its oracle and the oracle moved by the
#: camera's precision bound: the render's own rounding is another such move, not the same one
CHAOTIC_MARGIN_DB = 3.0
#: the relative rounding of POV-Ray's mesh camera (vertices, normals and their interpolation in single
#: precision) and of its other cameras (double)
SINGLE, DOUBLE = 2.0 ** -24, 2.0 ** -53
#: methods whose rays come from a mesh camera
MESH_CAMERA_METHODS = ("multi-ortho",)


def _frame_of(record: dict):
    """The pose a sidecar's placement records (native: the identity)."""
    from povh3d.geometry.pose import DisplayPose

    f = record["placement"]
    if "centre" in f:
        return DisplayPose(tuple(f["centre"]), tuple(f["axis_x"]), tuple(f["axis_y"]), tuple(f["normal"]),
                            f["units_per_mm"], f["source"])
    return DisplayPose((0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), 1.0, "native")


def oracle_view(scene: Path, record: dict, view: tuple[int, int], shape: tuple[int, int], timeout: float,
                supersample: int = 1, shift: int = 0, shift_mm: float | tuple[float, float] = 0.0,
                tilt: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
    """View ``(l, k)`` of ``shape`` (rows, cols) as a plain POV-Ray render of the scene through an oblique
    orthographic camera placed by the frame, point-sampled.

    ``supersample`` (odd): render that many times finer and keep each pixel's centre sample, the same
    rays.  ``shift``: render ``shift`` more pixels along the view's shorter side (columns on the left, or
    rows on top) and cut them off, the same rays again.  Both change where POV-Ray's image grid lies over
    the scene; radiosity's pretrace samples sit on that grid (``pretrace_start``/``pretrace_end`` are
    fractions of the image's larger side), so each gives another realization of its lighting.
    ``shift_mm``: every ray moved that far along the screen's x and y (a number: both), the camera's own
    precision (``chaotic_floor``).  ``tilt``: added to every ray's direction's x and y (its z is 1), the
    direction's own rounding (``chaotic_floor``).
    """
    from povh3d.image.io import read_image
    from povh3d.scene.format import pov_vector
    from povh3d.povray.process import PovrayJob, run_jobs

    if supersample < 1 or supersample % 2 == 0:
        raise ValueError(f"supersample must be odd, got {supersample}")
    frame, la = _frame_of(record), record["lens_array"]
    back = record["quality"]["front_clearance_mm"]
    nx, ny = la["views"]
    (s, sy), fl = la["panel"]["pixel_pitch_mm"], la["focal_mm"]
    width_mm, height_mm = la["lenses"][0] * la["lens_pitch_mm"][0], la["lenses"][1] * la["lens_pitch_mm"][1]
    l, k = view
    d = np.array([(k + 0.5 - nx / 2) * s / fl + tilt[0], (ny / 2 - l - 0.5) * sy / fl + tilt[1], 1.0])
    rows, cols = shape
    across = shift > 0 and cols <= rows        # the shift widens the shorter side: max(W, H) stays
    extra_cols, extra_rows = (shift, 0) if across else (0, shift)
    # the image grows to the left (or upwards) by whole pixels, its centre by half of that
    centre = -back * d + np.array([-extra_cols * width_mm / cols / 2, extra_rows * height_mm / rows / 2, 0.0])
    centre[:2] += np.broadcast_to(shift_mm, 2)
    script = (f'#include "{scene.name}"\ncamera {{ orthographic location {pov_vector(frame.to_scene(centre))} '
              f'direction {pov_vector(frame.directions_to_scene(d))} '
              f'right {pov_vector(frame.directions_to_scene([width_mm * (cols + extra_cols) / cols, 0, 0]))} '
              f'up {pov_vector(frame.directions_to_scene([0, height_mm * (rows + extra_rows) / rows, 0]))} }}\n')
    images: list[np.ndarray] = []
    m = supersample
    run_jobs([PovrayJob(name="oracle", script=script, width=(cols + extra_cols) * m, height=(rows + extra_rows) * m,
                        include_dirs=(str(scene.parent), str(EXAMPLES)), options=("-A",), timeout=timeout)],
             processes=1, on_result=lambda r: images.append(read_image(r.images[0])))
    return images[0][m // 2::m, m // 2::m][extra_rows:, extra_cols:]


#: Where the realizations' image grids start, as fractions of the view's shorter side (at least a pixel each).
GRID_SHIFTS = (0.02, 0.1, 0.3)


def grid_shifts(shape: tuple[int, int]) -> list[int]:
    """The pixel shifts of ``GRID_SHIFTS`` for a view of ``shape`` (rows, cols): distinct, each >= 1."""
    short = min(shape)
    return sorted({max(1, round(f * short)) for f in GRID_SHIFTS})


def realizations_psnr(scene: Path, record: dict, view: tuple[int, int], oracle: np.ndarray, timeout: float) -> float:
    """The worst PSNR (dB) between ``oracle`` (view ``view``'s render) and POV-Ray's own renders of the
    same rays with the image grid shifted (``grid_shifts``): how far apart two of its own realizations of
    stochastic lighting may lie.  inf where the lighting does not depend on the grid."""
    from povh3d.image.metrics import psnr

    return min(psnr(oracle_view(scene, record, view, oracle.shape[:2], timeout, shift=p)[..., :3], oracle[..., :3])
               for p in grid_shifts(oracle.shape[:2]))


def view_psnr(scene: Path, record: dict, views_dir: Path, picks: list[tuple[int, int]], timeout: float,
              stochastic: bool = False) -> tuple[float, float]:
    """The worst PSNR (dB) of the picked views against oblique orthographic renders placed by the frame, and
    (``stochastic``) the worst PSNR between the first pick's render and POV-Ray's own renders of the same
    rays with the image grid shifted (``realizations_psnr``; nan: not measured, as where every view
    passes)."""
    from povh3d.image.io import read_png
    from povh3d.image.metrics import psnr

    worst, first = float("inf"), None
    for l, k in picks:
        view = read_png(views_dir / f"v_{l:03d}_{k:03d}.png")
        oracle = oracle_view(scene, record, (l, k), view.shape[:2], timeout)
        worst = min(worst, psnr(view[..., :3], oracle[..., :3]))
        first = oracle if first is None else first
    if not stochastic or worst >= MIN_DB or first is None:   # the realizations only where they can matter
        return worst, float("nan")
    return worst, realizations_psnr(scene, record, picks[0], first, timeout)


def view_verdict(worst_db: float, realizations_db: float, chaotic_db: float = float("nan")) -> str:
    """'ok' for a view within MIN_DB of its oracle; 'stochastic' for one under it but within
    STOCHASTIC_MARGIN_DB of the gap between two of POV-Ray's own realizations; 'chaotic' for one within
    CHAOTIC_MARGIN_DB of ``chaotic_db`` (``chaotic_floor``) where that floor itself is under MIN_DB (the
    oracle moved by the render's precision fails the bar); else 'wrong'."""
    if worst_db >= MIN_DB:
        return "ok"
    if np.isfinite(realizations_db) and worst_db >= realizations_db - STOCHASTIC_MARGIN_DB:
        return "stochastic"
    if np.isfinite(chaotic_db) and chaotic_db < MIN_DB and worst_db >= chaotic_db - CHAOTIC_MARGIN_DB:
        return "chaotic"
    return "wrong"


def chaotic_shift_mm(record: dict) -> float:
    """How far (mm, along each of the screen's x and y) the render's rays may lie off the conventions' by
    its camera's rounding: the relative precision times the front clearance, the span its rays are
    interpolated over.  Measured on ``animations/fractalzoom``'s frame (``bench_ray_precision``: a plane
    at the screen whose pigment encodes the hit point): the mesh camera's rays hit 1.2e-7 mm off on
    ``demo`` and 6.7e-7 mm on ``ipad-retina``, 0.17 and 0.09 of this bound (7.2e-7 and 7.6e-6 mm);
    the oracle's, under 1.3e-9 mm."""
    rounding = SINGLE if record["method"] in MESH_CAMERA_METHODS else DOUBLE
    return rounding * record["quality"]["front_clearance_mm"]


def chaotic_floor(scene: Path, record: dict, picks: list[tuple[int, int]], shape: tuple[int, int],
                  timeout: float) -> float:
    """The worst PSNR (dB) over the picked views between the oracle and the oracle with every ray moved by
    ``chaotic_shift_mm`` along x and y, each way (four diagonal moves): what an exact renderer off by the
    render's precision may score.  One move is one sample of which pixels flip (on fractalzoom's
    24 x 18 view the four read 22.5..35.9 dB), hence the worst of four.  inf for a scene whose colours do
    not change at that scale, as for nearly every scene.  Four more renders tilt every ray's direction
    by the same relative rounding (``chaotic_shift_mm``'s, without the clearance) along x and y: a
    surface on a pattern's jump (``textures/pigments/cantelop``'s rind, a sphere of radius 1 in an
    ``onion``: either colour by the last bits of r) flips where a move of the rays' start does not
    (its oracle tilted by 1e-9 scores 25.7 dB against itself, moved by the bound 30.5 dB)."""
    from povh3d.image.metrics import psnr

    shift, worst = chaotic_shift_mm(record), float("inf")
    for view in picks:
        oracle = oracle_view(scene, record, view, shape, timeout)[..., :3]
        for sx, sy in ((1, 1), (-1, -1), (1, -1), (-1, 1)):
            moved = oracle_view(scene, record, view, shape, timeout, shift_mm=(sx * shift, sy * shift))[..., :3]
            worst = min(worst, psnr(moved, oracle))
        tilt = shift / record["quality"]["front_clearance_mm"]
        for tx, ty in ((tilt, 0.0), (-tilt, 0.0), (0.0, tilt), (0.0, -tilt)):
            tilted = oracle_view(scene, record, view, shape, timeout, tilt=(tx, ty))[..., :3]
            worst = min(worst, psnr(tilted, oracle))
    return worst

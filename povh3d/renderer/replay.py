"""Replay through the real lenslets (``povh3d replay --optics lens``): the display as a POV-Ray scene.

An emissive ``image_map`` panel (the H3D image, nearest pixel, linear through) behind CSG lenslets
(``templates/lenslet.pov.j2``, the shapes single-stage builds) with their curved vertices, the front
principal plane, on the lens plane ``z = 0`` toward the viewer, flat faces toward the panel, and the
panel at the rear principal plane plus ``f``: ``z = t (1 - 1/n) + f`` for a plano-convex lens of centre
thickness ``t``.  A perspective camera at the eye takes the display's area as an off-axis window
(``direction`` from the eye to the window's centre, ``right`` and ``up`` its sides), so picture pixel
``(col, row)`` looks through the same lens-plane point as the NumPy replay's (``display/replay.py``).
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..display.replay import check_eye, coded_panel
from ..errors import ConfigError, param
from ..geometry.lens_array import LensArray
from ..geometry.chief_rays import check_ior
from ..geometry.optics import Lenslet
from ..image.io import read_image, write_png
from ..scene.templates import render_template

# The index of the lenslets of the thesis's lab displays' acrylic sheets (and the prototype's).
REPLAY_IOR = 1.49
MAX_LENSLETS = 250_000
BLUR_SAMPLES = 24  # rays a pixel through the pupil (--pupil)


def replay_lenslet(lens_array: LensArray, ior: float = REPLAY_IOR, shape: str = "spherical") -> Lenslet:
    """The display's lenslet: plano-convex, focal ``f``, index ``ior`` (a sphere that cannot span the
    aperture at that index is one error line from ``Lenslet``)."""
    if lens_array.grid == "lattice":
        raise ConfigError(f"a lattice given by two vectors has no lenslet shape to replay; use {param('optics')} pinhole")
    aperture = {"square": "square", "hex": "hex", "lenticular": "lenticular"}[lens_array.grid]
    check_ior(ior)
    if not ior > 1:  # NaN too
        raise ConfigError(f"{param('ior')} {ior!r} does not make a converging lens; give an index above 1, e.g. {param('ior')} 1.49")
    return Lenslet(shape, aperture, lens_array.pitch_x, lens_array.pitch_y, lens_array.focal, ior)


def lenslet_centres(lens_array: LensArray, shift: float = 0.0) -> np.ndarray:
    """Where the lenslets sit, (n, 2) mm: the lens centres; on a lenticular sheet one lenticule a column,
    its axis through the origin's row (turned with the sheet, moved ``shift`` mm across it: a mapped
    panel's sheet), long enough to cross the whole panel."""
    la = lens_array
    if la.grid == "lenticular":
        cx = la.lattice_centres()[0, :, 0] + shift
        return np.stack(la.from_lattice(cx, np.zeros_like(cx)), axis=-1)
    if shift:
        raise ConfigError("only a lenticular sheet is moved across its lenticules; give no shift")
    return la.lens_centres().reshape(-1, 2)


def replay_script(lens_array: LensArray, eye: np.ndarray, lenslet: Lenslet, *, sheet: bool = True,
                  pupil: float | None = None, shift: float = 0.0) -> str:
    """The POV-Ray scene of the display seen from ``eye`` (module docstring); the panel is ``panel.png``.
    ``sheet`` False: no lenslets and the panel in the lens plane."""
    la = lens_array
    width_mm, height_mm = la.panel.size_mm
    half_x = la.pitch_x / 2
    half_y = math.hypot(width_mm, height_mm) / 2 + la.pitch_x if la.grid == "lenticular" else la.pitch_y / 2
    hex_half_y = la.pitch_x / math.sqrt(3)
    centres = lenslet_centres(la, shift)
    if len(centres) > MAX_LENSLETS:
        raise ConfigError(f"{len(centres)} lenslets are more than the replay builds ({MAX_LENSLETS}); "
                          f"use {param('optics')} pinhole")
    t = lenslet.thickness
    return render_template(
        "replay.pov.j2", version=__version__, lenslet=lenslet, aperture=lenslet.aperture,
        quadric=lenslet.quadric(), half_x=half_x, half_y=half_y, hex_half_y=hex_half_y,
        bound_half_y=hex_half_y if la.grid == "hex" else half_y, sqrt3_2=math.sqrt(3) / 2, thickness=t,
        centres=centres.tolist(), rotation=la.rotation, sheet=sheet,
        z_panel=t * (1 - 1 / lenslet.refractive_index) + la.focal if sheet else 0.0,
        panel_size=(width_mm, height_mm), eye=tuple(map(float, eye)), pupil=pupil, blur_samples=BLUR_SAMPLES,
        direction=(-float(eye[0]), -float(eye[1]), -float(eye[2])))


def render_replay(image: np.ndarray, lens_array: LensArray, eyes: np.ndarray, *, size: Any,
                  quality: str = "draft", ior: float = REPLAY_IOR, shape: str = "spherical", processes: int = 2,
                  sheet: bool = True, coded: bool = False, pupil: float | None = None, shift: float = 0.0,
                  subpixels: bool = False, codes: np.ndarray | None = None) -> tuple[list[np.ndarray], dict[str, Any]]:
    """One picture per eye through the lenslets (``sheet`` False: none, the panel in the lens plane);
    ``(pictures, timings)``.  ``size`` is ``(W, H)``.  ``coded``: each eye also sees ``coded_panel`` (point
    sampled, 16 bit), whose pictures follow the others: the report's light shares.  ``shift``: the
    lenticules lie that many mm across (a mapped panel's sheet).  ``subpixels``: the panel is its R, G
    and B stripes (``subpixel.panel_to_subpixels``, each a third of a pixel wide and lit in its own
    channel), as a slanted sheet addressing subpixels sees it.  ``codes``: the panel the coded pictures
    see instead of ``coded_panel`` (a mapped panel's view of every subpixel, ``view_codes``)."""
    from ..povray.job import PovrayJob
    from ..povray.process import run_jobs

    if isinstance(size, str):
        raise ConfigError(f"{param('optics')} lens renders a picture of the display's area; give {param('size')} WxH, e.g. {param('size')} 800x600")
    width, height = (int(v) for v in size)
    eyes = np.asarray(eyes, np.float64).reshape(-1, 3)
    for e in eyes:
        check_eye(e, lens_array)
    lenslet = replay_lenslet(lens_array, ior, shape)
    if pupil is not None and not (isinstance(pupil, (int, float)) and 0 < pupil <= 20):
        raise ConfigError(f"{param('pupil')} must be the eye's pupil diameter in mm, above 0 and at most 20, got {pupil!r}; "
                          f"e.g. {param('pupil')} 4")
    if quality not in ("draft", "high"):
        raise ConfigError(f"{param('quality')} must be draft or high, got {quality!r}")
    options = ("-A",) if quality == "draft" else ("+A0.05", "+AM2", "+R3")
    bit_depth = 16 if image.dtype == np.uint16 else 8
    start = time.perf_counter()
    pictures: dict[int, np.ndarray] = {}
    with tempfile.TemporaryDirectory(prefix="povh3d-replay-") as folder:
        panel = Path(folder) / "panel.png"
        from ..display.subpixel import panel_to_subpixels

        if subpixels:
            if coded and codes is None:
                raise ConfigError("a subpixel panel's coded pictures need its codes; give codes")
            write_png(panel, panel_to_subpixels(image[..., :3]))
        else:
            write_png(panel, image[..., :3])
        script = {n: replay_script(lens_array, e, lenslet, sheet=sheet, pupil=pupil, shift=shift) for n, e in enumerate(eyes)}
        jobs = [PovrayJob(name=f"replay eye {n}", script=script[n], width=width,
                          height=height, options=options, bit_depth=bit_depth, file_gamma="1.0",
                          read_files=(str(panel),), include_dirs=(folder,), links=(("panel.png", str(panel)),))
                for n, e in enumerate(eyes)]
        if coded:
            codes_path = Path(folder) / "codes.png"
            if codes is None:
                write_png(codes_path, coded_panel(lens_array))
            else:
                write_png(codes_path, panel_to_subpixels(codes) if subpixels else codes)
            jobs += [PovrayJob(name=f"replay codes eye {n}", script=replay_script(lens_array, e, lenslet, sheet=sheet, shift=shift),
                               width=width, height=height, options=("-A",), bit_depth=16, file_gamma="1.0",
                               read_files=(str(codes_path),), include_dirs=(folder,), links=(("panel.png", str(codes_path)),))
                     for n, e in enumerate(eyes)]
        index = {job.name: n for n, job in enumerate(jobs)}

        def keep(result: Any) -> None:
            pictures[index[result.job.name]] = read_image(result.images[0])[..., :3]

        seconds = run_jobs(jobs, processes=min(processes, len(jobs)), on_result=keep)
    timings = {"povray_s": [float(s) for s in seconds], "total_s": time.perf_counter() - start,
               "lenslets": int(len(lenslet_centres(lens_array, shift))), "lenslet": lenslet.as_record()}
    return [pictures[n] for n in range(len(jobs))], timings

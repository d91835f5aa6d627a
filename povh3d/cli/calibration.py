"""Capture-side commands (thesis chapter 4): ``calibrate``, ``undistort``, ``borders``,
``equalise``, ``viewpoints``, ``stitch``."""

from __future__ import annotations

from typing import Any

from ..errors import ConfigError
from .options import positive_int


def add_parsers(sub: Any) -> None:
    """Capture-side processing (thesis chapter 4): calibrate, undistort, borders, equalise, viewpoints, stitch."""
    def run(fn, show):
        def command(args):
            from ..commands import calibration  # scipy: imported by the command that runs, not the parser

            print(show(args, fn(calibration, args)))
            return 0
        return command

    p = sub.add_parser("calibrate", help="find the lens grid in a white image -> grid.json")
    p.add_argument("white", help="PNG of a white background taken through the lens array")
    p.add_argument("-o", "--output", required=True, help="grid file to write (.json)")
    p.add_argument("--lattice", choices=("square", "hex", "lenticular"),
                   help="expected lattice (default: detect square or hex); lenticular: a slanted sheet")
    p.add_argument("--no-distortion", action="store_true", help="fit a straight lattice (no Brown terms)")
    p.add_argument("--dpi", type=float, help="lenticular: panel pixels per inch, to write the Looking Glass "
                                             "fields that 'map --calibration' reads")

    def calibrate(c, a):
        if a.lattice == "lenticular":
            return c.calibrate_lenticular_file(a.white, a.output, dpi=a.dpi, distortion=not a.no_distortion)
        if a.dpi is not None:
            raise ConfigError("--dpi only applies to --lattice lenticular")
        return c.calibrate_file(a.white, a.output, lattice=a.lattice, distortion=not a.no_distortion)

    def show(a, g):
        if isinstance(g, dict):
            return (f"{a.output}  lenticular  pitch {g['pitch_px']:.5f} px  slant {g['slant_deg']:.5f} deg  "
                    f"phase {g['phase_px']:.4f} px  k1 {g['k1']:.3g}  residual {g['residual_rad']:.4f} rad")
        return (f"{a.output}  {g.lattice}  pitch {g.pitch_px:.4f} px  rotation "
                f"{g.rotation_deg:.4f} deg  {int(g.inside.sum())} lenses  k1 "
                f"{g.distortion.k1:.3g}  residual {g.residual_px:.4f} px  confidence {g.confidence:.3f}")
    p.set_defaults(func=run(calibrate, show))

    def image_cmd(name, help_text, fn, extra=()):
        p = sub.add_parser(name, help=help_text)
        p.add_argument("image", help="capture (PNG)")
        p.add_argument("--grid", required=True, help="grid.json from 'povh3d calibrate'")
        p.add_argument("-o", "--output", required=True)
        for args, kwargs in extra:
            p.add_argument(*args, **kwargs)
        p.set_defaults(func=run(fn, lambda a, r: f"{a.output}  {name}"))

    image_cmd("undistort", "remove the barrel/pincushion distortion of a capture",
              lambda c, a: c.undistort_file(a.image, a.grid, a.output))
    image_cmd("borders", "flat-field micro-images and clean the dark borders between them",
              lambda c, a: c.borders_file(a.image, a.grid, a.output, threshold=a.threshold, fill=a.fill),
              [(("--threshold",), dict(type=float, default=0.5, help="border below this fraction of a lens's peak")),
               (("--fill",), dict(choices=("black", "nearest"), default="black"))])
    image_cmd("equalise", "resample every micro-image to one size (upright, square)",
              lambda c, a: c.equalise_file(a.image, a.grid, a.output, size=a.size),
              [(("--size",), dict(type=positive_int, help="pixels per micro-image side (default: the mean size)"))])
    image_cmd("viewpoints", "extract viewpoint images (pixel a, b of every micro-image) into a folder",
              lambda c, a: c.viewpoints_file(a.image, a.grid, a.output, ppl=a.ppl),
              [(("--ppl",), dict(type=positive_int, required=True, help="pixels per micro-image side to sample"))])

    p = sub.add_parser("stitch", help="join two captures taken a whole number of lenses apart")
    p.add_argument("a")
    p.add_argument("b")
    p.add_argument("--grid", required=True)
    p.add_argument("-o", "--output", required=True)
    p.set_defaults(func=run(lambda c, a: c.stitch_files(a.a, a.b, a.grid, a.output),
                            lambda a, r: f"{a.output}  {r['size_px'][0]}x{r['size_px'][1]}  B shifted "
                                         f"{r['shift_lenses']['rows']} rows, {r['shift_lenses']['cols']} columns "
                                         f"of lenses ({r['mode']})"))

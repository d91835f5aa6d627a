"""The ``volumes`` options of ``povh3d render`` (one argument group) and the ``VolumeOptions`` they make."""

from __future__ import annotations

import argparse
from typing import Any

from .options import parse_numbers


def add_volume_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("volumes (.vti .vtk .nrrd .nhdr .mha .mhd .nii .nii.gz .npy, a DICOM folder)")
    g.add_argument("--labels", nargs="?", const="all", metavar="LIST",
                   help="one surface per label of a segmentation: all (the default when the data are integer "
                   "labels) or e.g. 1,4,7")
    add_volume_source_options(g)
    g.add_argument("--volume", action="store_true", help="draw the data as a glowing, absorbing medium")
    g.add_argument("--transfer", default="auto", metavar="NAME|FILE",
                   help="--volume's transfer function: ct-bone, ct-soft, mri, labels, a file, or auto (the default)")
    g.add_argument("--df3-bits", type=int, choices=(8, 16), default=16, help="--volume's density file depth")
    g.add_argument("--opacity", metavar="A[,A...]", help="surface opacity 0..1: one for all, or one per surface")
    g.add_argument("--smoothing", type=int, metavar="N",
                   help="surface smoothing iterations (default: 16 for labels, 0 for iso)")


def add_volume_source_options(g: Any) -> None:
    """How a volume is read and faces the viewer (render and layout alike)."""
    g.add_argument("--iso", metavar="VALUE[,VALUE...]", help="one surface per iso value (e.g. CT bone 300; "
                   "a negative one as --iso=-500)")
    g.add_argument("--orientation", choices=("coronal", "axial", "sagittal"), default="coronal",
                   help="radiological view (default coronal: the patient faces you, their left on your right)")
    g.add_argument("--spacing", metavar="SX,SY,SZ", help="voxel size in mm (needed by .npy)")
    g.add_argument("--series", metavar="UID", help="the DICOM series to read from a folder holding several")


def volume_options_from_args(args: argparse.Namespace, rotate: Any) -> Any:
    from ..renderer.request import VolumeOptions

    labels = args.labels if args.labels in (None, "all") else parse_numbers(args.labels, "--labels", int)
    return VolumeOptions(spacing=parse_numbers(args.spacing, "--spacing"), series=args.series, labels=labels,
                         iso=parse_numbers(args.iso, "--iso"), opacity=parse_numbers(args.opacity, "--opacity"),
                         smoothing=args.smoothing, orientation=args.orientation, rotate=rotate,
                         volume=args.volume, transfer=args.transfer, df3_bits=args.df3_bits)

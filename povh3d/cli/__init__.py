"""The ``povh3d`` command line (argument parsing only; the work is ``povh3d.app``'s)."""

from .main import main

__all__ = ["main"]

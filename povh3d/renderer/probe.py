"""What ``povh3d render`` starts before it imports the renderer: POV-Ray's version probe, where the
cache's memory does not know the binary (``povray.process.probe_version_early``), so that its 0.2 s of
waiting pass beside the imports; and its end, so that no probe outlives the command in a long-lived
process (an API caller's, a test's)."""

from __future__ import annotations


def probe_povray_early() -> None:
    """Start the version probe of the POV-Ray the render will run; none found: the render says so."""
    from ..cache import cache_root
    from ..errors import Povh3dError
    from ..povray.process import probe_version_early
    from ..system import find_povray

    try:
        probe_version_early(find_povray(), cache_root())
    except Povh3dError:
        pass


def stop_povray_probe() -> None:
    """Stop a probe the render did not take (it failed before its first POV-Ray run)."""
    from ..povray.process import stop_probes

    stop_probes()

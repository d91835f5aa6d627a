"""povh3d: holoscopic 3D (integral imaging) images rendered with POV-Ray."""

__version__ = "0.1.0"

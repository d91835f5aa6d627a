"""Hyper-video: the self-contained viewer page and the 3D Content Descriptive Protocol
(3DCDP) header of a render's objects.  Pure functions of arrays and values; the files
are read and written by ``commands/viewer.py`` and ``commands/annotate.py``."""

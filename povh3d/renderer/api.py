"""``povh3d.render``: a render from Python in one call, through the same request and
path as ``povh3d render`` on the command line.

    import povh3d
    record = povh3d.render("scene.pov", "out.png", preset="demo", quality="draft")
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields
from pathlib import Path
from typing import Any

from .methods.quality import Progress, RenderSettings
from ..errors import ConfigError, plain, warn
from ..geometry.lens_array import LensArray
from ..display.display import build_display
from .run import run_request as render_request
from .request import RenderRequest
from ..jsontext import JSONValue

_REQUEST = tuple(f.name for f in fields(RenderRequest)
                 if f.name not in ("source", "output", "display", "settings", "objects"))
_SETTINGS = tuple(f.name for f in fields(RenderSettings))


def render(source: str | Path, output: str | Path, *, preset: str = "demo", lens_array: LensArray | None = None,
           mapping: str | None = None, mapping_options: Mapping[str, JSONValue] | None = None,
           calibration: str | Path | None = None, progress: Progress | None = None,
           objects: str | Path | None = None, camera_model: str | None = None, **options: Any) -> dict[str, JSONValue]:
    """Render a scene or a mesh model into ``output`` (PNG + JSON sidecar); return the sidecar record.

    Parameters
    ----------
    source : path             a POV-Ray scene (.pov) or a mesh model (.obj .stl .ply .glb ...)
    output : path             the .png to write
    preset : str              a display preset (``povh3d.presets.names()``)
    lens_array : LensArray    a lens array of your own, instead of the preset's
    mapping : str             a pixel mapping name (``alioscopy``, ``slanted``, ``smart:4`` ...)
    mapping_options : dict    its options (``per_lens``, ``views``, ``slope``, ``offset``, ``rows_per_view``,
                              ``reverse``, ``blend``), as ``povh3d map`` takes them
    calibration : path        a calibration file: the sheet of ``mapping='slanted'``, or of
                              ``method='subpixel'`` (a calibrated subpixel render)
    camera_model : str        a Looking Glass preset's views: ``perspective`` (the vendor's sheared cameras,
                              the default) or ``orthographic`` (the lens array's oblique views)
    objects : path            also write the object masks into this folder, as ``render --objects DIR``
                              (docs/viewer.md); the record gets ``object_masks`` (the folder, the number
                              of objects and frames, the share of pixels no id) and the sidecar ``objects``
    **options
        Any field of ``RenderRequest`` (``method``, ``method_options``, ``views_dir``,
        ``frames`` ...) or of ``RenderSettings`` (``quality``, ``jobs``, ``bit_depth`` ...).
        An unknown name is refused with the list of names.

    Calling it again with nothing changed (the arguments, the scene and every file it reads,
    POV-Ray, povh3d) writes the stored image and sidecar and returns the stored record, whose
    ``timings`` say ``output_from_cache`` (``use_cache=False`` skips it, as it skips the image cache).
    """
    from . import output_cache

    for old, new in (("display_frame", "placement"), ("frame", "pose")):   # their names before issue 36
        if old in options:
            import warnings

            warnings.warn(f"render({old}=...) is deprecated; use {new}=", DeprecationWarning, stacklevel=2)
            options.setdefault(new, options.pop(old))
    cache_dir = options.get("cache_dir")
    inputs = dict(preset=preset, lens_array=lens_array, mapping=mapping, mapping_options=mapping_options,
                  calibration=calibration, objects=objects, camera_model=camera_model, **options)
    key = output_cache.api_key(source, output, inputs) if options.get("use_cache", True) else None
    if key is not None:
        hit = output_cache.answer(key, Path(output), cache_dir)
        if hit is not None:
            for line in hit.warnings:
                warn(line)
            return plain(hit.record)   # a Python caller reads parameter names, not marks
    with output_cache.warnings_kept() as given:
        record = _render(source, output, preset, lens_array, mapping, mapping_options, calibration, progress,
                         objects, options, camera_model)
    if key is not None and output_cache.api_key(source, output, inputs) == key:
        output_cache.keep(key, Path(output), "", given, cache_dir)
    return plain(record)


def _render(source: str | Path, output: str | Path, preset: str, lens_array: LensArray | None,
            mapping: str | None, mapping_options: Mapping[str, JSONValue] | None, calibration: str | Path | None,
            progress: Progress | None, objects: str | Path | None, options: dict[str, Any],
            camera_model: str | None = None) -> dict[str, JSONValue]:
    """The render itself (``render`` above, past its cache)."""
    unknown = sorted(set(options) - set(_REQUEST) - set(_SETTINGS))
    if unknown:
        raise ConfigError(f"render() takes no option {', '.join(map(repr, unknown))}; it takes: "
                          f"preset, lens_array, mapping, mapping_options, calibration, objects, camera_model, "
                          f"{', '.join(_REQUEST + _SETTINGS)}")
    display = build_display(preset, lens_array=lens_array, method=options.get("method", "multi-ortho"),
                            mapping=mapping, mapping_options=mapping_options, calibration=calibration,
                            camera_model=camera_model)
    settings = RenderSettings(**{k: v for k, v in options.items() if k in _SETTINGS})
    # No method given: the default, which the render may trade for one that renders the scene right.
    options.setdefault("method_chosen", "method" in options)
    request = RenderRequest(source=Path(source), display=display, output=Path(output), settings=settings,
                            objects=None if objects is None else Path(objects),
                            **{k: v for k, v in options.items() if k in _REQUEST and k != "objects"})
    return render_request(request, progress)   # the object masks too: renderer.render orchestrates them

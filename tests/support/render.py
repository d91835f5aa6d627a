"""Render helpers for tests: a scene or model, a lens array and an output, as the tests
have always called them, built into one ``RenderRequest`` and run through the one path."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from povh3d.display.display import Display
from povh3d.renderer.render import render as render_request
from povh3d.renderer.request import RenderRequest
from povh3d.renderer.methods.quality import RenderSettings

# Draft quality for the oracles, rendered afresh: the test checks what POV-Ray makes, never a cache hit.
DRAFT = RenderSettings(quality="draft", use_cache=False)
# Draft quality through the cache, for the tests of what the cache gives back.
DRAFT_CACHED = RenderSettings(quality="draft")


def render(source: str | Path, lens_array: Any, output: str | Path, *, progress: Any = None,
           settings: RenderSettings | None = None, include_dirs: tuple = (),
           method: str = "multi-ortho", views_dir: str | Path | None = None, crop: Any = None,
           **method_options: Any) -> dict[str, Any]:
    """Render ``source`` through ``lens_array`` into ``output``; the sidecar record."""
    request = RenderRequest(source=Path(source), display=Display(lens_array), output=Path(output),
                            method=method, method_options=method_options,
                            settings=settings or RenderSettings(), crop=crop, include_dirs=tuple(include_dirs),
                            views_dir=Path(views_dir) if views_dir is not None else None)
    return render_request(request, progress)


def render_animation(source: str | Path, lens_array: Any, output: str | Path, frames: Any, *,
                     progress: Any = None, settings: RenderSettings | None = None, include_dirs: tuple = (),
                     method: str = "multi-ortho", video: str | Path | None = None,
                     fps: float = 24.0) -> dict[str, Any]:
    """Render the ``frames`` of an animated ``source``; the animation's report."""
    request = RenderRequest(source=Path(source), display=Display(lens_array), output=Path(output),
                            method=method, settings=settings or RenderSettings(),
                            include_dirs=tuple(include_dirs), frames=frames,
                            video=Path(video) if video is not None else None, fps=fps)
    return render_request(request, progress)

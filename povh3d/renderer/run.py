"""A whole render request: the colour pass (``renderer.render``) and, with ``objects``, the object
masks after it (``renderer.passes.object_masks``), orchestrated once for the command line and
``povh3d.render`` alike."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

if TYPE_CHECKING:   # the render's own modules load when it runs: the import chain stays within 8 levels
    from ..jsontext import JSONValue
    from .methods.quality import Progress
    from .request import RenderRequest


def run_request(request: RenderRequest, progress: Progress | None = None) -> dict[str, JSONValue]:
    """Carry out ``request``: the sidecar record of the still (or the animation's report), with
    ``object_masks`` (the folder, the number of objects and frames, the share of pixels no id)
    when the request asks for them."""
    from .render import render

    if request.objects is None:
        return render(request, progress)
    from .passes.object_masks import check_objects_request, render_objects   # only here: 4 ms of start-up

    check_objects_request(request, request.objects)   # refused before any work, as every output
    colour = replace(request, objects=None)
    record = render(colour, progress)
    return {**record, "object_masks": render_objects(colour, request.objects, record)}

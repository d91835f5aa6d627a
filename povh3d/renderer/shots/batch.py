"""What a method asks POV-Ray for (``ShotBatch``) and what a render did (``RenderStats``):
plain values shared by the methods, the crop and the runner (``renderer.shots.shots``).

Words: a *shot* is one image a method asks POV-Ray for (a view, a camera mesh's image);
a POV-Ray run renders several shots as the frames of its own animation (a *POV-Ray frame*,
``povray.job``).  An *animation frame* is one H3D image of ``--frames`` (``renderer.animation``),
and the *placement* is where the display sits in the scene (``renderer.placement``; its pose ``geometry.pose``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ...jsontext import JSONValue
from ...errors import ConfigError, param
from ...system import cpu_count


@dataclass(frozen=True)
class ShotBatch:
    """What a method asks POV-Ray for: ``len(shots)`` images of ``width x height``.

    ``shots_per_job`` bounds how many shots one POV-Ray run renders as the frames
    of an animation: a run costs about 0.7 s to start, a further frame about 0.2 s.
    """

    template: str
    context: dict[str, Any]
    shots: list[dict[str, Any]]
    width: int
    height: int
    shots_per_job: int = 1
    processes: int | None = None  # the method's preferred process count
    options: tuple[str, ...] = ()  # POV-Ray switches after the quality's, e.g. a coverage pre-pass
    # The shots whose run computes a lighting solution shared by every shot, the one that sees most
    # of what the others see first (the centre view, then the corner views: ``renderer.shots.lighting``);
    # empty: each shot computes its own (the passes).
    lighting_shots: tuple[int, ...] = ()


def mesh_camera_batch(template: str, meshes: list[Any], options: tuple[str, ...] = ()) -> ShotBatch:
    """One shot per camera mesh (``camera_mesh.CameraMesh``, all of one image size), spread over the cores."""
    width, height = meshes[0].image_size
    if width < 3:  # measured: +W2 (one pixel plus the mesh's extra column) crashes POV-Ray 3.7, +H2 does not
        raise ConfigError("POV-Ray 3.7's mesh camera crashes (segmentation fault) on an image one pixel wide: "
                          f"give at least 2 lenses or 2 pixels per lens across ({param('lenses')}, {param('ppl')}), or use "
                          f"{param('method')} single-stage")
    if len(meshes) == 1:
        return ShotBatch(template, {"mesh": meshes[0]}, [{}], width, height, processes=1, options=options)
    processes = min(cpu_count(), len(meshes))
    return ShotBatch(template, {}, [{"mesh": m} for m in meshes], width, height,
                      shots_per_job=-(-len(meshes) // processes), processes=processes, options=options)


@dataclass
class RenderStats:
    """What a render did, for the sidecar and the benchmark."""

    shots: int = 0
    cached: int = 0
    jobs: int = 0
    processes: int = 0
    threads: int = 0
    povray_seconds: list[float] = field(default_factory=list)
    wall_seconds: float = 0.0
    povray_version: str = ""
    uncached: str = ""   # why the image cache was not used, when the scene forbids it
    lighting: dict[str, JSONValue] | None = None   # the shared lighting solution (``renderer.shots.lighting``)
    radiosity_samples: int = 0   # radiosity samples POV-Ray computed over every run (its statistics)

    def as_record(self) -> dict[str, JSONValue]:
        return {"shots": self.shots, "shots_from_cache": self.cached, "povray_jobs": self.jobs,
                "processes": self.processes, "threads_per_process": self.threads,
                "povray_seconds_total": round(sum(self.povray_seconds), 4),
                "wall_seconds": round(self.wall_seconds, 4),
                **({"image_cache": f"not used: {self.uncached}"} if self.uncached else {}),
                **({"radiosity_samples_computed": self.radiosity_samples} if self.radiosity_samples else {}),
                **({"shared_lighting": self.lighting} if self.lighting else {})}

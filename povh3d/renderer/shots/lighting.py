"""One lighting solution for every shot of a still: radiosity computed once, loaded by every other run.

POV-Ray computes radiosity anew for each image it renders, so a still traced as many cameras
(``multi-ortho-views``' views, ``pinhole``'s lenses: the batches that name ``lighting_shots``) would
pay for a solution a shot: ``advanced/diffuse_back.pov``, whose 2D render spends 98 % of its time there, never finished.
POV-Ray 3.7 saves a solution and loads it again, through command-line options only (the scene's
``save_file``/``load_file`` are ignored since 3.7):

- the *saving* run renders the batch's ``lighting_shots`` (the centre view, then the four corner
  views) as the frames of one POV-Ray animation that loads and saves the same file
  (``Radiosity_From_File`` and ``Radiosity_To_File``): the centre view computes a whole solution (its
  image is exactly an independent render's, and its key too), each corner view adds the samples it
  misses (a third to a half of a whole one on cornell);
- every other run loads that file (``Radiosity_From_File``) and adds, in a later ``global_settings``
  that keeps the scene's own radiosity settings (count, error bound, brightness...), a pretrace of one
  pass at one pixel (``pretrace_start 1 pretrace_end 1``: a loaded solution still gets the scene's
  whole pretrace otherwise, ``Radiosity_Vain_Pretrace=off`` notwithstanding, measured: 1.4 s and a
  third of the samples a frame on cornell) and ``always_sample off``, so its final render reuses the
  loaded samples and computes new ones only where none is near enough (surfaces the saving views
  do not see).  Their keys name the saving shots' keys: a shot lit by a shared
  solution is not the image of an independent render, and the cache keeps them apart.
  (The centre view's solution alone left the corner views of cornell 38.8 dB from their
  independent renders, outside POV-Ray's own spread of 44.4 dB; with the corners': 44.8 dB.)

The file lives in a folder of the render's own (removed with it); the saving run writes it in its job
folder (the only place the sandbox lets POV-Ray write) and hands it over (``PovrayJob.keep_files``);
the loading runs read it through a link in their job folder, allowed by name (``read_files``).
Accuracy and cost (``radiosity/cornell.pov``): docs/methods.md, "Shared lighting".

Photons are shot from the lights, whatever the camera, so one map serves every shot: the saving run's
first frame shoots and saves it, and its later frames and every other run, where the file is, load it.
Measured: a render that loads the map is, to the bit, the render that shot it; 0.9 s of a 1.7 s view of
``advanced/benchmark/benchmark.pov`` at one thread was the shooting.  POV-Ray 3.7 saves and loads a
photon map only by the scene's own ``global_settings { photons { save_file / load_file } }`` (a later
``photons`` block of povh3d's would reset the scene's settings), so the runs render a copy of the scene
whose block holds a hook for it (``scene.rewrite.photon_map_hook``); a scene whose block povh3d cannot
reach (in another folder's include) or that keeps its own map shoots its photons in every run, as before.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ...jsontext import JSONValue
from ...cache import content_key
from ...scene.scene import Scene
from .batch import ShotBatch
from .clock_runs import SEQUENCE_SAFE_WORDS
from ..methods.quality import RenderSettings

#: The solution's name in a job folder (POV-Ray's working folder).
SOLUTION = "povh3d-radiosity.rad"
#: The photon map's name there.
PHOTONS = "povh3d-photons.ph"
#: Added to the loading runs' global settings, after the scene's own.
LOADED = "pretrace_start 1 pretrace_end 1 always_sample off"


@dataclass(frozen=True)
class SharedLighting:
    """The shots whose run computes and saves the lighting every other shot loads, in the order it
    renders them (the first from nothing, each later one adding what it misses); what is shared: the
    radiosity solution, the photon map (the runs then render a copy of the scene whose global ``photons``
    block saves or loads it: ``scene.rewrite.photon_map_hook``)."""

    savers: tuple[int, ...]
    radiosity: bool = True
    photons: bool = False

    def keyed(self, keys: list[str]) -> list[str]:
        """The shots' cache keys: the first saving shot's as it is, the others' naming the solution."""
        solution = [keys[i] for i in self.savers]
        return [key if i == self.savers[0] else content_key(key, "radiosity loaded from", solution)
                for i, key in enumerate(keys)]

    def saving(self, folder: Path) -> dict[str, Any]:
        """What the saving run adds to its job: the options that load (from its second frame on) and
        save the solution, the files kept."""
        out: dict[str, Any] = {"options": (), "keep_files": ()}
        if self.radiosity:
            out = {"options": (f"Radiosity_File_Name={SOLUTION}", "Radiosity_From_File=on", "Radiosity_To_File=on"),
                   "keep_files": ((SOLUTION, str(folder / SOLUTION)),)}
        if self.photons:
            out["keep_files"] += ((PHOTONS, str(folder / PHOTONS)),)
        return {field: value for field, value in out.items() if value}

    def loading(self, folder: Path, radiosity: bool, photons: bool) -> dict[str, Any]:
        """What a loading run adds to its job: the options that load the radiosity solution without a
        pretrace, links to what the saving run saved (``radiosity``, ``photons``) in the job folder,
        and leave to read them."""
        out: dict[str, Any] = {"options": (), "links": (), "read_files": ()}
        if radiosity:
            out["options"] = (f"Radiosity_File_Name={SOLUTION}", "Radiosity_From_File=on", "Radiosity_Vain_Pretrace=off")
        for name, used in ((SOLUTION, radiosity), (PHOTONS, photons)):
            if used:
                out["links"] += ((name, str(folder / name)),)
                out["read_files"] += (str(folder / name),)
        return {field: value for field, value in out.items() if value}   # an empty read_files would confine


def loading_header(header: dict[str, Any]) -> dict[str, Any]:
    """``header`` with ``LOADED`` added to the later ``global_settings`` radiosity block (the quality's own kept)."""
    settings = dict(header.get("global_settings") or {})
    own = settings.get("radiosity", "{ }").strip()
    settings["radiosity"] = own[:-1].rstrip() + f" {LOADED} }}"
    return {**header, "global_settings": settings}


def photon_header(header: dict[str, Any]) -> dict[str, Any]:
    """``header`` with the declaration ``photon_map_hook`` reads: the map's file."""
    from ...scene.rewrite import PHOTON_MAP   # here: the rewrite's tokenizer only where photons are shared

    return {**header, "photon_map": {"name": PHOTON_MAP, "file": PHOTONS}}


def photon_map_reachable(scene: Scene) -> bool:
    """Whether the scene has photons and povh3d reaches its global ``photons`` block to share the map
    (``scene.rewrite.photon_map_hook``)."""
    if "photons" not in scene.features:
        return False
    from ...scene.rewrite import photon_map_hook, rewrites   # here: the tokenizer only for scenes with photons

    return rewrites(scene, photon_map_hook)


def shared_lighting(scene: Scene, batch: ShotBatch, settings: RenderSettings, local: bool) -> SharedLighting | None:
    """The shared lighting of this batch, or None where each shot lights itself: a batch that names no
    ``lighting_shots`` (the passes, whose frames must each light themselves; the mesh camera's
    footprint banks), a scene with neither radiosity nor photons povh3d can share, a single shot, turned
    off, a cluster (no shared file system), an animation whose frames go in clock sequences (each frame's
    runs then hold several clocks).  Photons alone need one saving shot: their map does not depend on the camera."""
    if (not batch.lighting_shots or len(batch.shots) < 2 or not settings.shared_lighting or not local
            or (settings.sequence is not None and settings.sequence.later)):
        return None
    radiosity = "radiosity" in scene.features
    photons = photon_map_reachable(scene)
    if not (radiosity or photons):
        return None
    savers = batch.lighting_shots
    if scene.animation_words - SEQUENCE_SAFE_WORDS or not radiosity:
        savers = savers[:1]  # each shot a run of its own (``shots._planned_jobs``): no chain of frames
    return SharedLighting(tuple(savers), radiosity=radiosity, photons=photons)


def record(lighting: SharedLighting, saved: tuple[int, float] | None, loaded: list[tuple[int, float] | None],
           shots: int, photons: tuple[int, int] | None = None) -> dict[str, JSONValue]:
    """The sidecar's account: the saving shots, the radiosity samples their run computed and what the
    loading runs computed beside the loaded ones (POV-Ray's statistics, ``povray.log.parse_radiosity``),
    and, where the photon map was shared, the photons the saving run and all the loading runs shot."""
    out: dict[str, JSONValue] = {}
    if saved is not None:
        out["radiosity"] = "computed once, loaded by the other shots"
    if photons is not None:
        out["photons"] = "shot once, loaded by the other shots"
        out["photons_shot"], out["photons_shot_by_loading_shots"] = photons
    out["saving_shots"] = list(lighting.savers)
    if saved is not None:
        out["samples_computed"], out["pretrace_seconds"] = saved[0], round(saved[1], 3)
    counts = [c for c in loaded if c is not None]
    if counts and shots:
        out["loading_shots"] = shots
        out["samples_computed_per_loading_shot"] = round(sum(c[0] for c in counts) / shots, 1)
        out["loading_pretrace_seconds"] = round(sum(c[1] for c in counts), 3)
    elif shots:
        out["loading_shots"] = shots
    return out

"""Draw the set-up picture off screen with PyVista: arrays in, an RGB image out (no files).

Display coordinates are left-handed (``z`` away from the viewer), VTK's is
right-handed, so every point is drawn at ``(x, y, -z)``: the picture is not a
mirror image, and the viewer's side (display ``-z``) is VTK's ``+z``.  The
camera looks from the viewer's side, above and to the right (a 3/4 view).

PyVista is imported here only, when a picture is drawn; VTK's complaint that
there is no X display (it falls back to an off-screen context) is silenced.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import Povh3dError, param
from ..geometry.lens_array import LensArray
from ..geometry.setup import BEHIND, FRONT, INSIDE, SetUp, classify

# Colours (RGB 0..255).  The screen's outline is drawn unlit, so its colour is exact in the picture.
SCREEN = (30, 90, 230)
ARRAY = (0, 140, 130)
SLAB_FRONT = (255, 170, 60)
SLAB_BACK = (90, 150, 255)
CONE = (230, 190, 0)
CONTENT = {INSIDE: (170, 170, 170), FRONT: (235, 90, 20), BEHIND: (120, 60, 200)}
BACKGROUND = (255, 255, 255)
MAX_GRID_LINES = 40      # lens-array lines drawn on a side (every k-th lens beyond that)
CONE_REACH = 0.75        # the cone is drawn at most this many screen sizes long


def quiet_pyvista() -> Any:
    """PyVista with VTK's log and warnings off (no X display is expected here)."""
    from vtkmodules.vtkCommonCore import vtkLogger, vtkObject

    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)
    vtkObject.GlobalWarningDisplayOff()
    import pyvista as pv

    pv.OFF_SCREEN = True
    return pv


def check_opengl() -> None:
    """Refuse to draw where VTK has no OpenGL to draw with (it would crash the process).

    VTK picks its window when one is made: X with a display, else EGL when an
    EGL driver answers, else OSMesa, which it loads only when drawing starts.
    """
    import ctypes.util

    import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (registers the OpenGL windows)
    from vtkmodules.vtkRenderingCore import vtkRenderWindow

    window = vtkRenderWindow()
    chosen = type(window).__name__
    window.Finalize()
    if chosen == "vtkOSOpenGLRenderWindow" and ctypes.util.find_library("OSMesa") is None:
        raise Povh3dError("povh3d layout cannot draw: no OpenGL to draw off screen with (no EGL driver, no "
                          "OSMesa); install Mesa's with 'make opengl' or apt-get install libegl1 libegl-mesa0")


def _v(points: np.ndarray | tuple[float, float, float]) -> np.ndarray:
    """Display mm -> drawing coordinates (``z`` negated: a right-handed frame, not mirrored)."""
    return np.asarray(points, dtype=np.float64) * (1.0, 1.0, -1.0)


def _rgb(colour: tuple[int, int, int]) -> tuple[float, float, float]:
    r, g, b = colour
    return r / 255, g / 255, b / 255


def _box(pv: Any, lo: np.ndarray | tuple[float, float, float], hi: np.ndarray | tuple[float, float, float]) -> Any:
    a, b = _v(lo), _v(hi)
    return pv.Box(bounds=(a[0], b[0], a[1], b[1], min(a[2], b[2]), max(a[2], b[2])))


def _loop(pv: Any, corners: np.ndarray) -> Any:
    return pv.lines_from_points(_v(np.vstack([corners, corners[:1]])))


def _lens_grid(pv: Any, lens_array: LensArray, outline: np.ndarray) -> tuple[Any, int]:
    """Lines between lens cells (every ``step``-th), in the lattice's frame, turned with it."""
    counts = (lens_array.lenses_x,) if lens_array.unidirectional else (lens_array.lenses_x, lens_array.lenses_y)
    step = max(1, math.ceil(max(counts) / MAX_GRID_LINES))
    lo_x, hi_x = lens_array.to_lattice(outline[:, 0], outline[:, 1])[0][[0, 1]]
    lo_y, hi_y = lens_array.to_lattice(outline[:, 0], outline[:, 1])[1][[0, 2]]
    segments = []
    for k in range(0, lens_array.lenses_x + 1, step):
        x = lo_x + k * lens_array.pitch_x
        segments += [(x, lo_y), (x, hi_y)]
    if not lens_array.unidirectional:  # a lenticular sheet has no rows of lenses
        for k in range(0, lens_array.lenses_y + 1, step):
            y = lo_y + k * lens_array.pitch_y
            segments += [(lo_x, y), (hi_x, y)]
    seg = np.asarray(segments, dtype=np.float64)
    x, y = lens_array.from_lattice(seg[:, 0], seg[:, 1])
    lines = pv.line_segments_from_points(_v(np.stack([x, y, np.zeros_like(x)], -1)))
    return (_cut(lines, lens_array) if lens_array.rotation else lines), step


def _cut(lines: Any, lens_array: LensArray) -> Any:
    """A turned lattice is cut by the panel's edges, as a real slanted sheet is."""
    w, h = lens_array.panel.size_mm
    return lines.clip_box((-w / 2, w / 2, -h / 2, h / 2, -1.0, 1.0), invert=False)


def _cone(pv: Any, setup: SetUp, reach: float) -> tuple[Any, Any, float]:
    """The viewing cone (a pyramid, or a lenticular fan) cut at ``reach`` mm; its surface and edges."""
    length = min(setup.viewing_distance_mm, reach)
    t = length / setup.viewing_distance_mm
    apex = setup.apex
    end = setup.cone_end.copy()
    end[:, :2] *= t
    end[:, 2] *= t
    if apex[0, 1] != apex[1, 1]:   # a fan: full height all along
        end[:, 1] = setup.cone_end[:, 1]
    points = np.vstack([apex, end])   # 0, 1: apex bottom, top; 2..5: the end, as the screen
    faces = np.hstack([[4, 0, 2, 3, 0], [4, 1, 4, 5, 1], [4, 0, 2, 5, 1], [4, 0, 3, 4, 1]])
    surface = pv.PolyData(_v(points), faces=faces)
    edges = pv.line_segments_from_points(_v(np.array([apex[0], end[0], apex[0], end[1], apex[1], end[2],
                                                      apex[1], end[3]])))
    return surface, edges.merge(_loop(pv, end)), length


def _legend_text(content: Any, setup: SetUp, lens_array: LensArray, numbers: dict, display: dict,
                 cone_length: float, grid_step: int) -> str:
    w, h = lens_array.panel.size_mm
    half = setup.budget_mm / 2
    views = lens_array.views
    lines = [f"{content.name} ({content.kind})  on  {display.get('preset', 'custom display')}",
             f"panel {w:.4g} x {h:.4g} mm, {lens_array.panel.width} x {lens_array.panel.height} px",
             f"{lens_array.grid} lenses {lens_array.lenses_x} x {lens_array.lenses_y}, "
             f"pitch {lens_array.pitch_x:.4g} mm, focal {lens_array.focal:.4g} mm"
             + (f", {views[1]} x {views[0]} views" if views else ""),
             f"viewing angle {2 * setup.half_angles_deg[0]:.3g} deg"
             + ("" if math.isnan(setup.half_angles_deg[1]) else f" x {2 * setup.half_angles_deg[1]:.3g} deg")
             + f"; every lens in view from {setup.viewing_distance_mm:.4g} mm",
             f"depth budget 2 N f = {setup.budget_mm:.4g} mm: z {-half:+.4g} .. {half:+.4g} mm"]
    if numbers.get("points"):
        what = numbers.get("counted", "")
        lines.append(f"content z {numbers['near_mm']:+.4g} .. {numbers['far_mm']:+.4g} mm, "
                     f"{100 * numbers['outside']:.0f} % {what} outside the budget "
                     f"({100 * numbers['front_outside']:.0f} % in front, "
                     f"{100 * numbers['behind_outside']:.0f} % behind)")
    else:
        lines.append("content: nothing seen by the display")
    subject = content.record.get("depth", {})
    if subject.get("near_mm") is not None:   # a scene: what 'render' and 'info' call the framed subject
        lines.append(f"subject (middle of the field) z {subject['near_mm']:+.4g} .. {subject['far_mm']:+.4g} mm")
    if content.record.get("depth", {}).get("unmeasured_fraction", 0) > 0.05:
        lines.append(f"depth pass: {100 * subject['unmeasured_fraction']:.0f} % of the field unmeasured "
                     "(viewpoint inside a solid)")
    fit = content.record.get("fit")
    if content.kind == "scene":
        lines.append(f"frame: {content.units_per_mm:.4g} scene units per mm ({content.record.get('source', 'native')})")
    elif fit:   # a model or a volume, staged in display mm
        limit = param("depth") if fit["limit"] == "depth" else f"the panel's {fit['limit']}"
        lines.append(f"placed at {fit['scale']:.4g} display mm per {content.kind} mm, limited by {limit}")
    notes = []
    if cone_length < setup.viewing_distance_mm:
        notes.append(f"cone drawn to {cone_length:.3g} mm")
    if grid_step > 1:
        notes.append(f"grid: a line every {grid_step} lenses")
    if notes:
        lines.append("; ".join(notes))
    return "\n".join(lines)


def draw(content: Any, setup: SetUp, lens_array: LensArray, numbers: dict, *, size: tuple[int, int],
         display: dict) -> np.ndarray:
    """The set-up picture: ``(size[1], size[0], 3)`` uint8 RGB."""
    pv = quiet_pyvista()
    check_opengl()
    width, height = size
    plot = pv.Plotter(off_screen=True, window_size=[width, height])
    try:
        plot.set_background(_rgb(BACKGROUND))
        scale = max(width, height) / 1200
        w, h = lens_array.panel.size_mm
        lo, hi = setup.slab
        plot.add_mesh(_box(pv, lo, (hi[0], hi[1], 0.0)), color=_rgb(SLAB_FRONT), opacity=0.15, lighting=False)
        plot.add_mesh(_box(pv, (lo[0], lo[1], 0.0), hi), color=_rgb(SLAB_BACK), opacity=0.15, lighting=False)
        plot.add_mesh(_box(pv, lo, hi).extract_all_edges(), color=_rgb(SLAB_BACK), line_width=1, lighting=False)
        grid, step = _lens_grid(pv, lens_array, setup.array)
        outline = _loop(pv, setup.array)
        outline = _cut(outline, lens_array) if lens_array.rotation else outline
        for lines, line_width in ((grid, 1), (outline, max(1, round(2 * scale)))):
            if lines.n_points:   # a turned lattice covering the whole panel has no outline inside it
                plot.add_mesh(lines, color=_rgb(ARRAY), line_width=line_width, lighting=False)
        plot.add_mesh(_loop(pv, setup.screen), color=_rgb(SCREEN), line_width=max(3, round(4 * scale)),
                      lighting=False)
        cone, edges, cone_length = _cone(pv, setup, CONE_REACH * max(w, h))
        plot.add_mesh(cone, color=_rgb(CONE), opacity=0.12, lighting=False)
        plot.add_mesh(edges, color=_rgb(CONE), line_width=max(1, round(2 * scale)), lighting=False)
        _add_content(pv, plot, content, setup, scale)
        _add_axes(pv, plot, setup, scale)
        text = _legend_text(content, setup, lens_array, numbers, display, cone_length, step)
        plot.add_text(text, position="upper_left", font_size=max(7, round(11 * scale)), color="black",
                      font="courier")
        plot.add_legend(labels=[["screen (panel)", _rgb(SCREEN)], ["lens array", _rgb(ARRAY)],
                                ["depth budget, front", _rgb(SLAB_FRONT)], ["depth budget, behind", _rgb(SLAB_BACK)],
                                ["viewing cone", _rgb(CONE)], ["content within budget", _rgb(CONTENT[INSIDE])],
                                ["content in front of it", _rgb(CONTENT[FRONT])],
                                ["content behind it", _rgb(CONTENT[BEHIND])]],
                        bcolor=(1.0, 1.0, 1.0), border=True, loc="lower right", size=(0.22, 0.2), face="rectangle")
        _place_camera(plot, content, setup, cone_length)
        image = plot.screenshot(return_img=True)
    finally:
        plot.close()
    return np.ascontiguousarray(image[..., :3], dtype=np.uint8)


def _add_content(pv: Any, plot: Any, content: Any, setup: SetUp, scale: float) -> None:
    if content.box is not None:
        # Volume.corners order: i slowest; the hexahedron's faces as quads
        quads = [(0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5)]
        faces = np.hstack([[4, *q] for q in quads])
        box = pv.PolyData(_v(content.box), faces=faces)
        kind = classify(content.box[:, 2], setup.budget_mm)
        plot.add_mesh(box, color=_rgb(CONTENT[INSIDE]), opacity=0.1 if len(content.faces) else 0.35)
        plot.add_mesh(box.extract_all_edges(), scalars=np.array([CONTENT[k] for k in kind], dtype=np.uint8),
                      rgb=True, line_width=max(2, round(3 * scale)), lighting=False)
        if content.marks:
            plot.add_point_labels(_v(np.array([p for _, p in content.marks])), [m for m, _ in content.marks],
                                  font_size=max(8, round(14 * scale)), text_color="black", shape=None,
                                  always_visible=True, show_points=False)
    if len(content.vertices) == 0:
        return
    colours = np.array([CONTENT[k] for k in range(3)], dtype=np.uint8)[classify(content.vertices[:, 2],
                                                                                 setup.budget_mm)]
    if len(content.faces):
        faces = np.hstack([np.full((len(content.faces), 1), 3), content.faces]).ravel()
        mesh = pv.PolyData(_v(content.vertices), faces=faces)
        plot.add_mesh(mesh, scalars=colours, rgb=True, smooth_shading=False)
    else:
        plot.add_points(_v(content.vertices), scalars=colours, rgb=True, point_size=max(2, round(3 * scale)))


def _add_axes(pv: Any, plot: Any, setup: SetUp, scale: float) -> None:
    """x, y, z arrows from the screen's bottom left corner, in the display's own directions."""
    origin = setup.screen[0]
    length = 0.3 * float(min(np.ptp(setup.screen[:, 0]), np.ptp(setup.screen[:, 1])))
    tips = []
    for axis, colour in zip(np.eye(3), ((200, 0, 0), (0, 150, 0), (0, 0, 200))):
        arrow = pv.Arrow(start=_v(origin), direction=_v(axis), scale=length, tip_length=0.2, shaft_radius=0.02)
        plot.add_mesh(arrow, color=_rgb(colour))
        tips.append(origin + 1.15 * length * axis)
    plot.add_point_labels(_v(np.array(tips)), ["x right", "y up", "z away from the viewer"],
                          font_size=max(8, round(12 * scale)), text_color="black", shape=None,
                          always_visible=True, show_points=False)


def _place_camera(plot: Any, content: Any, setup: SetUp, cone_length: float) -> None:
    """A 3/4 view from the viewer's side, above and to the right, fitting screen, slab, cone and content."""
    lo, hi = setup.slab
    pts = [setup.screen, np.array([lo, hi]), setup.apex, setup.apex + (0, 0, -cone_length)]
    if len(content.vertices):
        v = content.vertices
        # a far backdrop should not shrink the set-up to a dot: frame the middle 98 % of the content
        pts.append(np.percentile(v, [1, 99], axis=0))
    if content.box is not None:
        pts.append(content.box)
    allp = _v(np.vstack(pts))
    a, b = allp.min(axis=0), allp.max(axis=0)
    centre = (a + b) / 2
    direction = np.array([0.55, 0.4, 1.0])
    direction /= np.linalg.norm(direction)
    radius = float(np.linalg.norm(b - a)) / 2
    plot.camera_position = [tuple(centre + direction * radius * 3.2), tuple(centre), (0.0, 1.0, 0.0)]
    plot.camera.view_angle = 30.0
    plot.camera.SetWindowCenter(0.12, 0.05)   # the drawing a little left and down: the legend is at lower right
    plot.reset_camera_clipping_range()

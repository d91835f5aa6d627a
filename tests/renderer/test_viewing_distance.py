"""A viewing distance for a lenticular panel (``--viewing-distance``, docs/geometry.md "A viewing
distance"): every row is rendered as an eye at the screen centre's height, ``D`` in front of the
lens plane, sees it: the ray through the panel point ``(x, y, f)`` keeps its view's horizontal
direction and has the vertical slope ``y / (D + f)``, crossing the lens plane at ``y D / (D + f)``.

Oracles written here from that statement: the rays of the view bank's mesh; a floor below the
screen whose stripes a row shows at the depth where that ray meets it, computed in closed form;
the scene's 2D render from the eye (POV-Ray alone); and the replay from the eye against that 2D
render.  Negative control of each: the orthographic rows of the same display.
"""

from __future__ import annotations

import hashlib
import json
import math
import subprocess

import numpy as np
import pytest

from povh3d.display.display import build_display
from povh3d.errors import ConfigError
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.geometry.view_bank import view_bank_shots
from povh3d.image.io import read_png
from povh3d.renderer.request import RenderRequest

D, F, PY = 150.0, 2.0, 0.5
# Two footprint samples (ax, ay, du, dv), in lens pitches and pixel pitches.
SAMPLES = np.array([[0.125, -0.25, 0.375, 0.25], [-0.375, 0.125, -0.25, -0.125]])
ARRAY = ("--grid", "lenticular", "--ppl", "4", "--lenses", "40", "--rows", "120", "--pixel-pitch", str(PY),
         "--focal", str(F))
W_MM, H_MM, ROWS = 80.0, 60.0, 120
FLOOR, STRIPE = 10.0, 8.0   # the floor 10 mm below the screen centre, stripes 8 mm deep along z
RED, WHITE, BLUE = (255, 0, 0), (255, 255, 255), (0, 0, 255)
FLOOR_SCENE = f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
background {{ rgb <1, 0, 0> }}
plane {{ y, -{FLOOR} pigment {{ gradient z color_map {{ [0 rgb 1] [0.5 rgb 1] [0.5 rgb <0, 0, 1>] [1 rgb <0, 0, 1>] }}
        scale {STRIPE} }} finish {{ ambient 0 diffuse 0 emission 1 }} }}
"""
# A wall 20 mm behind the screen, striped along y: where a row shows it depends on the row's slope.
WALL, BAND = 20.0, 12.0   # a border every 6 mm (12 rows), of one kind every 24 rows
WALL_SCENE = f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
background {{ rgb <1, 0, 0> }}
plane {{ z, {WALL} pigment {{ gradient y color_map {{ [0 rgb 1] [0.5 rgb 1] [0.5 rgb <0, 0, 1>] [1 rgb <0, 0, 1>] }}
        scale {BAND} }} finish {{ ambient 0 diffuse 0 emission 1 }} }}
"""


def lenticular() -> LensArray:
    return LensArray("lenticular", 40, ROWS, 4 * PY, PY, F, Panel(160, ROWS, PY, PY))


# -- the rays of the mesh ---------------------------------------------------------------------------

def corner_rays(mesh) -> tuple[np.ndarray, np.ndarray]:
    """Every vertex's ray in mm: origin and direction (z = 1), after the mesh's ``scale``."""
    scale = np.array(mesh.scale)
    origin = mesh.vertices * scale
    direction = mesh.normals / scale
    return origin, direction / direction[:, 2:3]


def test_every_rows_ray_passes_through_the_eye_and_its_panel_point():
    """Each corner ray crosses z = -D at height 0 (the eye's) and z = f at its panel point's height, and
    keeps the orthographic ray's horizontal direction; the orthographic bank fails the first."""
    la = lenticular()
    vd = view_bank_shots(la, 144.0, viewing_distance=D)[0]
    origin, direction = corner_rays(vd)
    at_eye = origin[:, 1] + (-D - origin[:, 2]) * direction[:, 1]
    assert np.abs(at_eye).max() < 1e-9
    # Panel point: the corner's lens-row border (rows of PY mm, from the top), f behind the lens plane.
    at_panel = origin[:, 1] + (F - origin[:, 2]) * direction[:, 1]
    assert np.allclose(np.round(at_panel / PY * 2) / 2 * PY, at_panel, atol=1e-9)   # on a row border
    assert np.abs(at_panel).max() == pytest.approx(H_MM / 2)
    assert len(vd.faces) == 2 * 4 * ROWS // 2   # a face a view and two rows (``strip_rows``)
    ortho = view_bank_shots(la, 144.0)[0]
    o_origin, o_direction = corner_rays(ortho)
    assert set(np.round(o_direction[:, 0], 12)) == set(np.round(direction[:, 0], 12))   # the views' directions
    assert np.abs(o_origin[:, 1] + (-D - o_origin[:, 2]) * o_direction[:, 1]).max() > H_MM / 2 - 1


def traced_slopes(mesh) -> tuple[np.ndarray, np.ndarray]:
    """Per strip and row centre: the vertical slope POV-Ray traces (each written normal made a unit
    vector, then blended: measured, docs/geometry.md) and the exact one (the corners' slopes blended
    linearly, as the rows' slopes are linear in y)."""
    quads = len(mesh.faces) // 2
    normals = mesh.normals.reshape(quads, 4, 3)          # corners: bottom left, bottom right, top right, top left
    rows = np.abs(np.round((mesh.uvs.reshape(quads, 4, 2)[:, 2, 1] - mesh.uvs.reshape(quads, 4, 2)[:, 1, 1])
                           * mesh.image_size[1])).astype(int)
    scale = np.array(mesh.scale)
    traced, exact = [], []
    for q in range(quads):
        bottom, top = normals[q, 0], normals[q, 3]
        t = 1 - (np.arange(rows[q]) + 0.5) / rows[q]
        blend = (1 - t)[:, None] * bottom / np.linalg.norm(bottom) + t[:, None] * top / np.linalg.norm(top)
        d = blend / scale
        traced.append(d[:, 1] / d[:, 2])
        sb, st = (bottom / scale)[1] / (bottom / scale)[2], (top / scale)[1] / (top / scale)[2]
        exact.append((1 - t) * sb + t * st)
    return np.concatenate(traced), np.concatenate(exact)


def test_footprint_samples_of_rows_seen_from_the_eye_still_pass_through_it():
    """--quality high's samples: a sample's position in the row (ay) moves its crossing, its vertical
    angle (dv) is the eye's, so every corner ray still crosses z = -D at height 0; the orthographic
    bank's samples fan vertically by dv s_y / f (its negative control)."""
    la = lenticular()
    for mesh in view_bank_shots(la, 144.0, SAMPLES, gutter=1, viewing_distance=D):
        origin, direction = corner_rays(mesh)
        assert np.abs(origin[:, 1] + (-D - origin[:, 2]) * direction[:, 1]).max() < 1e-9
    origin, direction = corner_rays(view_bank_shots(la, 144.0, SAMPLES, gutter=1)[0])
    assert set(np.round(direction[:, 1], 9)) == {0.25 * PY / F, -0.125 * PY / F}


@pytest.mark.parametrize("preset, mapping, rows", [("ipad-retina", None, 623), ("alioscopy-42", None, 12),
                                                   ("philips-20", "philips", 1)])
def test_a_strip_of_rows_traces_every_rows_slope_within_the_tolerance(preset, mapping, rows):
    """Each preset's rows from its design distance: POV-Ray's blend of unit normals strays under 1e-6
    from every row's slope.  Negative control: faces half a view tall on philips-20's mapped views
    (1.53 mm rows) stray 1e-3 (a whole view, symmetric about the centre row, blends normals of one
    length: exact, but not once cropped or footprint-sampled)."""
    from povh3d.geometry import view_bank

    display = build_display(preset, mapping=mapping)
    la, distance = display.render_array, display.viewing_distance_mm
    assert view_bank.strip_rows(la, distance) == rows
    clearance = view_bank.eye_clearance(la, distance)
    traced, exact = traced_slopes(view_bank_shots(la, clearance, viewing_distance=distance)[0])
    assert len(traced) == la.views[1] * la.lenses_y
    assert np.abs(traced - exact).max() < view_bank.SLOPE_TOLERANCE
    if mapping is None:
        return
    whole = view_bank.strip_rows
    try:
        view_bank.strip_rows = lambda array, d: array.lenses_y // 2   # two faces a view
        traced, exact = traced_slopes(view_bank_shots(la, clearance, viewing_distance=distance)[0])
    finally:
        view_bank.strip_rows = whole
    assert np.abs(traced - exact).max() > 100 * view_bank.SLOPE_TOLERANCE


# The view bank of a custom lenticular array as the renderer wrote it before viewing distances existed
# (point-sampled; footprint-sampled with gutters): the digests of its arrays, taken from that code.
UNCHANGED = {(None, 0): "983fdef881ec1bda", ("samples", 1): "39fc3adf52ca9208"}


def bank_digest(meshes) -> str:
    h = hashlib.sha256()
    for m in meshes:
        for a in (m.vertices, m.normals, m.uvs, m.faces, *(m.kept or ())):
            h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


@pytest.mark.parametrize("samples, gutter", list(UNCHANGED))
def test_a_custom_array_without_a_viewing_distance_keeps_todays_bank_byte_for_byte(samples, gutter):
    la, given = lenticular(), None if samples is None else SAMPLES
    assert bank_digest(view_bank_shots(la, 160.0, given, gutter=gutter)) == UNCHANGED[samples, gutter]
    assert bank_digest(view_bank_shots(la, 160.0, given, gutter=gutter, viewing_distance=D)) != UNCHANGED[samples, gutter]


# -- what the request uses, and says ----------------------------------------------------------------

def request(tmp_path, preset="ipad-retina", **kw):
    display = build_display(preset, kw.pop("overrides", None), method=kw.get("method", "multi-ortho"))
    return RenderRequest(source=tmp_path / "s.pov", display=display, output=tmp_path / "o.png", **kw)


def test_presets_default_to_their_design_distance_and_custom_arrays_to_none(tmp_path):
    for preset, mm in (("ipad-retina", 846.0), ("philips-20", 800.0), ("alioscopy-42", 805.0)):
        r = request(tmp_path, preset)
        used, record = r.viewing()
        assert used == mm and r.method_options["viewing_distance"] == mm and record["mm"] == mm
        assert record["source"].startswith(f"preset {preset}: ")
    assert "thesis 4.6.1" in request(tmp_path, "philips-20").viewing()[1]["source"]
    custom = request(tmp_path, overrides={"ppl": 8})          # a custom array: orthographic rows
    assert custom.viewing()[0] is None and custom.method_options["viewing_distance"] is None
    assert request(tmp_path, "demo").viewing()[0] is None    # a square array
    assert request(tmp_path, viewing_distance=math.inf).viewing()[0] is None
    assert request(tmp_path, viewing_distance=300.0).viewing() == (300.0, {"mm": 300.0, "source": "given"})
    other = request(tmp_path, method="multi-ortho-views")   # its orthographic cameras: not applied, said so
    assert other.viewing()[0] is None and "multi-ortho-views traces orthographic rows" in other.viewing()[1]["source"]
    depth = request(tmp_path, depth_maps=tmp_path / "d")
    assert depth.viewing()[0] is None and "orthographic rows" in depth.viewing()[1]["source"]


@pytest.mark.parametrize("kw, words", [
    ({"viewing_distance": 300.0, "method": "pinhole"}, "multi-ortho"),
    ({"viewing_distance": 300.0, "depth_maps": "d"}, "orthographic rows"),
    ({"viewing_distance": -1.0}, "> 0"),
    ({"viewing_distance": float("nan")}, "> 0"),
])
def test_a_viewing_distance_it_cannot_trace_is_refused(tmp_path, kw, words):
    with pytest.raises(ConfigError, match=words):
        request(tmp_path, **kw)
    with pytest.raises(ConfigError, match="lenticular"):
        request(tmp_path, "demo", viewing_distance=300.0)


# -- rendered: the floor, the eye's 2D render, the replay -------------------------------------------

def render(cli, tmp_path, scene_text: str, name: str, *extra: str) -> tuple[np.ndarray, dict]:
    scene = tmp_path / f"{name}.pov"
    scene.write_text(scene_text)
    out = tmp_path / f"{name}.png"
    result = cli("render", scene, *ARRAY, "--quality", "draft", "-o", out, "-q", *extra)
    assert result.code == 0, result.err
    return read_png(out)[..., :3], json.loads(out.with_suffix(".json").read_text())


def classify(image: np.ndarray) -> np.ndarray:
    """0 red (sky), 1 white, 2 blue, -1 anything else (a mixed pixel)."""
    out = np.full(image.shape[:2], -1)
    for code, colour in enumerate((RED, WHITE, BLUE)):
        out[np.all(np.abs(image.astype(int) - colour) < 40, axis=-1)] = code
    return out


def floor_rows(distance: float = D, focal: float = F, pitch: float = PY, rows: int = ROWS,
               clearance: float = 144.0, depth_scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Per panel row, the colour the ray seen from ``distance`` shows (closed form: sky where it would
    meet the floor nearer than where rays start, ``clearance`` mm out) and whether it is clear of a
    stripe border, and of the start, by 0.3 mm of depth."""
    y_panel = (rows / 2 - np.arange(rows) - 0.5) * pitch
    crossing = y_panel * distance / (distance + focal)
    with np.errstate(divide="ignore"):
        z = distance * (FLOOR / np.abs(crossing) - 1) / depth_scale   # where the ray meets y = -FLOOR
    phase = np.mod(z / STRIPE, 1)
    sky = (crossing > 0) | (z * depth_scale < -clearance)
    colour = np.where(sky, 0, np.where(phase < 0.5, 1, 2))
    # Rows near the horizon meet the floor so far out that a slope 1e-6 off (the strips' tolerance, about
    # float32's on the mesh's normals) moves the hit by FLOOR / slope^2 * 1e-6: kept only under 0.3 mm.
    slope = np.abs(crossing) / distance
    with np.errstate(divide="ignore"):
        steady = FLOOR / slope ** 2 * 1e-6 < 0.3
    clear = (crossing > 0) | ((np.minimum(np.abs(phase - 0.5), np.minimum(phase, 1 - phase)) * STRIPE > 0.3)
                             & (np.abs(z * depth_scale + clearance) > 0.3) & steady)
    return colour, clear


@pytest.mark.povray
def test_every_row_shows_the_floor_where_its_ray_from_the_eye_meets_it(cli, tmp_path):
    colour, clear = floor_rows()
    image, record = render(cli, tmp_path, FLOOR_SCENE, "vd", "--viewing-distance", str(D))
    assert record["display"]["viewing_distance"] == {"mm": D, "source": "given"}
    assert record["quality"]["front_clearance_mm"] < D   # rays start at the eye
    seen = classify(image)
    assert clear.sum() > 100 and (colour[clear] != 0).sum() > 50
    assert np.array_equal(seen[clear], np.broadcast_to(colour[clear, None], seen[clear].shape))
    # Negative control: the orthographic rows of the same display (no flag) never meet the floor.
    ortho, record = render(cli, tmp_path, FLOOR_SCENE, "ortho")
    assert "viewing_distance" not in record["display"]
    assert (classify(ortho)[clear] == colour[clear, None]).mean() < 0.6


def eye_render(tmp_path, scene_text: str, name: str, width: int, height: int) -> np.ndarray:
    """POV-Ray alone: a perspective camera at the eye (0, 0, -D) whose picture is the lens plane's
    W x H mm window, pixel (col, row) through ((col + 0.5 - w/2) W / w, (h/2 - row - 0.5) H / h, 0)."""
    path = tmp_path / f"{name}.pov"
    path.write_text(scene_text + f"camera {{ perspective location <0, 0, {-D}> direction <0, 0, {D}> "
                                 f"right <{W_MM}, 0, 0> up <0, {H_MM}, 0> }}\n")
    out = tmp_path / f"{name}.png"
    subprocess.run(["povray", f"+I{path}", f"+O{out}", f"+W{width}", f"+H{height}", "-A", "-D", "+FN8",
                    "File_Gamma=sRGB"], check=True, capture_output=True)
    return read_png(out)[..., :3]


@pytest.mark.povray
def test_the_floor_shows_where_the_eyes_2d_render_shows_floor(cli, tmp_path):
    image, _ = render(cli, tmp_path, FLOOR_SCENE, "vd", "--viewing-distance", str(D))
    eye = classify(eye_render(tmp_path, FLOOR_SCENE, "eye", 160, ROWS))
    floor_2d = (eye != 0).all(axis=1)            # the rows the eye sees floor across
    assert 50 < floor_2d.sum() < ROWS
    assert (classify(image)[floor_2d] != 0).all()
    ortho, _ = render(cli, tmp_path, FLOOR_SCENE, "ortho")
    assert (classify(ortho)[floor_2d] == 0).all()   # negative control: sky in every one of those rows


def stripe_offsets(seen: np.ndarray, expected: np.ndarray) -> float:
    """The largest distance (rows) from a stripe border of ``expected``'s centre column to the nearest
    border of the same kind (white to blue, or blue to white) of ``seen``'s."""
    def borders(image):
        column = classify(image)[:, image.shape[1] // 2]
        at = np.flatnonzero((column[1:] != column[:-1]) & (column[1:] > 0) & (column[:-1] > 0))
        return at + 0.5, column[at]
    (a, kind_a), (b, kind_b) = borders(expected), borders(seen)
    assert len(a) >= 8 and len(b) >= 1
    apart = np.abs(a[:, None] - b[None, :]) + np.where(kind_a[:, None] == kind_b[None, :], 0, np.inf)
    return float(apart.min(axis=1).max())


@pytest.mark.povray
def test_the_replay_from_the_eye_lines_up_with_its_2d_render_within_a_row(cli, tmp_path):
    """``povh3d replay --eye 0,0,-D`` of the render, picture 160 x 120 (one picture row a panel row):
    every stripe border of the wall within one row of the eye's 2D render; the orthographic rows are off
    by ``y WALL / D`` at height y: 4 mm, 8 rows, at the top and bottom."""
    expected = eye_render(tmp_path, WALL_SCENE, "eye", 160, ROWS)
    offsets = {}
    for name, extra in (("vd", ("--viewing-distance", str(D))), ("ortho", ())):
        render(cli, tmp_path, WALL_SCENE, name, *extra)
        picture = tmp_path / f"{name}-eye.png"
        result = cli("replay", tmp_path / f"{name}.png", "--eye", f"0,0,{-D}", "--size", f"160x{ROWS}",
                     "-o", picture)
        assert result.code == 0, result.err
        offsets[name] = stripe_offsets(read_png(picture)[..., :3], expected)
    assert offsets["vd"] <= 1.0
    assert offsets["ortho"] >= 6.0


@pytest.mark.povray
def test_replay_puts_its_default_eye_where_the_rows_were_rendered_for(cli, tmp_path):
    render(cli, tmp_path, WALL_SCENE, "vd", "--viewing-distance", str(D))
    render(cli, tmp_path, WALL_SCENE, "ortho")
    for name, distance in (("vd", D), ("ortho", 300.0)):   # the orthographic rows: replay's own default
        report = tmp_path / f"{name}.json"
        assert cli("replay", tmp_path / f"{name}.png", "-o", tmp_path / f"{name}-r.png", "--json", report).code == 0
        assert json.loads(report.read_text())["eyes"][0]["eye_mm"] == [0.0, 0.0, -distance]



@pytest.mark.povray
def test_a_lenticular_preset_shows_the_floor_as_seen_from_its_design_distance(cli, tmp_path):
    """ipad-retina (a 600 x 480 pixel window of it: 100 lenses, 480 rows of 0.096 mm) with no option: its
    rows seen from 846 mm, each showing the floor's stripe where that ray meets it (closed form); the
    orthographic rows (``--viewing-distance inf``) never meet the floor."""
    colour, clear = floor_rows(846.0, 1.25, 0.096, 480, clearance=840.0)   # rays from near the eye
    scene = tmp_path / "floor.pov"
    scene.write_text(FLOOR_SCENE)
    seen = {}
    for name, extra in (("preset", ()), ("ortho", ("--viewing-distance", "inf"))):
        out = tmp_path / f"{name}.png"
        result = cli("render", scene, "--preset", "ipad-retina", "--panel", "600x480", "--quality", "draft",
                     "--front-clearance", "840", "-o", out, "-q", *extra)
        assert result.code == 0, result.err
        seen[name] = classify(read_png(out)[..., :3])
        record = json.loads(out.with_suffix(".json").read_text())
        assert record["quality"]["front_clearance_mm"] == 840.0
    assert record["display"]["viewing_distance"] == {"mm": None, "source": "given: infinite (orthographic rows)"}
    assert clear.sum() > 300 and (colour[clear] != 0).sum() > 150
    assert np.array_equal(seen["preset"][clear], np.broadcast_to(colour[clear, None], seen["preset"][clear].shape))
    assert (seen["ortho"][clear] == colour[clear, None]).mean() < 0.6


@pytest.mark.parametrize("args, words", [
    (("--preset", "demo", "--viewing-distance", "300"), "--viewing-distance renders the rows of a lenticular sheet"),
    (("--preset", "ipad-retina", "--method", "pinhole", "--viewing-distance", "300"), "--method multi-ortho"),
    (("--preset", "ipad-retina", "--viewing-distance", "300", "--depth-maps", "d"), "--depth-maps measures"),
    (("--preset", "ipad-retina", "--viewing-distance", "far"), "mm or inf"),
    (("--preset", "ipad-retina", "--viewing-distance", "0"), "> 0"),
    (("--preset", "ipad-retina", "--viewing-distance", "5"), "inside the view bank's first step"),
])
def test_the_command_refuses_a_viewing_distance_it_cannot_trace_in_one_line(cli, tmp_path, args, words):
    from tests.support.cli import one_error_line

    scene = tmp_path / "s.pov"
    scene.write_text(FLOOR_SCENE)
    out = tmp_path / "o.png"
    line = one_error_line(cli("render", scene, *args, "--quality", "draft", "-o", out))
    assert words in line and not out.exists()


@pytest.mark.povray
def test_rows_seen_from_the_eye_of_a_depth_compressed_scene(cli, tmp_path):
    """--depth-scale 0.5: the floor's stripes where the eye at D meets the floor compressed to half its
    depth (its rays from D / k = 300 mm in the scene itself); without the compression's eye the stripes
    of the uncompressed floor (the negative control) disagree."""
    image, record = render(cli, tmp_path, FLOOR_SCENE, "ds", "--viewing-distance", str(D), "--depth-scale", "0.5")
    seen = classify(image)
    colour, clear = floor_rows(depth_scale=0.5, clearance=record["quality"]["front_clearance_mm"] * 0.5)
    assert clear.sum() > 100
    assert np.array_equal(seen[clear], np.broadcast_to(colour[clear, None], seen[clear].shape))
    wrong, near = floor_rows()
    both = clear & near & (colour != 0)
    assert (seen[both] == wrong[both, None]).mean() < 0.7


def test_a_sidecar_gives_back_the_distance_its_rows_were_rendered_for():
    from povh3d.display.display import Display

    la = lenticular()
    record = {"lens_array": la.as_record(), "display": {"preset": None, "viewing_distance": {"mm": D, "source": "given"}}}
    assert Display.from_record(record).viewing_distance_mm == D
    record["display"]["viewing_distance"] = {"mm": None, "source": "given: infinite (orthographic rows)"}
    assert Display.from_record(record).viewing_distance_mm is None
    for damaged in ("far", -3.0, float("nan"), True):
        record["display"]["viewing_distance"] = {"mm": damaged}
        with pytest.raises(ConfigError, match="viewing distance"):
            Display.from_record(record)

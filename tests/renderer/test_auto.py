"""Run time against error: the footprint reference that --quality auto scores against, and auto."""

from dataclasses import replace

import numpy as np
import pytest

from povh3d.image.colour import decode, linear_to_srgb
from povh3d.errors import ConfigError
from povh3d.geometry.footprint import latin_hypercube
from povh3d.geometry.rays import pixel_rays
from povh3d.renderer.methods.registry import run_method
from povh3d.renderer.methods.auto import (AUTO_LADDER, FULL_IMAGE_PIXELS, full_image_auto, probe_window, resolve_auto,
                                window_offset)
from povh3d.renderer.methods.auto_seeds import SeedRuns, view_labels, view_seeds
from povh3d.errors import RenderInterrupted
from povh3d.geometry.view_bank import view_bank_shots
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.metrics import Reference
from povh3d.renderer.methods.quality import Quality, RenderSettings
from povh3d.scene.scene import load_scene

from tests.conftest import SAMPLE
from tests.support.arrays import lenticular_array, square_array
from tests.support.scenes import COLOUR_A, COLOUR_B, write_checker_plane, write_textured_scene

Z0, PERIOD = 3.3, 0.37  # a fine checker: every pixel's footprint straddles edges


def footprint_oracle(la, samples):
    """The mean linear colour over ``samples`` of each pixel's footprint (docs/geometry.md):
    the ray through c + (ax px, ay py) with direction (u + du s, v + dv s, f) meets
    z = Z0 at c + a + Z0 (u + du s, v + dv s) / f."""
    centres, dirs, _ = pixel_rays(la)
    uv = dirs[..., :2] / dirs[..., 2:] * la.focal
    if la.grid == "lenticular":
        centres = centres.copy()
        centres[..., 1] = la.panel.pixel_centres()[1][:, None]
    total = np.zeros(centres.shape[:2] + (3,))
    for ax, ay, du, dv in samples:
        x = centres[..., 0] + ax * la.pitch_x + Z0 * (uv[..., 0] + du * la.panel.pitch_x) / la.focal
        y = centres[..., 1] + ay * la.pitch_y + Z0 * (uv[..., 1] + dv * la.panel.pitch_y) / la.focal
        parity = (np.floor(x / PERIOD) + np.floor(y / PERIOD)) % 2
        total += np.where(parity[..., None] == 0, COLOUR_A, COLOUR_B)
    return total / len(samples)


@pytest.mark.povray
@pytest.mark.parametrize("la", [square_array(lx=8, ly=6, nx=4, ny=4), lenticular_array(lx=8, rows=12, nx=4)],
                         ids=["square", "lenticular"])
def test_footprint_samples_integrate_each_pixels_footprint(tmp_path, la):
    scene = load_scene(write_checker_plane(tmp_path, Z0, PERIOD))
    quality = Quality(footprint=24, seed=3)
    got = run_method("multi-ortho", scene, la, RenderSettings(quality=quality, bit_depth=16)).h3d
    expected = footprint_oracle(la, latin_hypercube(24, 3))
    err = np.abs(decode(got) - expected)
    # One sample of 24 on the wrong side of an edge moves a channel by up to 1/24.
    assert np.mean(err < 0.01) > 0.99 and err.max() < 0.05
    # Negative controls: the point-sampled render, and other samples, are not this integral.
    point = run_method("multi-ortho", scene, la, RenderSettings(quality="draft", bit_depth=16)).h3d
    assert np.mean(np.abs(decode(point) - expected) < 0.01) < 0.6
    assert np.mean(np.abs(footprint_oracle(la, latin_hypercube(24, 4)) - expected) < 0.01) < 0.6


@pytest.fixture(scope="module")
def textured(tmp_path_factory):
    return load_scene(write_textured_scene(tmp_path_factory.mktemp("bench")))


@pytest.mark.povray
def test_auto_quality_probe_path_for_methods_without_footprint_samples(textured):
    """pinhole cannot split footprint samples: the probe window and its two-seed reference."""
    la = square_array(lx=10, ly=8, nx=4, ny=4)
    reports: list[tuple[int, int]] = []
    settings, choice = resolve_auto(textured, la, "pinhole", RenderSettings(quality="auto", max_error_db=20),
                                    lambda done, total: reports.append((done, total)))
    assert settings.quality == choice.quality and settings.max_error_db is None and choice.image is None
    assert choice.reference_floor_db >= 20
    assert all("footprint" not in s for s, _ in choice.tried)
    ladder = list(dict.fromkeys(q.point_sampled() for q in AUTO_LADDER))
    assert reports == [(k, 1 + len(ladder)) for k in range(1, 2 + len(choice.tried))]
    scores = {label: p for label, p in choice.tried}
    chosen = ladder.index(choice.quality)
    assert scores[choice.quality.label] >= 20
    assert all(scores[q.label] < 20 for q in ladder[:chosen] if q.label in scores)


def test_per_view_samples_move_only_their_own_view():
    """auto's seeds give each view its own footprint samples (``auto_seeds.view_seeds``): the
    same sample in every view is the one-sample-per-bank mesh; another sample in one view moves
    only that view's quad."""
    la = square_array(lx=5, ly=3, nx=3, ny=2)
    samples = latin_hypercube(4, seed=5)
    shared = view_bank_shots(la, 40.0, samples)
    per_view = np.broadcast_to(samples[:, None, None, :], (4, 2, 3, 4)).copy()
    same = view_bank_shots(la, 40.0, per_view)
    assert all(np.array_equal(a.vertices, b.vertices) and np.array_equal(a.normals, b.normals)
               for a, b in zip(shared, same))
    per_view[2, 1, 0] = latin_hypercube(1, seed=9)[0]   # bank 2, view row 1, column 0
    moved = view_bank_shots(la, 40.0, per_view)
    differ = sum(int(np.any(a.vertices != b.vertices, axis=1).sum() + np.any(a.normals != b.normals, axis=1).sum())
                 for a, b in zip(shared, moved))
    assert 0 < differ <= 8   # one quad's four corners, origin and direction
    seeds = view_seeds(4, 1, (2, 3))
    assert seeds.shape == (4, 2, 3, 4) and not np.array_equal(seeds[:, 0, 0], seeds[:, 0, 1])


@pytest.mark.povray
@pytest.mark.parametrize("grid", ["square", "hex"])
def test_the_probe_is_a_window_of_the_full_render(grid):
    """sample.pov fits itself to the declared panel (``Povh3d_Panel_Width``): the probe
    renders the central lenses with the real panel declared, a crop of the full render."""
    la = (square_array(lx=20, ly=16, nx=4, ny=4) if grid == "square" else
          LensArray("hex", 20, 16, 0.6, 0.6 * np.sqrt(3) / 2, 1.5, Panel(123, 84, 0.1, 0.1)))
    scene = load_scene(SAMPLE)
    window, mask = probe_window(la, (6, 4))
    (r0, c0), (h, w) = window_offset(la, window), mask.shape
    draft = RenderSettings(quality="draft", use_cache=False)
    full = run_method("multi-ortho", scene, la, draft).h3d[r0:r0 + h, c0:c0 + w]
    probe = run_method("multi-ortho", scene, window, draft, declared=la).h3d
    differ = np.mean(np.any(probe[mask] != full[mask], axis=-1))
    # Square view banks are written in lens pitches, exact in POV-Ray's float32 mesh; a hex lens
    # mesh in mm rounds its vertices by position, moving a ray that grazes an edge (5 of 676 pixels).
    assert mask.mean() > 0.75 and differ <= (0.0 if grid == "square" else 0.01)
    # Negative control: the window declaring its own, smaller panel (the probe before) shrinks the scene.
    own = run_method("multi-ortho", scene, window, draft).h3d
    assert np.mean(np.any(own[mask] != full[mask], axis=-1)) > 0.3


@pytest.fixture(scope="module")
def full_reference(textured):
    """A converged reference of the full 10 x 8-lens, 8 x 8-view image: two seeds of 512 footprint samples.
    (auto's estimate is as good as its views are many: each has samples of its own, and on 4 x 4 views
    it scattered by 0.65 dB about the image's score at 4 samples a seed, over six seed pairs.)"""
    la = square_array(lx=10, ly=8, nx=8, ny=8)
    return la, Reference(*(run_method("multi-ortho", textured, la, RenderSettings(
        quality=Quality(footprint=512, seed=seed), bit_depth=16)).h3d for seed in (1, 2)))


@pytest.mark.povray
@pytest.mark.parametrize("target", [25, 35])
def test_auto_meets_the_target_on_the_full_image(textured, full_reference, target):
    """The image auto writes (rendered while choosing, on the full image), scored against an
    independent converged reference, reaches the target within 0.2 dB, and auto's own estimate
    of it (its seeds' difference) is within 0.5 dB of that score; draft, the negative control,
    misses the target by far on the same reference."""
    la, reference = full_reference
    assert reference.floor_db > target + 3
    reports: list[tuple[int, int]] = []
    settings, choice = resolve_auto(textured, la, "multi-ortho", RenderSettings(quality="auto", max_error_db=target),
                                    lambda done, total: reports.append((done, total)))
    assert settings.quality == choice.quality and settings.max_error_db is None and choice.image is not None
    got = reference.psnr(choice.image.h3d)
    assert got >= target - 0.2, f"{choice.quality.label}: {got:.2f} dB on the full image"
    label, estimate = choice.tried[-1]
    assert label == choice.quality.label.split(", ")[-1] or label == "draft"
    assert abs(estimate - got) < 0.5, f"estimated {estimate:.2f} dB, {got:.2f} dB against the reference"
    # every run before the last fell short of the target: no run more than needed
    assert all(p < target for _, p in choice.tried[:-1])
    assert [done for done, _ in reports] == list(range(1, len(reports) + 1))
    draft = run_method("multi-ortho", textured, la, RenderSettings(quality="draft", bit_depth=16)).h3d
    assert reference.psnr(draft) < target - 3


@pytest.mark.povray
def test_auto_refuses_a_target_past_its_samples(textured):
    la = square_array(lx=10, ly=8, nx=4, ny=4)
    with pytest.raises(ConfigError, match=r"noise floor .* use max_error_db [0-9.]+ or less"):
        resolve_auto(textured, la, "multi-ortho", RenderSettings(quality="auto", max_error_db=99))
    with pytest.raises(ConfigError, match=r"1024 footprint samples reach .* use max_error_db [0-9.]+ or less"):
        resolve_auto(textured, la, "multi-ortho", RenderSettings(quality="auto", max_error_db=80, bit_depth=16))


@pytest.mark.povray
def test_a_seed_continued_in_a_later_run_is_the_seed_drawn_at_once(textured):
    """auto's later runs continue each seed's Sobol' sequence (``view_seeds(..., start)``): the first
    run's samples and the next run's, weighted by their counts, make the very image of the whole
    sequence traced in one run; another seed, the control, differs.  ``RenderSettings.should_stop``
    stops a run where it returns True (RenderInterrupted) and not where it returns False."""
    la = square_array(lx=6, ly=4, nx=2, ny=2)
    base = RenderSettings(quality=Quality(footprint=1), bit_depth=16, use_cache=False)
    assert np.array_equal(view_seeds(5, 1, (2, 2)), view_seeds(8, 1, (2, 2))[:5])
    assert np.array_equal(view_seeds(3, 1, (2, 2), start=5), view_seeds(8, 1, (2, 2))[5:])
    once = run_method("multi-ortho", textured, la, base, footprint_groups=[view_seeds(8, 1, (2, 2))]).groups[0]
    parts = run_method("multi-ortho", textured, la, base, footprint_groups=[
        view_seeds(5, 1, (2, 2)), view_seeds(3, 1, (2, 2), start=5)]).groups
    assert np.allclose((5 * parts[0] + 3 * parts[1]) / 8, once, atol=1e-6)
    other = run_method("multi-ortho", textured, la, base, footprint_groups=[view_seeds(8, 2, (2, 2))]).groups[0]
    assert not np.allclose(other, once, atol=1e-3)
    groups = [view_seeds(3, 1, (2, 2)), view_seeds(3, 2, (2, 2))]
    with pytest.raises(RenderInterrupted):
        run_method("multi-ortho", textured, la, replace(base, should_stop=lambda: True), footprint_groups=groups)
    here = run_method("multi-ortho", textured, la, base, footprint_groups=groups)
    assert np.array_equal(run_method("multi-ortho", textured, la, replace(base, should_stop=lambda: False),
                                     footprint_groups=groups).h3d, here.h3d)


def test_auto_renders_the_full_image_only_where_it_can_split_samples_and_hold_them():
    small = square_array(lx=20, ly=15, nx=8, ny=8)
    assert full_image_auto("multi-ortho", small)
    assert not full_image_auto("pinhole", small)   # no footprint samples: the probe
    big = square_array(lx=250, ly=150, nx=8, ny=8)   # 2000 x 1200 pixels: the probe window
    assert big.panel.width * big.panel.height > FULL_IMAGE_PIXELS and not full_image_auto("multi-ortho", big)


def test_auto_needs_a_target_and_a_target_needs_auto():
    with pytest.raises(ConfigError, match="max_error_db"):
        RenderSettings(quality="auto")
    with pytest.raises(ConfigError, match="quality auto"):
        RenderSettings(quality="normal", max_error_db=30)


def test_view_labels_give_each_pixel_of_a_lens_cell_its_own_view():
    la = square_array(lx=5, ly=3, nx=3, ny=2)
    labels = view_labels(la)
    rows, cols = la.bank_region
    bank = labels[rows, cols]
    cells = bank.reshape(3, 2, 5, 3).transpose(0, 2, 1, 3).reshape(15, 6)   # (lens, pixel of its cell)
    assert all(sorted(cell) == list(range(6)) for cell in cells)
    assert np.all(cells == cells[0])   # the same pixel of every cell: the same view
    assert np.all(labels[:, :cols.start] == -1) and np.all(labels[:, cols.stop:] == -1)


def test_the_error_bound_is_the_seeds_error_one_standard_error_high():
    """``SeedRuns.error_bound``: a quarter of the seeds' mean squared difference (sRGB codes), plus one
    standard error from the views' independent shares; views that differ alike add nothing (the
    control), one view that differs alone adds its spread."""
    la = square_array(lx=4, ly=4, nx=2, ny=2)
    labels = view_labels(la)
    h, w = labels.shape
    a = np.full((h, w, 3), 0.2)
    runs = SeedRuns(labels, sums=[a, a + 0.0], counts=[1])
    assert runs.error_bound() == 0.0
    coded = np.rint(linear_to_srgb(np.array([0.2, 0.3])) * 65535) / 65535
    d2 = (coded[1] - coded[0]) ** 2
    even = a.copy()
    even[labels >= 0] = 0.3   # every view's pixels differ alike
    runs = SeedRuns(labels, sums=[a, even], counts=[1])
    plain = d2 * (labels >= 0).sum() / labels.size / 4
    assert runs.error_bound() == pytest.approx(plain, rel=1e-6)
    one = a.copy()
    one[labels == 0] = 0.3   # one view of four differs
    runs = SeedRuns(labels, sums=[a, one], counts=[1])
    per_view = np.array([d2 * (labels == 0).sum(), 0, 0, 0])
    expected = (per_view.sum() + 2 * np.std(per_view, ddof=1)) / labels.size / 4
    # one view's share of four, alone: its standard error is as large as the estimate itself
    assert runs.error_bound() == pytest.approx(expected, rel=1e-6) == 2 * per_view.sum() / labels.size / 4

"""Run time against error: the footprint reference that --quality auto scores against, and auto."""

from dataclasses import replace

import numpy as np
import pytest

from povh3d.image.colour import decode
from povh3d.errors import ConfigError
from povh3d.geometry.footprint import latin_hypercube
from povh3d.geometry.rays import pixel_rays
from povh3d.engine.methods import run_method
from povh3d.engine.auto import AUTO_LADDER, probe_window, resolve_auto, window_offset
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.metrics import Reference
from povh3d.engine.quality import Quality, RenderSettings
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
def test_auto_quality_takes_the_first_rung_that_meets_the_target(textured):
    la = square_array(lx=10, ly=8, nx=4, ny=4)
    reports: list[tuple[int, int]] = []
    settings, choice = resolve_auto(textured, la, "multi-ortho", RenderSettings(quality="auto", max_error_db=30),
                                    lambda done, total: reports.append((done, total)))
    assert settings.quality == choice.quality and settings.max_error_db is None
    assert choice.reference_floor_db >= 30
    # the probe's progress: the reference, then each rung tried, out of the whole ladder
    assert reports == [(k, 1 + len(AUTO_LADDER)) for k in range(1, 2 + len(choice.tried))]
    scores = {label: p for label, p in choice.tried}
    chosen = AUTO_LADDER.index(choice.quality)
    assert scores[choice.quality.label] >= 30
    # every rung below the choice that was tried misses; the one just below it was tried
    below = [q.label for q in AUTO_LADDER[:chosen]]
    assert all(scores[label] < 30 for label in below if label in scores)
    assert chosen == 0 or below[-1] in scores
    with pytest.raises(ConfigError, match=r"noise floor .* use --max-error [0-9.]+ or less"):
        resolve_auto(textured, la, "multi-ortho", RenderSettings(quality="auto", max_error_db=99))
    # A method without footprint samples tries only what it can render.
    _, choice = resolve_auto(textured, la, "pinhole", RenderSettings(quality="auto", max_error_db=20))
    assert all("footprint" not in s for s, _ in choice.tried)


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


@pytest.mark.povray
@pytest.mark.parametrize("target", [25, 35])
def test_auto_meets_the_target_on_the_full_image(textured, target):
    """The full image at the chosen level, scored against a converged reference of the full
    image (two seeds of 1024 samples), reaches the target within 0.2 dB; the rung below does not
    clear it by more than the probe's precision."""
    la = square_array(lx=20, ly=16, nx=4, ny=4)   # the probe sees its central 16 x 12 lenses
    settings, choice = resolve_auto(textured, la, "multi-ortho", RenderSettings(quality="auto", max_error_db=target))
    reference = Reference(*(run_method("multi-ortho", textured, la, RenderSettings(
        quality=Quality(footprint=1024, seed=seed), bit_depth=16)).h3d for seed in (1, 2)))
    assert reference.floor_db > target + 3
    got = reference.psnr(run_method("multi-ortho", textured, la, settings).h3d)
    assert got >= target - 0.2, f"{choice.quality.label}: {got:.2f} dB on the full image"
    chosen = AUTO_LADDER.index(choice.quality)
    if chosen:
        below = reference.psnr(run_method("multi-ortho", textured, la,
                                          replace(settings, quality=AUTO_LADDER[chosen - 1])).h3d)
        # within the probe's precision (the window is the centre; a 24-sample render's PSNR moves
        # ~0.1 dB with its seed): measured 35.21 dB on the full image where the window gave under 35.1
        assert below < target + 0.5, f"{AUTO_LADDER[chosen - 1].label} already reaches {below:.2f} dB"


def test_auto_needs_a_target_and_a_target_needs_auto():
    with pytest.raises(ConfigError, match="--max-error"):
        RenderSettings(quality="auto")
    with pytest.raises(ConfigError, match="--quality auto"):
        RenderSettings(quality="normal", max_error_db=30)

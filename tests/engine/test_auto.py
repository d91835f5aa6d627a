"""Run time against error: the footprint reference that --quality auto scores against, and auto."""

import numpy as np
import pytest

from povh3d.image.colour import decode
from povh3d.errors import ConfigError
from povh3d.geometry.footprint import latin_hypercube
from povh3d.geometry.rays import pixel_rays
from povh3d.engine.methods import run_method
from povh3d.engine.auto import AUTO_LADDER, resolve_auto
from povh3d.engine.quality import Quality, RenderSettings
from povh3d.scene.scene import load_scene

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
    psnrs = [p for _, p in choice.tried]
    # the probe's progress: the reference, then each rung tried, out of the whole ladder
    assert reports == [(k, 1 + len(AUTO_LADDER)) for k in range(1, 2 + len(psnrs))]
    assert psnrs[-1] >= 30 and all(p < 30 for p in psnrs[:-1])
    assert choice.quality == AUTO_LADDER[len(psnrs) - 1]
    with pytest.raises(ConfigError, match="lower --max-error"):
        resolve_auto(textured, la, "multi-ortho", RenderSettings(quality="auto", max_error_db=99))
    # A method without footprint samples tries only what it can render.
    _, choice = resolve_auto(textured, la, "pinhole", RenderSettings(quality="auto", max_error_db=20))
    assert all("footprint" not in s for s, _ in choice.tried)


def test_auto_needs_a_target_and_a_target_needs_auto():
    with pytest.raises(ConfigError, match="--max-error"):
        RenderSettings(quality="auto")
    with pytest.raises(ConfigError, match="--quality auto"):
        RenderSettings(quality="normal", max_error_db=30)


def test_probe_reference_is_10_db_better_than_the_target_where_256_samples_allow():
    # Two 256-sample references differ by 43.4 dB (bench), each ~46.4 dB from the converged
    # image, 3 dB per halving: the probe takes the fewest samples 10 dB under the target.
    from povh3d.engine.auto import probe_reference_samples

    def error_db(n):
        return 46.4 - 3.0 * np.log2(256 / n)

    targets = [15, 25, 29, 30, 33, 35, 38, 45]
    samples = [probe_reference_samples(t) for t in targets]
    assert samples == sorted(samples) and set(samples) <= {32, 64, 128, 256}
    for t, n in zip(targets, samples):
        assert n == 256 or error_db(n) >= t + 10
        assert n == 32 or error_db(n // 2) < t + 10          # and no more than that

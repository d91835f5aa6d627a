import numpy as np
import pytest

from povh3d.image.metrics import pareto_front, psnr, ssim


def test_psnr_matches_its_definition():
    ref = np.full((8, 8, 3), 100, np.uint8)
    img = ref.copy()
    img[0, 0, 0] = 110  # one error of 10/255 over 192 values
    expected = 10 * np.log10(1 / ((10 / 255) ** 2 / 192))
    assert psnr(img, ref) == pytest.approx(expected)
    assert psnr(ref, ref) == float("inf")
    assert ssim(ref, ref) == pytest.approx(1.0)
    rng = np.random.default_rng(0)
    noisy = np.clip(ref + rng.normal(0, 20, ref.shape), 0, 255).astype(np.uint8)
    assert ssim(noisy, ref) < 0.9


def test_pareto_front_keeps_only_undominated_trials():
    seconds = np.array([1.0, 2.0, 2.0, 3.0, 0.5])
    db = np.array([20.0, 25.0, 24.0, 25.0, 10.0])
    np.testing.assert_array_equal(pareto_front(seconds, db), [True, True, False, False, True])

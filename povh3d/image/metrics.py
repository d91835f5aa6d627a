"""Image error figures and the time-versus-error Pareto front (pure NumPy)."""

from __future__ import annotations

import numpy as np


def _unit(image: np.ndarray) -> np.ndarray:
    """Integer image to float in ``[0, 1]`` (still sRGB-encoded: errors as a viewer sees them)."""
    return np.asarray(image, dtype=np.float64) / float(np.iinfo(image.dtype).max)


def psnr(image: np.ndarray, reference: np.ndarray) -> float:
    """Peak signal-to-noise ratio in dB of two integer images of one shape; inf if equal."""
    if image.shape != reference.shape:
        raise ValueError(f"images differ in shape: {image.shape} and {reference.shape}")
    mse = float(np.mean((_unit(image) - _unit(reference)) ** 2))
    return float("inf") if mse == 0 else 10.0 * np.log10(1.0 / mse)


def ssim(image: np.ndarray, reference: np.ndarray) -> float:
    """Structural similarity (scikit-image, 7x7 window) of two integer images, over channels."""
    a, b = _unit(image), _unit(reference)
    from ..extras import require

    # scikit-image (and SciPy): only when SSIM is asked for
    structural_similarity = require("skimage.metrics", "analysis", "SSIM").structural_similarity

    return float(structural_similarity(a, b, data_range=1.0, channel_axis=-1 if a.ndim == 3 else None))


def pareto_front(seconds: np.ndarray, error_db: np.ndarray) -> np.ndarray:
    """Which trials no other trial beats in both time and PSNR.

    Parameters
    ----------
    seconds : (n,) float     wall time, lower is better
    error_db : (n,) float    PSNR, higher is better

    Returns
    -------
    (n,) bool
    """
    t, q = np.asarray(seconds, float), np.asarray(error_db, float)
    # i is dominated if some j is no slower and no worse, and strictly better in one.
    no_worse = (t[None, :] <= t[:, None]) & (q[None, :] >= q[:, None])
    better = (t[None, :] < t[:, None]) | (q[None, :] > q[:, None])
    return ~np.any(no_worse & better, axis=1)


class Reference:
    """A converged reference made of two renders that differ only in their random seed.

    ``floor_db`` is the PSNR between the two: the reference's own noise floor.  The
    reference is their mean (in sRGB-coded values, as PSNR sees them), whose own mean
    squared error is a quarter of the two renders' mean squared difference; ``psnr``
    takes it off, so a setting is scored against the converged image, not the noise.
    """

    def __init__(self, first: np.ndarray, second: np.ndarray, mask: np.ndarray | None = None) -> None:
        if first.shape != second.shape:
            raise ValueError(f"references differ in shape: {first.shape} and {second.shape}")
        self.mask = np.ones(first.shape[:2], bool) if mask is None else np.asarray(mask, bool)
        a, b = _unit(first)[self.mask], _unit(second)[self.mask]
        between = float(np.mean((a - b) ** 2))
        self.floor_db = float("inf") if between == 0 else 10.0 * np.log10(1.0 / between)
        self.image = (a + b) / 2
        self.noise_mse = between / 4

    def psnr(self, image: np.ndarray) -> float:
        """PSNR in dB of ``image`` (integer, the references' shape) against the converged image."""
        mse = float(np.mean((_unit(image)[self.mask] - self.image) ** 2)) - self.noise_mse
        return float("inf") if mse <= 0 else 10.0 * np.log10(1.0 / mse)

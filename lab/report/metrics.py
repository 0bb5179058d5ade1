"""Image metrics against a reference, on a stated tonemap.

Linear radiance is tonemapped by clipping to [0, 1] and applying the sRGB transfer curve
(:func:`tonemap`); SSIM (scikit-image, Gaussian-weighted as Wang et al. 2004, data_range = 1,
channel_axis = 2) and PSNR (data_range = 1) are computed on the tonemapped images, so both
measure what a viewer sees. The tonemap is recorded in every report.
"""
from __future__ import annotations

import numpy as np
from skimage.metrics import peak_signal_noise_ratio, structural_similarity

TONEMAP = "srgb(clip(x, 0, 1))"
# Two seeds of a reference must agree at least this well (SSIM) for it to validate a method: below
# it the reference's own noise is as large as the errors a report should tell apart (LSR18: 0.97).
CONVERGED_FLOOR = 0.98


def tonemap(linear: np.ndarray) -> np.ndarray:
    """Linear RGB -> display sRGB in [0, 1] (clip, then the sRGB transfer curve)."""
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def _check(image, reference):
    if image.shape != reference.shape:
        raise ValueError(f"image shape {image.shape} differs from reference shape {reference.shape}")


def ssim(image: np.ndarray, reference: np.ndarray) -> float:
    """SSIM of two linear RGB images (H, W, 3) after :func:`tonemap`."""
    _check(image, reference)
    return float(structural_similarity(tonemap(image), tonemap(reference), data_range=1.0,
                                       channel_axis=2, gaussian_weights=True, sigma=1.5,
                                       use_sample_covariance=False))


def psnr(image: np.ndarray, reference: np.ndarray) -> float:
    """PSNR in dB of two linear RGB images after :func:`tonemap` (inf when identical)."""
    _check(image, reference)
    a, b = tonemap(image), tonemap(reference)
    if np.array_equal(a, b):
        return float("inf")
    return float(peak_signal_noise_ratio(b, a, data_range=1.0))


def error_map(image: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Per-pixel mean absolute difference of the tonemapped images, (H, W) in [0, 1]."""
    _check(image, reference)
    return np.abs(tonemap(image) - tonemap(reference)).mean(axis=2)


def noise_corrected_mse(image: np.ndarray, reference: np.ndarray, reference_b: np.ndarray) -> float:
    """The MSE of ``image`` against the reference's expectation, with the references' own noise
    taken out (on the tonemap, as every metric here).

    With a, b two references rendered with independent seeds (per pixel: the same mean mu and
    variance s^2, independent) and m the method's image, r = (a + b) / 2 has
    E[(m - r)^2] = (m - mu)^2 + s^2 / 2 and E[(a - b)^2] = 2 s^2, so

        mean((m - r)^2) - mean((a - b)^2) / 4

    is an unbiased estimate of mean((m - mu)^2): the error no further reference samples would
    change. mu is the mean of the tonemapped reference, which tends to the tonemapped converged
    image as the noise goes (the tonemap's curvature adds a bias of order s^2). It can come out
    below 0 when the method's error is below the estimate's own noise.
    """
    _check(image, reference)
    _check(reference_b, reference)
    m, a, b = tonemap(image), tonemap(reference), tonemap(reference_b)
    return float(np.mean((m - 0.5 * (a + b)) ** 2) - 0.25 * np.mean((a - b) ** 2))

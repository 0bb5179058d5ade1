"""Per-PSF statistics of a sparsification (LSR18 section 7.3): sparsity and similarity.

Similarity is measured on the PSF's working box (its bounding box plus margin, see
:func:`lab.sparsify.laplacian.working_box`), not on the whole PSF image: on a 512^2 image a 5 px
disc would otherwise score SSIM ~1 from empty pixels alone. The relative L1 error uses the whole
image, so the spreadlets' far field counts as error wherever it lands.
"""
from __future__ import annotations

import numpy as np
from skimage.metrics import structural_similarity

from .laplacian import Box

__all__ = ["dense_count", "similarity"]


def dense_count(psf: np.ndarray) -> int:
    """Number of pixels a dense splat of ``psf`` (R, R, C) draws: nonzero in any channel."""
    return int((np.asarray(psf) != 0).any(axis=2).sum())


def similarity(psf: np.ndarray, rec: np.ndarray, box: Box) -> tuple[float, float]:
    """SSIM on ``box`` and relative L1 on the whole image between a PSF and a reconstruction.

    Parameters
    ----------
    psf, rec : ndarray, (R, R, C)
        Dense PSF and reconstruction (integrated spreadlets) of the same shape.
    box : Box
        Window for SSIM; ``data_range`` is the PSF's maximum there (its minimum is 0).

    Returns
    -------
    ssim : float
        Mean SSIM (scikit-image, 7x7 window, channels averaged).
    l1 : float
        ``sum |psf - rec| / sum |psf|``.
    """
    f, r = np.asarray(psf, np.float64), np.asarray(rec, np.float64)
    l1 = float(np.abs(f - r).sum() / np.abs(f).sum())
    fb, rb = box.crop(f), box.crop(r)
    data_range = float(fb.max() - fb.min())
    if fb.shape[2] == 1:
        ssim = structural_similarity(fb[..., 0], rb[..., 0], data_range=data_range)
    else:
        ssim = structural_similarity(fb, rb, data_range=data_range, channel_axis=2)
    return float(ssim), l1

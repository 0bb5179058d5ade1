"""Validation of :func:`lab.sparsify.sparsify`'s inputs: every problem is a UserError with the fix."""
from __future__ import annotations

import math
import numbers

import numpy as np

from lab.errors import UserError

__all__ = ["check_psf", "check_params"]


def check_psf(psf) -> np.ndarray:
    """Check the PSF contract and return the PSF as float64.

    Parameters
    ----------
    psf : ndarray, (R, R, C)
        Must be floating point, C in {1, 3}, 8 <= R <= 32767, finite, non-negative, each channel
        summing to 1 (within 1e-3) and zero within 2 px of the border.

    Returns
    -------
    ndarray, float64 (R, R, C)
    """
    if not isinstance(psf, np.ndarray):
        raise UserError(f"sparsify: psf must be a numpy array (R, R, C), got {type(psf).__name__}")
    if psf.ndim != 3 or psf.shape[0] != psf.shape[1] or psf.shape[2] not in (1, 3):
        raise UserError(f"sparsify: psf shape {psf.shape} must be (R, R, C) with C = 1 or 3; "
                        "add a channel axis with psf[..., None] for a grey PSF")
    if not 8 <= psf.shape[0] <= 32767:
        raise UserError(f"sparsify: psf resolution R = {psf.shape[0]} must be in 8 .. 32767")
    if not np.issubdtype(psf.dtype, np.floating):
        raise UserError(f"sparsify: psf dtype {psf.dtype} must be floating point (float32)")
    f = psf.astype(np.float64)
    if not np.isfinite(f).all():
        raise UserError(f"sparsify: psf has {int((~np.isfinite(f)).sum())} NaN/inf pixels; "
                        "fix the PSF tracer output")
    if (f < 0).any():
        raise UserError(f"sparsify: psf has negative values (min {f.min():.3g}); a PSF is "
                        "non-negative")
    sums = f.sum(axis=(0, 1))
    if not np.allclose(sums, 1.0, rtol=0, atol=1e-3):
        raise UserError(f"sparsify: psf channel sums {np.round(sums, 6).tolist()} must be 1; "
                        "normalise each channel")
    ring = np.concatenate([f[:2].ravel(), f[-2:].ravel(), f[:, :2].ravel(), f[:, -2:].ravel()])
    if ring.any():
        raise UserError("sparsify: psf is nonzero within 2 px of its border; trace it into a "
                        "larger image so the Laplacian and its integration stay inside")
    return f


def check_params(density, seed, dart_failures, lloyd_iterations, anneal_steps, anneal_fraction,
                 rays):
    """Check :func:`lab.sparsify.sparsify`'s keyword arguments (see there); raise UserError."""
    def is_int(v):
        return isinstance(v, (int, np.integer)) and not isinstance(v, bool)

    if not (isinstance(density, numbers.Real) and not isinstance(density, bool)
            and math.isfinite(density) and density > 0):
        raise UserError(f"sparsify: density = {density!r} must be a finite number > 0 "
                        "(1.0 = default, 2.0 = about twice the spreadlets)")
    if not is_int(seed) or seed < 0:
        raise UserError(f"sparsify: seed = {seed!r} must be an integer >= 0")
    for name, v, lo in (("dart_failures", dart_failures, 1),
                        ("lloyd_iterations", lloyd_iterations, 0),
                        ("anneal_steps", anneal_steps, 0)):
        if not is_int(v) or v < lo:
            raise UserError(f"sparsify: {name} = {v!r} must be an integer >= {lo}")
    if not (isinstance(anneal_fraction, numbers.Real) and not isinstance(anneal_fraction, bool)
            and 0 < anneal_fraction <= 1):
        raise UserError(f"sparsify: anneal_fraction = {anneal_fraction!r} must be in (0, 1]")
    per_channel = isinstance(rays, (list, tuple, np.ndarray)) and len(rays) >= 1 \
        and all(is_int(r) and r >= 1 for r in rays)
    if rays is not None and not (is_int(rays) and rays >= 1) and not per_channel:
        raise UserError(f"sparsify: rays = {rays!r} must be the tracer's ray count (an integer >= 1, "
                        "or one per channel for a PSF whose channels are normalised by their own "
                        "counts) or None for an exact PSF")

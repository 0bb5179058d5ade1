"""The analytic SimpleLens PSF in numpy: the exact-area disc (:func:`runtime_cl.psf.disc.disc_psf`
with ``pixel="area"``) averaged over a range of radii, the reference the light tracer is tested
against.

Pixels follow the tracer: the pixel at offset (i, j) from the centre (R//2, R//2) covers
[j - 1/2, j + 1/2) x [i - 1/2, i + 1/2). The pre-filtered PSF averages the disc over radii drawn
uniformly from [lo, hi] with the midpoint rule in r.
"""
from __future__ import annotations

import numpy as np

from lab.errors import UserError
from runtime_cl.psf.disc import disc_psf

__all__ = ["prefiltered_disc_psf"]


def prefiltered_disc_psf(lo: float, hi: float, resolution: int, nodes: int = 256) -> np.ndarray:
    """The exact-area disc PSF averaged over radii uniform in [lo, hi] pixels, (R, R) float64.

    Parameters
    ----------
    lo, hi : float
        Radius range in pixels, 0 <= lo <= hi.
    resolution : int
        R, the image edge in pixels; must hold the disc of radius ``hi``.
    nodes : int, default 256
        Midpoint-rule nodes in r (the integrand is continuous in r; error falls ~ nodes^-2).
    """
    if not (0 <= lo <= hi):
        raise UserError(f"radius range [{lo}, {hi}]: needs 0 <= lo <= hi")
    largest = disc_psf(hi, resolution, pixel="area")  # a bad R fails here, naming hi
    if hi == lo:
        return largest
    radii = lo + (hi - lo) * (np.arange(nodes) + 0.5) / nodes
    return sum(disc_psf(float(r), resolution, pixel="area") for r in radii) / nodes

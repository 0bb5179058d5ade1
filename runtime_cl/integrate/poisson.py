"""From a Laplacian image back to the image: an exact discrete Poisson solve by FFT.

The splatting runtime draws the Laplacian of every PSF (LSR18 section 4). We use the 5-point
Laplacian (a 3x3 stencil, LSR18 section 5.5)

    (L f)[y, x] = f[y-1, x] + f[y+1, x] + f[y, x-1] + f[y, x+1] - 4 f[y, x]

and invert it exactly: on a periodic canvas L is diagonal in the Fourier basis with eigenvalues
2 cos(2 pi kx / W) + 2 cos(2 pi ky / H) - 4, zero only for the constant mode. An image that is
zero on the canvas border (guaranteed by padding the canvas by the largest PSF radius, LSR18
section 6.2) is therefore recovered exactly, up to the constant, which is fixed by making the
border ring zero. This is the free-space Green's function solve of LSR18 section 4 without the
epsilon regularisation, so integrating the Laplacian of a splatted image gives back the splatted
image to float rounding.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

try:  # scipy's pocketfft runs on all cores (about 2x numpy's on this 2-core machine); optional
    import scipy.fft as _fft

    _WORKERS = {"workers": -1}
except ImportError:  # the runtime needs only numpy
    _fft = np.fft
    _WORKERS = {}


def laplacian5(image: np.ndarray) -> np.ndarray:
    """5-point Laplacian of ``image`` (H, W) or (H, W, C), zero outside the array."""
    f = np.asarray(image)
    pad = [(1, 1), (1, 1)] + [(0, 0)] * (f.ndim - 2)
    p = np.pad(f, pad)
    return p[:-2, 1:-1] + p[2:, 1:-1] + p[1:-1, :-2] + p[1:-1, 2:] - 4.0 * p[1:-1, 1:-1]


@lru_cache(maxsize=8)
def _eigenvalues(h: int, w: int, dtype=np.float64) -> np.ndarray:
    """Eigenvalues of the periodic 5-point Laplacian on the rfft2 grid (read-only, cached per size),
    computed in float64 and stored as ``dtype``."""
    ky = 2.0 * np.cos(2.0 * np.pi * np.arange(h) / h)
    kx = 2.0 * np.cos(2.0 * np.pi * np.arange(w // 2 + 1) / w)
    lam = ky[:, None] + kx[None, :] - 4.0
    lam[0, 0] = 1.0  # the constant mode is fixed afterwards from the border
    lam = lam.astype(dtype, copy=False)
    lam.flags.writeable = False
    return lam


PRECISIONS = {"float64": np.float64, "float32": np.float32}


def poisson_integrate(laplacian: np.ndarray, precision: str = "float64") -> np.ndarray:
    """Invert :func:`laplacian5` on a canvas whose true image is zero on its border ring.

    Parameters
    ----------
    laplacian : ndarray, (H, W) or (H, W, C)
        The Laplacian image. Its mean (the part no zero-border image can have) is ignored.
    precision : {"float64", "float32"}
        The FFTs' precision. Default float64: exact to float32 rounding. float32 is faster and
        about 1e-5 of the image's largest value off (``splatlab bench integrate``).

    Returns
    -------
    ndarray, float32, same shape
        The image whose Laplacian is ``laplacian`` and whose border ring averages to zero.
    """
    if precision not in PRECISIONS:
        raise ValueError(f"poisson_integrate: precision = {precision!r}, must be one of {list(PRECISIONS)}")
    dtype = PRECISIONS[precision]
    lap = np.asarray(laplacian, dtype=dtype)
    h, w = lap.shape[:2]
    if h < 3 or w < 3:
        raise ValueError(f"poisson_integrate: canvas {h}x{w} is too small, need at least 3x3")
    lam = _eigenvalues(h, w) if dtype is np.float64 else _eigenvalues(h, w, dtype)
    if lap.ndim == 3:
        lam = lam[..., None]
    spec = _fft.rfft2(lap, axes=(0, 1), **_WORKERS)
    spec /= lam
    spec[0, 0] = 0.0
    f = _fft.irfft2(spec, s=(h, w), axes=(0, 1), **_WORKERS)
    border = np.concatenate([f[0], f[-1], f[1:-1, 0], f[1:-1, -1]], axis=0)
    f -= border.mean(axis=0)
    return f.astype(np.float32, copy=False)


def fft_friendly(n: int) -> int:
    """Smallest m >= n whose only prime factors are 2, 3 and 5 (fast FFT sizes)."""
    m = max(int(n), 1)
    while True:
        k = m
        for p in (2, 3, 5):
            while k % p == 0:
                k //= p
        if k == 1:
            return m
        m += 1

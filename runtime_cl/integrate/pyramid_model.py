"""The convolution pyramid (Farbman et al. 2011) as a plain numpy operator: its kernels' file, the
reference the OpenCL integrator is checked against, and what ``python -m lab.pyramid_fit`` fits.

The operator (Farbman et al. 2011, section 3) on a Laplacian canvas ``a0`` (H, W[, C]):

    a[l+1] = down(h1 * a[l])                 analysis: filter, keep every other row and column
    s[L]   = g[L] * a[L]                      the coarsest level
    s[l]   = h2 * up(s[l+1]) + g[l] * a[l]    synthesis: zero-insert, filter, add this level's term
    image  = s[0] - mean of s[0] over the canvas's border ring

``h1`` and ``h2`` are separable, symmetric 1-D taps (the same at every level; ``h2`` carries the
gain 4 of zero insertion); ``g[l]`` is a small 2-D kernel with the square's 8 symmetries (its own
size per kernel), one per level for the finest levels and one shared by the rest (the Green's function of the 5-point
Laplacian differs from (1/2 pi) log r near its centre only; at coarser levels the log is
scale-invariant, so one kernel serves them all). Each level is the previous one's
``n + 2 PAD`` padded samples halved (rounded up), so every coarse sample that a canvas pixel
depends on is computed: the free-space operator, not a periodic one. Levels stop once a side
is at most ``TOP`` samples. Before the analysis the canvas's mean is subtracted, as the exact
solve ignores it (:func:`runtime_cl.integrate.poisson.poisson_integrate`).
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from runtime_cl.errors import InputError

__all__ = ["KERNELS_FILE", "PAD", "TOP", "PyramidKernels", "analysis", "correlate2", "load_kernels",
           "level_shapes", "pyramid_integrate_numpy", "ring_mean", "symmetric_basis", "symmetric_kernel",
           "upsample"]

KERNELS_FILE = Path(__file__).with_name("pyramid_kernels.json")
FORMAT = 1
PAD = 4     # zero samples added on each side of a level before it is filtered and halved
TOP = 12    # no level is halved once its longer side is at most this many samples


def symmetric_basis(radius: int) -> list[np.ndarray]:
    """The (2r+1)^2 kernels with the square's 8 symmetries, one per orbit of offsets (i >= j >= 0):
    (0,0), (1,0), (1,1), (2,0), ... Each is 1 on its orbit's offsets, 0 elsewhere."""
    out = []
    for i in range(radius + 1):
        for j in range(i + 1):
            k = np.zeros((2 * radius + 1, 2 * radius + 1))
            for a, b in {(i, j), (j, i)}:
                for sa in (-1, 1):
                    for sb in (-1, 1):
                        k[radius + sa * a, radius + sb * b] = 1.0
            out.append(k)
    return out


def symmetric_kernel(values, radius: int) -> np.ndarray:
    """The 2-D kernel whose orbit values (:func:`symmetric_basis` order) are ``values``."""
    basis = symmetric_basis(radius)
    if len(values) != len(basis):
        raise ValueError(f"symmetric_kernel: {len(values)} values for radius {radius}, need {len(basis)}")
    return sum(v * b for v, b in zip(values, basis))


@dataclass(frozen=True)
class PyramidKernels:
    """A fitted kernel set: ``h1``, ``h2`` odd-length symmetric taps; ``g`` one 2-D kernel per fine
    level, the last one serving every coarser level."""

    h1: np.ndarray
    h2: np.ndarray
    g: tuple

    def g_at(self, level: int) -> np.ndarray:
        return self.g[min(level, len(self.g) - 1)]


@lru_cache(maxsize=4)
def load_kernels(path: Path = KERNELS_FILE) -> PyramidKernels:
    """Read the fitted kernels (written by ``python -m lab.pyramid_fit``)."""
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: cannot read the convolution pyramid's kernels ({exc}); "
                         "refit them with `python -m lab.pyramid_fit`") from exc
    if data.get("format") != FORMAT or data.get("pad") != PAD or data.get("top") != TOP:
        raise InputError(f"{path}: kernels of format {data.get('format')}, pad {data.get('pad')}, top "
                         f"{data.get('top')}; this runtime needs {FORMAT}, {PAD}, {TOP}: refit them with "
                         "`python -m lab.pyramid_fit`")
    return PyramidKernels(np.asarray(data["h1"], np.float64), np.asarray(data["h2"], np.float64),
                          tuple(symmetric_kernel(v, int(r)) for v, r in zip(data["g"], data["g_radii"])))


def level_shapes(h: int, w: int) -> list[tuple]:
    """(H, W) of every level, finest first."""
    shapes = [(h, w)]
    while max(shapes[-1]) > TOP:
        ph, pw = shapes[-1]
        shapes.append(((ph + 2 * PAD + 1) // 2, (pw + 2 * PAD + 1) // 2))
    return shapes


def _correlate1(a: np.ndarray, taps: np.ndarray, axis: int) -> np.ndarray:
    r = len(taps) // 2
    n = a.shape[axis]
    width = [(0, 0)] * a.ndim
    width[axis] = (r, r)
    p = np.pad(a, width)
    idx = [slice(None)] * a.ndim
    out = np.zeros_like(a)
    for k, t in enumerate(taps):
        idx[axis] = slice(k, k + n)
        out += t * p[tuple(idx)]
    return out


def correlate2(a: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """``a`` (H, W[, C]) correlated with the odd square ``kernel``, zero outside ``a``."""
    r = kernel.shape[0] // 2
    h, w = a.shape[:2]
    p = np.pad(a, [(r, r), (r, r)] + [(0, 0)] * (a.ndim - 2))
    out = np.zeros_like(a)
    for dy, dx in zip(*np.nonzero(kernel)):
        out += kernel[dy, dx] * p[dy:dy + h, dx:dx + w]
    return out


def analysis(a0: np.ndarray, h1: np.ndarray) -> list[np.ndarray]:
    """Every level ``a[l]`` of the analysis, finest (``a0`` itself) first."""
    levels = [a0]
    for h, w in level_shapes(*a0.shape[:2])[1:]:
        cur = levels[-1]
        p = np.pad(cur, [(PAD, 2 * h - cur.shape[0] - PAD), (PAD, 2 * w - cur.shape[1] - PAD)]
                   + [(0, 0)] * (cur.ndim - 2))
        levels.append(_correlate1(_correlate1(p, h1, 0), h1, 1)[::2, ::2])
    return levels


def upsample(s: np.ndarray, h2: np.ndarray, shape: tuple) -> np.ndarray:
    """``h2 * up(s)`` on the finer level of ``shape`` (zero insertion, then the separable filter)."""
    up = np.zeros((2 * s.shape[0], 2 * s.shape[1]) + s.shape[2:])
    up[::2, ::2] = s
    up = _correlate1(_correlate1(up, h2, 0), h2, 1)
    return up[PAD:PAD + shape[0], PAD:PAD + shape[1]]


def ring_mean(image: np.ndarray) -> np.ndarray:
    """Mean over the border ring of (H, W[, C]), per channel."""
    ring = np.concatenate([image[0], image[-1], image[1:-1, 0], image[1:-1, -1]], axis=0)
    return ring.mean(axis=0)


def pyramid_integrate_numpy(laplacian: np.ndarray, kernels: PyramidKernels | None = None) -> np.ndarray:
    """The convolution pyramid in float64 numpy (the module docstring's operator).

    Parameters
    ----------
    laplacian : ndarray, (H, W) or (H, W, C)
        The Laplacian canvas (H, W >= 3).
    kernels : PyramidKernels, optional
        Default: the fitted ones (:func:`load_kernels`).

    Returns
    -------
    ndarray, float64, same shape
    """
    k = kernels or load_kernels()
    a0 = np.asarray(laplacian, np.float64)
    a0 = a0 - a0.mean(axis=(0, 1))
    a = analysis(a0, k.h1)
    s = correlate2(a[-1], k.g_at(len(a) - 1))
    for level in range(len(a) - 2, -1, -1):
        s = upsample(s, k.h2, a[level].shape) + correlate2(a[level], k.g_at(level))
    return s - ring_mean(s)

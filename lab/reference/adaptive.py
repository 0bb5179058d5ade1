"""Variance-guided (adaptive) references: extra samples where the reference's noise is.

A reference's noise is not spread evenly: most of it is speckle in small regions (the clipped
bokeh discs of small bright lights, fog halos), so uniform samples converge the frame long after
most of it was done. ``[render] reference_adaptive = { extra_spp = E, tiles = K }`` renders it in
three rounds, each a job of seeded, cached passes (:mod:`lab.reference.passes`):

1. a **pilot** (``pilot_spp``, its own seed stream ``"pilot"``) whose passes' spread estimates
   each pixel's variance (:meth:`~lab.reference.passes.Accumulator.variance`);
2. the **base**: the plain reference (``reference_spp``, the ``"reference"`` stream), unchanged;
3. **tiles**: the frame is cut into ``tile_px`` squares; from the pilot, each tile's expected
   squared error of the base *in the tonemapped domain the metrics use*
   (:func:`tonemapped_error`), weighted by what that error costs SSIM there (:func:`ssim_weight`:
   noise on a flat region, a clipped bokeh disc or a plain wall, costs far more than on texture),
   is estimated, and ``E * width * height`` extra samples are shared among the ``K`` tiles of
   largest error so as to minimise the frame's summed weighted error (:func:`allocate`:
   n_t ~ sqrt(error_t), water-filled). Each chosen tile is rendered through the film crop of the
   same sensor (:attr:`RenderJob.crop`), seed stream ``("adaptive", t)``.

It pays where the noise is concentrated and the base already converges the rest: on a small
light's speckled bokeh disc over a plain wall (the tests' scene) SSIM +0.01-0.025 and a 3-6.6x
lower worst-tile error than uniform sampling at the same samples; on ``tiny`` at 32 spp (f/0.5, bokeh
over the whole frame) the worst tile improved 1.4x but SSIM did not (0.755 against 0.771); on
``occlusion`` at 256² (128 + 1024 + 896 spp against 2048) the worst tile 1.2-1.8x and the twins'
PSNR +1.4 dB, their SSIM 0.985 against 0.987. Each refined tile costs a kernel build and small
launches, so at equal *time* uniform sampling won on all three (README).

Each pixel's value is the plain weighted mean of its base and tile samples.

**Why it is unbiased.** Let F be the pilot's samples. The allocation (which tiles, how many
samples each) is a function of F alone, and the base and tile samples are drawn from streams
independent of F and of each other. Given F, a pixel's estimate is therefore the mean of a
*fixed* number of i.i.d. samples of the pixel integral (or, for sub-frame and per-wavelength
jobs, a fixed-weight mean of unbiased pass estimates), whose expectation is the pixel's value
whatever F was; so its unconditional expectation is that value too. The pilot's own samples are
*not* in the image: a pixel whose count depended on its own samples would be biased (a firefly
in the pilot both raises the mean and draws more samples, which then dilute it). Keeping the
pilot's samples only in the tiles left alone would not help either: whether a pixel keeps them
would then depend on their values. The pilot costs ``pilot_spp``; the
report states pilot, base and extra samples. ``tests/lab/reference/test_adaptive_reference.py``
sums the adaptive render minus an 8192-spp brute-force render over the refined and the other
pixels, per channel, in units of its standard deviation (each pixel's from the passes' spread):
all within 4.5 (a false alarm about once in 10^4 runs), while a 25 % bias lands far outside; and
checks that the adaptive render beats a uniform one of the same total samples.

Nothing here runs a job: :meth:`AdaptiveJob.run` takes the runner (the pipeline's
:func:`lab.reference.execute.run_job`), so the executor is no part of the reference's cache key.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..report.metrics import tonemap
from ..scene import AdaptiveSettings
from .passes import RenderJob

__all__ = ["AdaptiveJob", "allocate", "ssim_weight", "tile_grid", "tonemapped_error"]

PILOT_PASSES = 8   # the pilot's passes: 7 degrees of freedom per pixel, averaged over a tile
SSIM_C2 = 0.03 ** 2  # SSIM's C2 at data_range 1 (K2 = 0.03, as skimage)
SMOOTH_PX = 2.0    # the pilot's mean and variance are blurred this much (px) before the tonemap


def tile_grid(width: int, height: int, tile_px: int) -> list[tuple[int, int, int, int]]:
    """Row-major (x, y, w, h) tiles of ``tile_px`` covering the frame (the last row/column smaller)."""
    return [(x, y, min(tile_px, width - x), min(tile_px, height - y))
            for y in range(0, height, tile_px) for x in range(0, width, tile_px)]


def tonemapped_error(mean: np.ndarray, variance: np.ndarray, smooth_px: float = SMOOTH_PX) -> np.ndarray:
    """(H, W): expected squared error of the tonemapped image of a mean with ``variance`` per pixel.

    The metrics tonemap (:func:`lab.report.metrics.tonemap`: clip to [0, 1], sRGB curve) is flat
    above 1 and steep near 0, so the linear variance alone would chase noise nobody sees (a light
    far above white) and miss speckle at the clip. The error is the mean over channels of
    ``((T(m + s) - T(m))^2 + (T(m - s) - T(m))^2) / 2`` with s the standard deviation: one-sigma
    steps through the tonemap itself (the delta method where T is smooth, the clip where it is not).

    Mean and variance are first blurred by a Gaussian of ``smooth_px``: in a bokeh disc of a small
    light most pilot pixels saw no light path yet (mean and spread 0, so no error by this formula)
    and a few saw one (clipped: little error either), while every pixel of the disc has that
    variance. Measured on ``tiny`` (16-px tiles, 16-spp pilot): unblurred, the tiles' predicted
    errors spanned 2.8x where the 32-spp render's actual errors spanned 17x; blurred by 1.5-3 px
    they span 46-50x, ordered as the actual ones.
    """
    from scipy.ndimage import gaussian_filter

    if smooth_px > 0:
        mean = gaussian_filter(mean, (smooth_px, smooth_px, 0), mode="nearest")
        variance = gaussian_filter(variance, (smooth_px, smooth_px, 0), mode="nearest")
    s = np.sqrt(np.maximum(variance, 0.0))
    t0 = tonemap(mean)
    e = 0.5 * ((tonemap(mean + s) - t0) ** 2 + (tonemap(mean - s) - t0) ** 2)
    return e.mean(axis=2)


def ssim_weight(mean: np.ndarray, pilot_error: np.ndarray) -> np.ndarray:
    """(H, W): how much a unit of tonemapped squared error costs SSIM at each pixel.

    For an image y = x + noise of variance v, SSIM's contrast-structure term is
    (2 s_x^2 + C2) / (2 s_x^2 + v + C2) ~ 1 - v / (2 s_x^2 + C2), with s_x^2 the local variance of
    the clean tonemapped image in SSIM's window (Gaussian, 1.5 px) and C2 = (0.03)^2: noise costs
    ~1000x more in a flat region (a clipped bokeh disc, a dark wall) than on texture. s_x^2 is the
    pilot mean's local variance less its own noise (``pilot_error``, per pixel, tonemapped).
    """
    from scipy.ndimage import gaussian_filter

    t = tonemap(mean)
    blur = lambda a: gaussian_filter(a, (1.5, 1.5, 0)[:a.ndim], mode="nearest")  # noqa: E731
    local = (blur(t * t) - blur(t) ** 2).mean(axis=2)
    signal = np.maximum(local - blur(pilot_error), 0.0)
    return 1.0 / (2.0 * signal + SSIM_C2)


def allocate(error: np.ndarray, base_spp: float, extra_samples: float, tiles: int,
             tile_px: int) -> list[tuple[int, tuple[int, int, int, int], int]]:
    """Share ``extra_samples`` among at most ``tiles`` tiles; [(tile index, (x, y, w, h), spp)].

    With e_t the mean squared error per pixel of tile t at ``base_spp`` samples (A_t pixels),
    adding m_t samples per pixel leaves e_t B / (B + m_t). Minimising sum_t A_t e_t B / (B + m_t)
    subject to sum_t A_t m_t = M gives B + m_t = c sqrt(e_t) (Neyman allocation), clipped at m_t >= 0
    and water-filled over the ``tiles`` tiles of largest e_t. Counts are rounded down, so at most
    ``extra_samples`` are spent. Ties break by tile index (deterministic).

    Parameters
    ----------
    error : (H, W) float
        Expected squared error per pixel at ``base_spp`` (:func:`tonemapped_error`).
    base_spp : float
    extra_samples : float
        Samples to share (pixels x spp).
    tiles : int
    tile_px : int
    """
    h, w = error.shape
    grid = tile_grid(w, h, tile_px)
    e = np.array([error[y:y + th, x:x + tw].mean() for x, y, tw, th in grid])
    area = np.array([tw * th for _, _, tw, th in grid], dtype=np.float64)
    order = sorted(range(len(grid)), key=lambda i: (-e[i], i))[:tiles]
    order = [i for i in order if e[i] > 0]
    if not order or extra_samples <= 0:
        return []
    r, a = np.sqrt(e[order]), area[order]

    def spent(c):
        return float(np.sum(a * np.maximum(c * r - base_spp, 0.0)))

    lo, hi = 0.0, (base_spp + extra_samples / a.min()) / r.min()
    for _ in range(200):   # bisection on the water level c
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if spent(mid) < extra_samples else (lo, mid)
    m = np.floor(np.maximum(lo * r - base_spp, 0.0)).astype(int)
    return [(i, grid[i], int(n)) for i, n in zip(order, m) if n > 0]


@dataclass
class AdaptiveJob:
    """A reference rendered as pilot, base and refined tiles (see the module docstring).

    Parameters
    ----------
    job : RenderJob
        The plain reference job (any subclass: sub-frames, wavelengths); its spp is the base.
    settings : lab.scene.AdaptiveSettings
    """

    job: RenderJob
    settings: AdaptiveSettings

    @property
    def pilot_spp(self) -> int:
        return self.settings.pilot_spp or max(PILOT_PASSES, self.job.spp // 8)

    def pilot(self) -> RenderJob:
        """The pilot job: ``pilot_spp`` in at least :data:`PILOT_PASSES` passes, its own stream."""
        n = self.pilot_spp
        pass_spp = 1 << max(0, (n // PILOT_PASSES).bit_length() - 1)
        return replace(self.job, spp=n, stream="pilot", pass_spp=pass_spp, crop=None,
                       desc=f"{self.job.desc} pilot")

    def tile_job(self, index: int, crop, spp: int) -> RenderJob:
        """Tile ``index`` (of :func:`tile_grid`) with ``spp`` more samples, seed stream ("adaptive", index)."""
        return replace(self.job, spp=spp, stream=("adaptive", index), crop=tuple(crop), pass_spp=None,
                       desc=f"{self.job.desc} tile {index}")

    def run(self, run) -> tuple[np.ndarray, dict]:
        """Render it; returns ((H, W, 3) float32, info).

        ``run(job, name, stats)`` renders a job (``stats``: return its Accumulator) with its
        passes cached under ``name`` (:func:`lab.reference.execute.run_job`).
        """
        s, job = self.settings, self.job
        w, h = job.scene.width, job.scene.height
        pilot = run(self.pilot(), "pilot", True)
        base = run(job, "base", True)
        variance = pilot.variance() * (pilot.weights / base.weights)   # the base mean's variance
        m = pilot.mean().astype(np.float64)
        error = tonemapped_error(m, variance) * ssim_weight(m, tonemapped_error(m, pilot.variance(), 0.0))
        chosen = allocate(error, float(job.spp), float(s.extra_spp) * w * h, s.tiles, s.tile_px)
        total, weights = base.total.copy(), np.broadcast_to(base.weights, base.total.shape).copy()
        for index, (x, y, tw, th), spp in chosen:
            tile = run(self.tile_job(index, (x, y, tw, th), spp), f"tile{index:05d}-{spp}", True)
            total[y:y + th, x:x + tw] += tile.total
            weights[y:y + th, x:x + tw] += tile.weights
        extra = sum(spp * tw * th for _, (_, _, tw, th), spp in chosen) / (w * h)
        info = {"pilot_spp": self.pilot_spp, "base_spp": job.spp, "extra_spp": round(extra, 2),
                "total_spp": round(self.pilot_spp + job.spp + extra, 2), "tile_px": s.tile_px,
                "tiles_refined": len(chosen),
                "tile_spp_max": max((job.spp + n for *_, n in chosen), default=job.spp)}
        return (total / weights).astype(np.float32), info

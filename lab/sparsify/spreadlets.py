"""LSR18 section 5.5 end to end: a dense PSF becomes sparse Laplacian "spreadlets".

Steps: Laplacian (:mod:`.laplacian`), dart throwing (:mod:`.dart`), Lloyd (:mod:`.lloyd`), Voronoi
collapse (:mod:`.voronoi`), simulated annealing (:mod:`.anneal`), merge (:mod:`.merge`), then the
fast-track decision of LSR18 section 6.4 and the statistics of section 7.3 (:mod:`.stats`).
``basis="rows"`` stores row differences instead (:mod:`.rows`), fitted row by row.

The sparsity knob: each dart-throwing disk carries the importance mass ``MASS / density``
(importance = |Laplacian| in units of the PSF's intensity level, :mod:`.laplacian`), so the point
count grows with ``density`` until a rim runs out of pixels (a 3 px ramp saturates near 2x).
``MASS = 0.25`` was chosen on pre-filtered discs (3 px ramp, 512^2 images), measured as
sparsity / SSIM on the working box for density 0.5 | 1 | 2:

    r =  25 px   16.4 % .970 | 24.4 % .968 | 29.9 % .997
    r = 100 px    4.1 % .939 |  6.6 % .979 |  7.9 % 1.00
    r = 250 px    1.4 % .958 |  2.2 % .974 |  3.2 % 1.00

i.e. SSIM ~.97 at the default, LSR18's operating point (mean SSIM .97; LSR18 Fig. 10d). At
MASS = 0.5 the default would drop to SSIM .94 - .95 on 100 - 250 px discs.

Beyond LSR18: the spreadlets' low harmonic moments and their energy are matched to the dense
Laplacian's (:mod:`.moments`: no far-field tail, no lost energy), ray-histogram PSFs get a
noise-aware importance (:mod:`.noise`), and the importance is measured against the PSF's local
level (:mod:`.laplacian`), so a faint part beside a bright one (the Volume model's scattering halo
around its sharp core) gets the spreadlets it would get alone. Measured on the Volume model's PSFs
(255^2, 2^23 rays; 0.25 .. 5 m) the energy kept went from 0.49 - 1.16 to 1.000 (+- 0.0006) and
every octave ring of the halo keeps its energy to 1.2 % of the PSF's (before: up to 29 %), for
about 2 000 spreadlets (3 % of the pixels, most of them on the image edge that cuts the halo);
on 16 PSFs of the other models the mean SSIM per model rose by 0.001 - 0.026 with 0 - 71 % more
spreadlets (the faint parts of lens PSFs), and sparsify takes 30 - 80 % longer (0.5 - 1.1 s).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
from scipy.spatial import cKDTree

from lab.errors import UserError
from runtime_cl.integrate.poisson import poisson_integrate
from runtime_cl.psf.database import BASES   # what spreadlet values are: Laplacian or row differences

from .anneal import anneal
from .cost import BoxCost
from .dart import throw_darts
from .laplacian import LEVEL_REACH, importance, psf_laplacian, working_box
from .lloyd import lloyd
from .merge import merge_coincident
from .moments import MomentMatch
from .noise import K_SIGMA, coarse_laplacian, denoise
from .rows import L1_MAX, LAMBDA, REFITS, fit_rows, row_terms
from .stats import dense_count, similarity
from .validate import check_params, check_psf
from .voronoi import assign, collapse

__all__ = ["sparsify", "SparsePSF", "MASS", "BASES"]

# Importance mass per dart-throwing disk at density 1 (see the module docstring).
MASS = 0.25


@dataclass(frozen=True, eq=False)
class SparsePSF:
    """A sparsified PSF: spreadlets, or the dense PSF when the fast track wins.

    Attributes
    ----------
    points : ndarray, int16 (n, 2)
        Spreadlet offsets ``(dx, dy)`` in pixels from the PSF centre; empty on the fast track.
    values : ndarray, float32 (n, C)
        Laplacian value of each spreadlet per channel; empty on the fast track.
    fast_track : bool
        True when the spreadlets are not sparser than the dense PSF (LSR18 section 6.4): the
        runtime should splat ``dense`` directly.
    stats : dict of str to float
        ``n_points`` spreadlets found (after dart throwing only, if that already decided the fast
        track), ``n_dense`` nonzero PSF pixels, ``sparsity = n_points / n_dense``, ``ssim`` and
        ``l1`` of what is stored (1 and 0 on the fast track), ``drawn`` splats per input pixel
        (``n_points`` or ``n_dense``), ``cost_lloyd`` / ``cost_final`` the relative L1 cost on the
        working box before / after annealing (0 on the fast track: the dense PSF is exact).
    dense : ndarray, float32 (h, w, C) or None
        On the fast track, the PSF's nonzero bounding box.
    dense_origin : (int, int)
        ``(dx, dy)`` of ``dense[0, 0]`` relative to the PSF centre.
    basis : {"laplacian", "rows"}
        What ``values`` are: the Laplacian (LSR18), or backward differences along rows
        (:mod:`.rows`), integrated by a prefix sum per row.
    """

    points: np.ndarray
    values: np.ndarray
    fast_track: bool
    stats: dict = field(default_factory=dict)
    dense: np.ndarray | None = None
    dense_origin: tuple[int, int] = (0, 0)
    basis: str = "laplacian"

    def reconstruct(self, resolution: int) -> np.ndarray:
        """The PSF as the runtime draws it, centred in an (R, R, C) float32 image.

        Spreadlets are splatted into a Laplacian canvas and integrated with
        :func:`runtime_cl.integrate.poisson.poisson_integrate` (row differences: summed along
        each row); the fast track places ``dense``.

        Parameters
        ----------
        resolution : int
            R, the image edge in pixels; must hold every point (or the dense box) plus one pixel.
        """
        if not isinstance(resolution, (int, np.integer)) or resolution < 3:
            raise UserError(f"reconstruct: resolution = {resolution!r} must be an integer >= 3")
        c = resolution // 2
        chans = self.values.shape[1]
        out = np.zeros((resolution, resolution, chans), np.float32)
        if self.fast_track:
            dx, dy = self.dense_origin
            h, w = self.dense.shape[:2]
            if min(c + dx, c + dy) < 0 or max(c + dx + w, c + dy + h) > resolution:
                raise UserError(f"reconstruct: resolution = {resolution} cannot hold the dense "
                                f"PSF ({w}x{h} at offset {dx},{dy}); use a larger resolution")
            out[c + dy:c + dy + h, c + dx:c + dx + w] = self.dense
            return out
        pos = c + self.points.astype(np.int64)
        if len(pos) and (pos.min() < 1 or pos.max() > resolution - 2):
            ext = int(np.abs(self.points.astype(np.int64)).max())
            raise UserError(f"reconstruct: resolution = {resolution} cannot hold spreadlets "
                            f"{ext} px from the centre; use resolution >= {2 * ext + 4}")
        lap = np.zeros((resolution, resolution, chans), np.float64)
        np.add.at(lap, (pos[:, 1], pos[:, 0]), self.values.astype(np.float64))
        if self.basis == "rows":
            return np.cumsum(lap, axis=1).astype(np.float32)
        return poisson_integrate(lap)


def _below_floor_values(mask, lap_b, py, px) -> np.ndarray:
    """Laplacian of the pixels below the noise floor, summed into their nearest point (n, C).

    They are mostly noise, but also weak smooth signal whose sum matters (dropping it shifts the
    integrated level), so they are collapsed like the rest, once, after Lloyd: they stay with
    their point during annealing. Without a noise floor the mask is empty and this is zero.
    """
    out = np.zeros((py.size, lap_b.shape[2]))
    if mask.any():
        qy, qx = np.nonzero(mask)
        _, lab = cKDTree(np.column_stack([py, px])).query(np.column_stack([qy, qx]))
        out = collapse(lab, lap_b[qy, qx], py.size)
    return out


def _move_bounds(sy, sx, box, resolution) -> tuple[int, int, int, int]:
    """Where annealed points may go (box coordinates, inclusive): within 2 px of the support,
    inside the box and inside the PSF image without its border ring (the runtime's canvas)."""
    return (max(int(sy.min()) - 2, 1, 1 - box.y0),
            min(int(sy.max()) + 2, box.h - 2, resolution - 2 - box.y0),
            max(int(sx.min()) - 2, 1, 1 - box.x0),
            min(int(sx.max()) + 2, box.w - 2, resolution - 2 - box.x0))


def _dense(f, n_points, n_dense, extra, basis: str = "laplacian") -> SparsePSF:
    mask = (f != 0).any(axis=2)
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    c = f.shape[0] // 2
    crop = f[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1].astype(np.float32)
    stats = dict(n_points=float(n_points), n_dense=float(n_dense),
                 sparsity=n_points / n_dense, ssim=1.0, l1=0.0, drawn=float(n_dense),
                 cost_lloyd=0.0, cost_final=0.0, ssim_target=1.0, l1_target=0.0, **extra)
    chans = f.shape[2]
    return SparsePSF(np.zeros((0, 2), np.int16), np.zeros((0, chans), np.float32), True, stats,
                     crop, (int(cols[0]) - c, int(rows[0]) - c), basis)


def _quantum(rays, channels: int) -> np.ndarray:
    """1 / rays per channel from one count or one count per channel."""
    if np.ndim(rays) == 0:
        return np.full(channels, 1.0 / rays)
    if len(rays) != channels:
        raise UserError(f"sparsify: rays = {list(rays)} gives {len(rays)} counts for a PSF with {channels} "
                        "channel(s); give one count, or one per channel")
    return 1.0 / np.asarray(rays, dtype=np.float64)


def _sparsify_rows(f_in: np.ndarray, density: float, quantum, n_dense: int, extra: dict) -> SparsePSF:
    """Row-difference spreadlets (:mod:`.rows`), or the dense PSF when they are no sparser.

    A fit whose relative L1 error exceeds :data:`~.rows.L1_MAX` (plus the L1 that ray noise alone
    gives a histogram PSF) is redone with a quarter of the segment cost, at most
    :data:`~.rows.REFITS` times: a PSF a few pixels wide has ramps as wide as its plateau, which
    the level-scaled cost would merge."""
    box = working_box(f_in, psf_laplacian(f_in))
    lam = LAMBDA / density
    bound = L1_MAX   # plus the ray noise's own expected L1 (E|n| = sqrt(2 / pi) sigma per pixel)
    if quantum is not None:
        f64 = np.asarray(f_in, np.float64)
        bound += float(np.sqrt(2.0 / np.pi * f64 * quantum).sum() / f64.sum())
    for _ in range(REFITS + 1):
        pts, vals = row_terms(fit_rows(f_in, lam, quantum))
        if len(pts) >= n_dense:
            return _dense(f_in, len(pts), n_dense, extra, "rows")
        sparse = SparsePSF(pts, vals, False, basis="rows")
        rec = sparse.reconstruct(f_in.shape[0])
        ssim, l1 = similarity(f_in, rec, box)
        if l1 <= bound:
            break
        lam /= 4.0
    stats = dict(n_points=float(len(pts)), n_dense=float(n_dense), sparsity=len(pts) / n_dense,
                 ssim=ssim, l1=l1, drawn=float(len(pts)), cost_lloyd=l1, cost_final=l1,
                 ssim_target=ssim, l1_target=l1, **extra)
    return SparsePSF(pts, vals, False, stats, basis="rows")


def sparsify(psf: np.ndarray, *, density: float = 1.0, seed: int = 0,
             dart_failures: int = 10_000, lloyd_iterations: int = 50, anneal_steps: int = 400,
             anneal_fraction: float = 0.01, rays: int | Sequence[int] | None = None,
             basis: str = "laplacian", denoise_tau: float | None = None) -> SparsePSF:
    """Turn a dense PSF into spreadlets (LSR18 section 5.5) or keep it dense (section 6.4).

    Parameters
    ----------
    psf : ndarray, (R, R, C), C = 1 or 3
        Dense PSF centred at pixel (R//2, R//2): finite, non-negative, each channel summing to 1,
        zero within 2 px of the border.
    density : float, default 1.0
        Sparsity knob: about ``density`` times the default number of spreadlets (LSR18 Fig. 10d
        uses 0.5, 1 and 2). Thin rims saturate: a rim has only so many pixels.
    seed : int, default 0
        Seed of the numpy Generator behind every random choice; same seed, same result.
    dart_failures : int, default 10000
        Dart throwing stops after this many consecutive rejected candidates.
    lloyd_iterations : int, default 50
        Lloyd relaxation iterations (stops early at a fixed point).
    anneal_steps : int, default 400
        Simulated annealing steps.
    anneal_fraction : float, default 0.01
        Fraction of the points moved per annealing step (at least one).
    rays : int or sequence of int, optional
        The PSF is a histogram of this many equal-weight rays (the tracer's count): it is denoised
        first and Laplacian values within the noise get no spreadlets (:mod:`lab.sparsify.noise`).
        A sequence gives each channel's own count, for RGB tracers whose rays pick a channel and
        whose channels are normalised separately (the rays landing in each channel,
        ``TraceResult.counts.sum(axis=(0, 1))``). None (default): the PSF is exact.
    basis : {"laplacian", "rows"}, default "laplacian"
        LSR18's Laplacian spreadlets, or row differences (:mod:`lab.sparsify.rows`: a Potts fit of
        each row; ``seed`` and the dart/Lloyd/anneal settings do not apply, ``density`` scales
        its segment cost). ``stats`` has the same keys either way.
    denoise_tau : float, optional
        The Laplacian spreadlets' denoising level (:func:`lab.sparsify.noise.denoise`'s ``tau``;
        default its ``TAU``): larger blurs a traced PSF less, keeping thin rims sharp for more
        noise left in the importance.

    Returns
    -------
    SparsePSF
        Spreadlets and statistics, or the dense fast-track PSF. ``stats`` also holds ``rays``
        (the ray count, the smallest channel's if per channel; 0 if exact), ``denoise_sigma`` (px, the
        widest blur any pixel's rays got) and ``ssim_target`` /
        ``l1_target``, the similarity to the denoised PSF the spreadlets were fitted to.

    Raises
    ------
    UserError
        On a malformed PSF or parameter; the message names it and the fix.
    """
    f_in = check_psf(psf)
    check_params(density, seed, dart_failures, lloyd_iterations, anneal_steps, anneal_fraction,
                 rays)
    if basis not in BASES:
        raise UserError(f"sparsify: basis = {basis!r}; choose one of {list(BASES)}")
    rng = np.random.default_rng(seed)
    n_dense = dense_count(f_in)
    quantum = None if rays is None else _quantum(rays, f_in.shape[2])
    f, floor, coarse, reach = f_in, None, None, LEVEL_REACH
    extra = dict(rays=0.0, denoise_sigma=0.0)
    if basis == "rows":
        if quantum is not None:
            extra["rays"] = float(1.0 / quantum.max())
        return _sparsify_rows(f_in, density, quantum, n_dense, extra)
    if quantum is not None:
        dn = denoise(f_in, quantum, tau=denoise_tau)
        f, floor, reach = dn.psf, K_SIGMA * dn.lap_sd, dn.reach
        extra = dict(rays=float(1.0 / quantum.max()), denoise_sigma=dn.sigma)
    lap = psf_laplacian(f)
    box = working_box(f, lap)
    lap_b = box.crop(lap)
    if floor is not None:
        coarse = coarse_laplacian(lap, floor, f_in, quantum)
    imp = box.crop(importance(f, lap, floor, coarse, reach))
    if not (imp > 0).any():  # nothing above the noise: fall back to the plain importance
        imp = box.crop(importance(f, lap))
    sy, sx = np.nonzero(imp > 0)
    shape = (box.h, box.w)
    py, px = throw_darts(sy, sx, imp[sy, sx], MASS / density, rng, dart_failures, shape)
    if py.size >= n_dense:  # Lloyd and annealing never add points: decided already
        return _dense(f_in, py.size, n_dense, extra)
    py, px = lloyd(sy, sx, imp[sy, sx], py, px, lloyd_iterations)
    cost = BoxCost(box.crop(f))
    lap_s = lap_b[sy, sx]
    nonzero = lap_b.any(axis=2)
    match = MomentMatch(*np.nonzero(nonzero), lap_b[nonzero])
    fixed = _below_floor_values(nonzero & ~(imp > 0), lap_b, py, px)
    if anneal_steps > 0:
        res = anneal(sy, sx, lap_s, py, px, cost, rng, anneal_steps, anneal_fraction,
                     _move_bounds(sy, sx, box, f.shape[0]), match, fixed)
        py, px = res.py, res.px
        cost_lloyd, cost_final = res.start_cost, float(res.best_costs[-1])
    # exact per-cell sums (the annealer's are incremental); same tie rule, same cells
    labels, _ = assign(sy, sx, py, px, shape)
    vals = match(py, px, collapse(labels, lap_s, py.size) + fixed)
    if anneal_steps == 0:
        canvas = np.zeros(cost.target.shape)
        np.add.at(canvas, (py, px), vals)
        cost_lloyd = cost_final = cost(canvas)
    c = f.shape[0] // 2
    pts, vals = merge_coincident(np.column_stack([px + box.x0 - c, py + box.y0 - c]), vals)
    if len(pts) >= n_dense:
        return _dense(f_in, len(pts), n_dense, extra)
    sparse = SparsePSF(pts.astype(np.int16), vals.astype(np.float32), False)
    rec = sparse.reconstruct(f.shape[0])
    ssim, l1 = similarity(f_in, rec, box)
    ssim_t, l1_t = (ssim, l1) if quantum is None else similarity(f, rec, box)
    stats = dict(n_points=float(len(pts)), n_dense=float(n_dense), sparsity=len(pts) / n_dense,
                 ssim=ssim, l1=l1, drawn=float(len(pts)), cost_lloyd=cost_lloyd,
                 cost_final=cost_final, ssim_target=ssim_t, l1_target=l1_t, **extra)
    return SparsePSF(sparse.points, sparse.values, False, stats)

"""LSR18 section 5.5 end to end: a dense PSF becomes sparse Laplacian "spreadlets".

Steps: Laplacian (:mod:`.laplacian`), dart throwing (:mod:`.dart`), Lloyd (:mod:`.lloyd`), Voronoi
collapse (:mod:`.voronoi`), simulated annealing (:mod:`.anneal`), merge (:mod:`.merge`), then the
fast-track decision of LSR18 section 6.4 and the statistics of section 7.3 (:mod:`.stats`).

The sparsity knob: each dart-throwing disk carries the importance mass ``MASS / density``
(importance = |Laplacian| in units of the PSF's intensity level, :mod:`.laplacian`), so the point
count scales about linearly with ``density``. ``MASS`` was chosen on pre-filtered discs
(r = 5 .. 250 px, 3 px rim ramp): see the module constant for the measured trade-off.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from lab.errors import UserError
from runtime_cl.integrate import poisson_integrate

from .anneal import anneal
from .cost import BoxCost
from .dart import throw_darts
from .laplacian import importance, psf_laplacian, working_box
from .lloyd import lloyd
from .merge import merge_coincident
from .moments import MomentMatch
from .stats import dense_count, similarity
from .voronoi import assign, collapse

__all__ = ["sparsify", "SparsePSF", "MASS"]

# Importance mass per dart-throwing disk at density 1 (see the module docstring).
MASS = 2.0


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
    """

    points: np.ndarray
    values: np.ndarray
    fast_track: bool
    stats: dict = field(default_factory=dict)
    dense: np.ndarray | None = None
    dense_origin: tuple[int, int] = (0, 0)

    def reconstruct(self, resolution: int) -> np.ndarray:
        """The PSF as the runtime draws it, centred in an (R, R, C) float32 image.

        Spreadlets are splatted into a Laplacian canvas and integrated with
        :func:`runtime_cl.integrate.poisson_integrate`; the fast track places ``dense``.

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
        if len(self.points):
            ext = int(np.abs(self.points.astype(np.int64)).max())
            if c - ext < 1 or c + ext > resolution - 2:
                raise UserError(f"reconstruct: resolution = {resolution} cannot hold spreadlets "
                                f"{ext} px from the centre; use resolution >= {2 * ext + 5}")
        lap = np.zeros((resolution, resolution, chans), np.float64)
        np.add.at(lap, (c + self.points[:, 1].astype(np.int64),
                        c + self.points[:, 0].astype(np.int64)), self.values.astype(np.float64))
        return poisson_integrate(lap)


def _check_psf(psf) -> np.ndarray:
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


def _check_params(density, seed, dart_failures, lloyd_iterations, anneal_steps, anneal_fraction):
    def is_int(v):
        return isinstance(v, (int, np.integer)) and not isinstance(v, bool)

    if not (isinstance(density, (int, float)) and math.isfinite(density) and density > 0):
        raise UserError(f"sparsify: density = {density!r} must be a finite number > 0 "
                        "(1.0 = default, 2.0 = about twice the spreadlets)")
    if not is_int(seed) or seed < 0:
        raise UserError(f"sparsify: seed = {seed!r} must be an integer >= 0")
    for name, v, lo in (("dart_failures", dart_failures, 1),
                        ("lloyd_iterations", lloyd_iterations, 0),
                        ("anneal_steps", anneal_steps, 0)):
        if not is_int(v) or v < lo:
            raise UserError(f"sparsify: {name} = {v!r} must be an integer >= {lo}")
    if not (isinstance(anneal_fraction, (int, float)) and 0 < anneal_fraction <= 1):
        raise UserError(f"sparsify: anneal_fraction = {anneal_fraction!r} must be in (0, 1]")


def _dense(f, n_points, n_dense) -> SparsePSF:
    mask = (f != 0).any(axis=2)
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    c = f.shape[0] // 2
    crop = f[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1].astype(np.float32)
    stats = dict(n_points=float(n_points), n_dense=float(n_dense),
                 sparsity=n_points / n_dense, ssim=1.0, l1=0.0, drawn=float(n_dense),
                 cost_lloyd=0.0, cost_final=0.0)
    chans = f.shape[2]
    return SparsePSF(np.zeros((0, 2), np.int16), np.zeros((0, chans), np.float32), True, stats,
                     crop, (int(cols[0]) - c, int(rows[0]) - c))


def sparsify(psf: np.ndarray, *, density: float = 1.0, seed: int = 0,
             dart_failures: int = 10_000, lloyd_iterations: int = 50, anneal_steps: int = 400,
             anneal_fraction: float = 0.01) -> SparsePSF:
    """Turn a dense PSF into spreadlets (LSR18 section 5.5) or keep it dense (section 6.4).

    Parameters
    ----------
    psf : ndarray, (R, R, C), C = 1 or 3
        Dense PSF centred at pixel (R//2, R//2): finite, non-negative, each channel summing to 1,
        zero within 2 px of the border.
    density : float, default 1.0
        Sparsity knob: about ``density`` times the default number of spreadlets (LSR18 Fig. 10d
        uses 0.5, 1 and 2).
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

    Returns
    -------
    SparsePSF
        Spreadlets and statistics, or the dense fast-track PSF.

    Raises
    ------
    UserError
        On a malformed PSF or parameter; the message names it and the fix.
    """
    f = _check_psf(psf)
    _check_params(density, seed, dart_failures, lloyd_iterations, anneal_steps, anneal_fraction)
    rng = np.random.default_rng(seed)
    n_dense = dense_count(f)
    lap = psf_laplacian(f)
    box = working_box(f, lap)
    imp, lap_b = box.crop(importance(f, lap)), box.crop(lap)
    sy, sx = np.nonzero(imp > 0)
    shape = (box.h, box.w)
    py, px = throw_darts(sy, sx, imp[sy, sx], MASS / density, rng, dart_failures, shape)
    if py.size >= n_dense:  # Lloyd and annealing never add points: decided already
        return _dense(f, py.size, n_dense)
    py, px = lloyd(sy, sx, imp[sy, sx], py, px, lloyd_iterations)
    cost = BoxCost(box.crop(f))
    lap_s = lap_b[sy, sx]
    match = MomentMatch(sy, sx, lap_s)
    if anneal_steps > 0:
        bounds = (max(int(sy.min()) - 2, 1), min(int(sy.max()) + 2, box.h - 2),
                  max(int(sx.min()) - 2, 1), min(int(sx.max()) + 2, box.w - 2))
        res = anneal(sy, sx, lap_s, py, px, cost, rng, anneal_steps, anneal_fraction, bounds,
                     match)
        py, px = res.py, res.px
        cost_lloyd, cost_final = res.start_cost, float(res.best_costs[-1])
    # exact per-cell sums (the annealer's are incremental); same tie rule, same cells
    labels, _ = assign(sy, sx, py, px, shape)
    vals = match(py, px, collapse(labels, lap_s, py.size))
    if anneal_steps == 0:
        canvas = np.zeros(cost.target.shape)
        np.add.at(canvas, (py, px), vals)
        cost_lloyd = cost_final = cost(canvas)
    c = f.shape[0] // 2
    pts = np.column_stack([px + box.x0 - c, py + box.y0 - c])
    pts, vals = merge_coincident(pts, vals)
    if len(pts) >= n_dense:
        return _dense(f, len(pts), n_dense)
    sparse = SparsePSF(pts.astype(np.int16), vals.astype(np.float32), False)
    ssim, l1 = similarity(f, sparse.reconstruct(f.shape[0]), box)
    stats = dict(n_points=float(len(pts)), n_dense=float(n_dense), sparsity=len(pts) / n_dense,
                 ssim=ssim, l1=l1, drawn=float(len(pts)), cost_lloyd=cost_lloyd,
                 cost_final=cost_final)
    return SparsePSF(sparse.points, sparse.values, False, stats)

"""Every PSF turned once per quantised angle, so the splat kernel turns nothing per pixel.

Moving scenes turn each pixel's PSF by its own angle (``kernels/spreadlets/rotate.cl``). Turning
per pixel costs: a turned spreadlet is shared bilinearly among four pixels (four writes), and a
fast-tracked dense PSF is resampled by inverse bilinear mapping for every run of pixels -- and
runs are short, since neighbouring pixels of a rotating object differ in angle. On ``whirl``
(1024^2) the turned fast-tracked cells (thin motion streaks, dense in any representation: the
Laplacian of a 1-2 px wide line is 3 px wide) cost the same in the spreadlet and Splat passes.

The bank holds, for each cell i, its PSF turned by K_i angles 2 pi k / K_i: spreadlets shared
bilinearly exactly as the kernel shares them, with the four shares of neighbouring spreadlets
merged per pixel (fewer writes than 4 per spreadlet), and fast-tracked dense PSFs resampled and
energy-scaled exactly as ``rotate.cl`` resamples them, stored as row spans. A pixel then takes
the bank entry of the angle nearest its own, and the kernel splats it with the unrotated code
(``BANK`` in ``kernels/spreadlets/splat.cl``); runs of pixels with the same cell and angle index
form as in a still image. Measured on whirl at 1024^2 (README, "Where a spreadlet frame's time
goes"): Splat / spreadlets 1.4x -> 4.1x (7.5-7.9x with the dual basis and without Laplacian
entries, :func:`bank_needs`), SSIM 0.99972 against the per-pixel turn. Only the entries a
frame draws are built (``entries``; on whirl 8.8 k of 60.5 k: ~1 s, where every angle of its 118
turned cells took ~5 s and, before, 21-31 s), so the bank is the spreadlet passes' default.

The price is the angle quantisation: a PSF point at distance R from the centre moves by at most
R pi / K_i. K_i is chosen per cell so that this stays below ``angle_error_px`` for the cell's
farthest point, rounded up to a multiple of 4 (quarter and half turns, the ``coc_sign``
symmetry's pi among them, stay exact).
"""
from __future__ import annotations

import math

import numpy as np

from runtime_cl.errors import InputError
from runtime_cl.masks import nonzero_pixels
from runtime_cl.psf.database import SpreadletDatabase
from runtime_cl.psf.upload import KIND_DENSE, KIND_LAPLACIAN, KIND_ROWS, dense_row_spans, half_turn_rows

__all__ = ["ANGLE_ERROR_PX", "LAPLACIAN_PLANE_ADDS", "AngleBank", "angle_counts", "angles_for_reach",
           "bank_needs", "cell_reach", "entry_of", "turned_dense", "turned_spreadlets"]

# Largest displacement (px) of a PSF's farthest point by the angle rounding; see the module docstring
# and README ("Where a spreadlet frame's time goes") for the SSIM it costs on whirl. At 0.5 px the
# held-out brute-force check of the combined model (tests/lab/precompute/
# test_runtime_matches_brute_force.py: motion angles changing every few pixels) fell to SSIM 0.994,
# below its 0.995 floor; 0.25 px passes it.
ANGLE_ERROR_PX = 0.25
MAX_ANGLES = 1024   # bounds the bank's size (a PSF reaching 80 px at 0.25 px)
# What a frame's Laplacian plane costs per pixel of its box (merge and crop integration), in
# spreadlet adds: on whirl (1024^2, 2-core PoCL) its ~1.1 M px box cost 40-50 ms of merge and
# fft32 integration, ~45 ns/px, against ~0.5 ns per add in the splat kernel.
LAPLACIAN_PLANE_ADDS = 80.0


def angles_for_reach(reach_px: float, error_px: float) -> int:
    """K: the number of angles (a multiple of 4, at least 4) whose rounding moves a point at
    ``reach_px`` from the centre by at most ``error_px`` (half a step: reach pi / K)."""
    k = math.ceil(math.pi * max(reach_px, 1.0) / error_px / 4.0) * 4
    return int(min(max(k, 4), MAX_ANGLES))


def cell_reach(db: SpreadletDatabase, laplacian: bool) -> np.ndarray:
    """How far each cell's bank entries reach from the centre when turned (float64 (n,)): a cell
    drawn dense (fast-tracked, or any cell without Laplacian entries) its crop's corner,
    sqrt 2 (r + 1) -- not its farthest non-zero pixel: that tighter bound halved K and fell below
    the brute-force check's SSIM floor (0.9942) -- and a spreadlet cell its farthest spreadlet."""
    dense = db.fast_track.astype(bool) | (not laplacian)
    corner = math.sqrt(2.0) * (db.dense_radius.astype(np.float64) + 1.0)
    norm = np.sqrt((db.P.astype(np.float64) ** 2).sum(axis=1)) if len(db.P) else np.zeros(0)
    far = np.zeros(db.n_samples)
    has = np.diff(db.C) > 0
    if has.any():   # reduceat over the non-empty cells' spans only
        far[has] = np.maximum.reduceat(norm, db.C[:-1][has])
    return np.where(dense, corner, far)


def angle_counts(db: SpreadletDatabase, cells: np.ndarray, laplacian: bool,
                 error_px: float = ANGLE_ERROR_PX) -> np.ndarray:
    """K_i of every cell of an :class:`AngleBank` (int32 (n,)): :func:`angles_for_reach` of its
    :func:`cell_reach` for the ``cells`` turned by every angle, 4 (the quarter turns) for the
    others."""
    reach = cell_reach(db, laplacian)
    return np.array([angles_for_reach(r, error_px) if c else 4 for r, c in zip(reach, np.asarray(cells, bool))],
                    np.int32)


def entry_of(K: np.ndarray, cell: np.ndarray, angle: np.ndarray, margin: float = 1e-3) -> tuple:
    """The bank entries (cell, k) pixels of ``cell`` (int) at ``angle`` (float32 radians) take, as
    ``bank_entry`` in ``kernels/spreadlets/splat.cl`` rounds them: ``(cell, k)`` int64 arrays,
    each pixel once, and again with the neighbouring k where its angle lies within ``margin``
    of a step's half-way point (float32 rounding on the device may land it either side)."""
    Kc = K[cell].astype(np.float32)
    t = np.fmod(np.asarray(angle, np.float32), np.float32(2.0 * np.pi)) * (Kc * np.float32(0.5 / np.pi))
    k = np.rint(t)
    off = t - k
    near = np.abs(np.abs(off) - 0.5) < margin
    kk = np.concatenate([k, (k + np.sign(off))[near]]).astype(np.int64)
    cc = np.concatenate([cell, cell[near]]).astype(np.int64)
    return cc, np.mod(kk, K[cc])


def bank_cs(k: int, K: int) -> tuple:
    """(cos, sin) of 2 pi k / K, exact (0, +-1) at quarter turns as ``rotation_cs`` makes them."""
    if (4 * k) % K == 0:
        q = (4 * k // K) % 4
        return ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))[q]
    a = 2.0 * math.pi * k / K
    return math.cos(a), math.sin(a)


def turned_spreadlets(P: np.ndarray, V: np.ndarray, cs: np.ndarray) -> tuple:
    """Spreadlets (P int (n, 2) offsets (dx, dy), V (n, C)) turned by each of cs ((K, 2) cos,
    sin) and shared bilinearly among the four pixels around each turned offset
    (``splat_spreadlets_rotated``), the shares summed per pixel. Returns (counts (K,), P int16
    (m, 2), V float32 (m, C)): the turns one after another, each sorted by (dy, dx)."""
    K, ch = len(cs), V.shape[1]
    if not len(P):
        return np.zeros(K, np.int64), np.zeros((0, 2), np.int16), np.zeros((0, ch), np.float32)
    c, s = cs[:, :1], cs[:, 1:]
    x, y = P[None, :, 0].astype(np.float64), P[None, :, 1].astype(np.float64)
    fx, fy = c * x + s * y, c * y - s * x   # rotate_xy, (K, n)
    ix, iy = np.floor(fx), np.floor(fy)
    wx, wy = fx - ix, fy - iy
    ix, iy = ix.astype(np.int64), iy.astype(np.int64)
    px = np.concatenate([ix, ix + 1, ix, ix + 1], axis=1)
    py = np.concatenate([iy, iy, iy + 1, iy + 1], axis=1)
    w = np.concatenate([(1 - wx) * (1 - wy), wx * (1 - wy), (1 - wx) * wy, wx * wy], axis=1)
    k = np.broadcast_to(np.arange(K)[:, None], w.shape)
    keep = w != 0.0   # quarter turns: one share of weight 1
    px, py, w, k = px[keep], py[keep], w[keep], k[keep]
    vals = np.tile(V.astype(np.float64), (4, 1))[np.nonzero(keep)[1]] * w[:, None]
    lo = min(px.min(), py.min())
    span = max(px.max(), py.max()) - lo + 1
    key = (k * span + (py - lo)) * span + (px - lo)
    uniq, inv = np.unique(key, return_inverse=True)
    out = np.zeros((len(uniq), ch))
    np.add.at(out, inv, vals)
    pix = uniq % (span * span)
    pts = np.column_stack([pix % span + lo, pix // span + lo]).astype(np.int16)
    return np.bincount(uniq // (span * span), minlength=K), pts, out.astype(np.float32)


def turned_dense(psf: np.ndarray, cs: np.ndarray) -> list:
    """A dense PSF ((2r+1, 2r+1, C), centre [r, r]) turned by each of cs ((K, 2)) as
    ``rotate.cl`` turns it: destination offset d takes the stored PSF bilinearly at R^-1 d (zero
    outside the crop's support |R^-1 d| < r + 1), scaled per channel to keep the stored sum.
    Only destinations within sqrt 2 of a turned non-zero pixel can be non-zero (bilinear support),
    so only those are sampled (a thin streak: a few hundred per angle instead of its whole
    turned square). Returns, per angle, the bank's layout of the turned crop (the smallest centred
    square holding its non-zero pixels): ``(radius, spans, values)``, spans ((2 radius + 1, 2)
    int32, [first, end) columns of each row's non-zero pixels, (0, 0) for an empty row, as
    :func:`runtime_cl.psf.upload.dense_row_spans`) and the float32 values inside the spans, row
    after row."""
    r, ch = psf.shape[0] // 2, psf.shape[2]
    K = len(cs)
    ys, xs = np.nonzero(np.any(psf != 0, axis=2))
    if not len(ys):
        return [_empty_entry(ch)] * K
    sx0, sy0 = (xs - r).astype(np.float64), (ys - r).astype(np.float64)
    c, s = cs[:, :1], cs[:, 1:]
    fx, fy = c * sx0 + s * sy0, c * sy0 - s * sx0   # rotate_xy of the non-zero pixels, (K, m)
    off = np.arange(-1, 3)
    cx = (np.floor(fx)[:, :, None, None].astype(np.int64) + off[None, None, None, :])
    cy = (np.floor(fy)[:, :, None, None].astype(np.int64) + off[None, None, :, None])
    cx, cy = np.broadcast_arrays(cx, cy)
    big = 2 * int(math.ceil((r + 3) * math.sqrt(2.0))) + 1
    k = np.broadcast_to(np.arange(K)[:, None, None, None], cx.shape)
    # the candidate destinations, sorted by (angle, dy, dx) and unique: marked on the (K, big, big)
    # grid they lie in (a hash of ~10^6 keys per chunk was a third of a bank's build)
    mark = np.zeros(K * big * big, bool)
    mark[((k * big + (cy + big // 2)) * big + (cx + big // 2)).ravel()] = True
    key = np.flatnonzero(mark)
    kk, rest = key // (big * big), key % (big * big)
    dy, dx = (rest // big - big // 2).astype(np.float64), (rest % big - big // 2).astype(np.float64)
    c, s = cs[kk, 0], cs[kk, 1]
    sx, sy = c * dx - s * dy, s * dx + c * dy   # R^-1 d
    inside = (np.abs(sx) < r + 1) & (np.abs(sy) < r + 1)
    ix, iy = np.floor(sx).astype(np.int64), np.floor(sy).astype(np.int64)
    wx, wy = (sx - ix)[:, None], (sy - iy)[:, None]
    f = psf.astype(np.float64)
    padded = np.zeros((f.shape[0] + 4, f.shape[1] + 4, ch))
    padded[2:-2, 2:-2] = f   # taps one outside the crop read zeros

    def tap(xx, yy):
        return padded[np.clip(yy + r + 2, 0, padded.shape[0] - 1), np.clip(xx + r + 2, 0, padded.shape[1] - 1)]

    val = (tap(ix, iy) * ((1 - wx) * (1 - wy)) + tap(ix + 1, iy) * (wx * (1 - wy))
           + tap(ix, iy + 1) * ((1 - wx) * wy) + tap(ix + 1, iy + 1) * (wx * wy))
    val[~inside] = 0.0
    stored = f.sum(axis=(0, 1))
    turned = np.zeros((K, ch))
    np.add.at(turned, kk, val)
    ok = (stored > 0) & (turned > 0)
    val *= np.where(ok, stored / np.where(ok, turned, 1.0), 1.0)[kk]
    live = np.any(val != 0, axis=1)
    kk, dx, dy, val = kk[live], dx[live].astype(np.int64), dy[live].astype(np.int64), val[live]
    return _spans_of(kk, dx, dy, val, K, ch)


def _empty_entry(ch: int) -> tuple:
    """An all-zero entry: radius 0, one empty row."""
    return 0, np.zeros((1, 2), np.int32), np.zeros((0, ch), np.float32)


def _spans_of(kk, dx, dy, val, K: int, ch: int) -> list:
    """:func:`turned_dense`'s entries from the non-zero pixels (angle kk, offset (dx, dy), values),
    sorted by (kk, dy, dx): each row's span from its first to its last pixel, zeros between."""
    bounds = np.searchsorted(kk, np.arange(K + 1))
    if not len(kk):
        return [_empty_entry(ch)] * K
    group = np.flatnonzero(np.diff(kk, prepend=-1) | np.diff(dy, prepend=dy[0] - 1))   # (kk, dy) runs
    last = np.append(group[1:], len(kk)) - 1
    first_x, end_x = dx[group], dx[last] + 1
    starts = np.concatenate([[0], np.cumsum(end_x - first_x)])
    values = np.zeros((int(starts[-1]), ch), np.float32)
    values[np.repeat(starts[:-1] - first_x, last - group + 1) + dx] = val
    g_bounds = np.searchsorted(kk[group], np.arange(K + 1))
    out = []
    for a in range(K):
        lo, hi = bounds[a], bounds[a + 1]
        if lo == hi:
            out.append(_empty_entry(ch))
            continue
        radius = int(max(np.abs(dx[lo:hi]).max(), np.abs(dy[lo:hi]).max()))
        g = slice(g_bounds[a], g_bounds[a + 1])
        spans = np.zeros((2 * radius + 1, 2), np.int32)
        rows = dy[group[g]] + radius
        spans[rows, 0], spans[rows, 1] = first_x[g] + radius, end_x[g] + radius
        out.append((radius, spans, values[starts[g_bounds[a]]:starts[g_bounds[a + 1]]]))
    return out


def row_turns(P: np.ndarray, V: np.ndarray) -> list:
    """A row cell's entries at angle 0 and pi: [(P, V) as stored, (P, V) half-turned] (the half
    turn's difference at x is minus the stored one's at 1 - x, as ``splat.cl`` draws it per
    pixel), each sorted by (dy, dx)."""
    turned = np.column_stack([1 - P[:, 0].astype(np.int64), -P[:, 1].astype(np.int64)])
    out = []
    for p, v in ((P.astype(np.int64), V), (turned, -V)):
        order = np.lexsort((p[:, 0], p[:, 1]))
        out.append((p[order].astype(np.int16), v[order].astype(np.float32)))
    return out


def _row_entries(db: SpreadletDatabase, i: int, cs: np.ndarray, ks: list, per: list, dense: list,
                 kinds: list) -> None:
    """Cell ``i``'s bank entries at angles 0 and pi (``ks``: those of k = 0 and K / 2 the bank
    builds; ``cs`` their (cos, sin)) replaced by a dual database's row differences (or its dense
    PSF, if fast-tracked as rows): ``per`` (spreadlets per angle), ``dense`` and ``kinds`` in
    place."""
    ch = db.channels
    if db.row_fast[i]:
        turned = turned_dense(db.dense_psf(i), cs)
        for k, d in zip(ks, turned):
            dense[k], kinds[k] = d, KIND_DENSE
            per[k] = (np.zeros((0, 2), np.int16), np.zeros((0, ch), np.float32))
        return
    rows = row_turns(*db.row_spreadlets(i))
    for k, (c, _) in zip(ks, cs):
        per[k] = rows[0 if c > 0 else 1]
        dense[k], kinds[k] = _empty_entry(ch), KIND_ROWS


def _half_turn_rows(db: SpreadletDatabase, dense_n: np.ndarray, laplacian: bool) -> np.ndarray:
    """(n,) bool: the cells whose bank entries at 0 and pi are a ``"dual"`` database's row
    differences: those the kernel draws so per pixel (:func:`half_turn_rows`), and without
    Laplacian entries also every other cell whose rows cost fewer adds than its dense PSF."""
    if db.basis != "dual":
        return np.zeros(db.n_samples, bool)
    rows = half_turn_rows(db, dense_n)
    if not laplacian:
        rows |= ~db.fast_track & ~db.row_fast & (np.diff(db.row_C) < dense_n)
    return rows


def bank_needs(db: SpreadletDatabase, colour: np.ndarray, coords: np.ndarray, angle: np.ndarray,
               dense_n: np.ndarray | None = None, lit_cells: np.ndarray | None = None) -> tuple:
    """What an :class:`AngleBank` must hold to draw this frame: ``(cells, laplacian)``.

    ``cells`` (n,) bool: the cells of the lit pixels whose angle is no multiple of 90 degrees
    (the turns the bank must hold at every angle; ``rotation_cs``'s 2^-19 rad tolerance).
    ``laplacian``: whether the frame is cheaper with Laplacian entries than without them. Without,
    each pixel that would draw Laplacian spreadlets draws its dense PSF (or, at 0 and pi, its row
    differences) instead, at ``extra`` more adds, but the frame has no Laplacian plane to merge and
    integrate: dropped when ``extra`` < :data:`LAPLACIAN_PLANE_ADDS` x the box of those pixels
    widened by the database's reach. On whirl a horizontally sliding capsule is the only
    Laplacian left (its rows are ramps: 857 row differences against 247 Laplacian spreadlets),
    +22 M adds against a 1.1 M px box. ``dense_n``: each dense PSF's pixels in its row spans
    (default :func:`~runtime_cl.psf.upload.dense_row_spans`'s). ``lit_cells``: the cells of the
    lit (non-zero) pixels in row-major order, if the caller has them (the
    :class:`~runtime_cl.spreadlets.renderer.Renderer` takes the splat kernel's own map on the
    device); default the grid's numpy map.
    """
    lit = nonzero_pixels(colour)
    cells = np.zeros(db.n_samples, bool)
    if not lit.any():
        return cells, False
    a = np.fmod(angle[lit].astype(np.float64), 2.0 * math.pi)
    quarter = np.rint(a / (0.5 * math.pi))
    off = np.abs(a - quarter * (0.5 * math.pi)) > 2.0 ** -19
    cell = db.grid.index(np.asarray(coords[lit], np.float64)) if lit_cells is None else lit_cells
    cells[np.unique(cell[off])] = True
    dense_n = dense_row_spans(db)[2] if dense_n is None else dense_n
    half = ~off & (quarter.astype(np.int64) % 2 == 0)
    half_rows = _half_turn_rows(db, dense_n, True)
    lap = ~db.fast_track[cell] & ~(half & half_rows[cell])
    if not lap.any():
        return cells, False
    c = cell[lap]
    instead = dense_n[c]
    if db.basis == "dual":   # at 0 and pi the cheaper of rows and dense (_half_turn_rows without Laplacian)
        rows = np.where(db.row_fast[c], dense_n[c], np.minimum(np.diff(db.row_C)[c], dense_n[c]))
        instead = np.where(half[lap], rows, instead)
    extra = float(np.sum(instead - np.diff(db.C)[c]))
    ys, xs = np.nonzero(lit)
    ys, xs = ys[lap], xs[lap]
    box = float((ys.max() - ys.min() + 1 + 2 * db.pad) * (xs.max() - xs.min() + 1 + 2 * db.pad))
    return cells, extra >= LAPLACIAN_PLANE_ADDS * box


class AngleBank:
    """Host arrays of the turned PSFs, laid out as a database of ``sum(K_i)`` samples.

    Entry ``base[i] + k`` is cell i turned by 2 pi k / K_i (``k = 0`` the stored PSF). The
    arrays have the names and layouts of :class:`~runtime_cl.psf.upload.DeviceDatabase`'s
    buffers (``C, P, V, fast, dense_r, dense_off, dense_v, span_off, span, dense_n``),
    spreadlets sorted by (dy, dx), except that ``dense_v`` holds each row's span only (rows one
    after another; ``dense_off`` indexes those values). ``fast`` holds each entry's kind
    (:func:`~runtime_cl.psf.upload.cell_kinds`): a ``"dual"`` database's cells hold their row
    differences at k = 0 and, half-turned, at k = K_i / 2 where the kernel draws them per pixel
    (:func:`~runtime_cl.psf.upload.half_turn_rows`).

    Parameters
    ----------
    db : SpreadletDatabase
        The database.
    angle_error_px : float
        Largest displacement of a cell's farthest point by the angle rounding (> 0; default
        :data:`ANGLE_ERROR_PX`).
    cells : ndarray of bool (n,), optional
        The cells to turn by every angle; the others get only the four quarter turns (exact
        for angles that are multiples of 90 degrees, e.g. the ``coc_sign`` symmetry's 0 and
        pi). Default: every cell. The :class:`~runtime_cl.spreadlets.renderer.Renderer` passes
        the cells its frames turn by other angles, so a bank holds what is drawn.
    laplacian : bool, default True
        False: no entry is Laplacian spreadlets, so a frame drawn from the bank has no Laplacian
        plane to merge and integrate (:func:`bank_needs` says when that is cheaper): a cell
        that is not fast-tracked holds its dense PSF turned, and at angles 0 and pi its row
        differences where they cost less (a ``"dual"`` database).
    entries : ndarray of bool (sum K_i,), optional
        The entries to build (by :func:`angle_counts`' layout); the others are left empty.
        Default: all. The renderer passes those its frames draw (:func:`entry_of`): building a
        turned PSF is the bank's cost, and a frame draws few of its angles.
    """

    def __init__(self, db: SpreadletDatabase, angle_error_px: float = ANGLE_ERROR_PX, cells=None,
                 laplacian: bool = True, entries=None):
        if isinstance(angle_error_px, bool) or not (isinstance(angle_error_px, (int, float))
                                                    and 0.01 <= angle_error_px <= 10.0):
            raise InputError(f"angle_error_px = {angle_error_px!r}: must be a number in [0.01, 10] px "
                             "(the largest displacement of a PSF point by the angle rounding)")
        self.angle_error_px = float(angle_error_px)
        self.laplacian = bool(laplacian)
        n, ch = db.n_samples, db.channels
        self.cells = np.ones(n, bool) if cells is None else np.asarray(cells, bool).copy()
        k_of = angle_counts(db, self.cells, self.laplacian, self.angle_error_px)
        self.built = np.ones(int(k_of.sum()), bool) if entries is None else np.asarray(entries, bool).copy()
        if self.built.shape != (int(k_of.sum()),):
            raise InputError(f"entries: shape {self.built.shape}, need one flag per bank entry ({int(k_of.sum())},)")
        base = np.concatenate([[0], np.cumsum(k_of)[:-1]])
        P_parts, V_parts, counts, fast, dense_parts = [], [], [], [], []
        dense_n = dense_row_spans(db)[2]
        half_rows = _half_turn_rows(db, dense_n, laplacian)
        empty_pv = (np.zeros((0, 2), np.int16), np.zeros((0, ch), np.float32))
        for i in range(n):
            K = int(k_of[i])
            ks = np.flatnonzero(self.built[base[i]:base[i] + K])
            is_dense = bool(db.fast_track[i]) or not laplacian
            per, dense = [empty_pv] * K, [_empty_entry(ch)] * K
            entry_kinds = [KIND_DENSE if is_dense else KIND_LAPLACIAN] * K
            rows = [k for k in ks if half_rows[i] and k in (0, K // 2)]   # angles 0 and pi: as the kernel draws them
            turn = [k for k in ks if k not in rows]
            cs = np.array([bank_cs(k, K) for k in turn]).reshape(-1, 2)
            if turn and is_dense:   # in chunks of angles: a 150 px square at 900 angles is 160 MB per array
                psf = db.dense_psf(i)
                for a in range(0, len(turn), 64):
                    for k, d in zip(turn[a:a + 64], turned_dense(psf, cs[a:a + 64])):
                        dense[k] = d
            elif turn:
                cnt, pts, vals = turned_spreadlets(*db.spreadlets(i), cs)
                bounds = np.concatenate([[0], np.cumsum(cnt)])
                for j, k in enumerate(turn):
                    per[k] = (pts[bounds[j]:bounds[j + 1]], vals[bounds[j]:bounds[j + 1]])
            if rows:
                _row_entries(db, i, np.array([bank_cs(k, K) for k in rows]), rows, per, dense, entry_kinds)
            P_parts.extend(p for p, _ in per)
            V_parts.extend(v for _, v in per)
            counts.extend(len(p) for p, _ in per)
            fast.extend(entry_kinds)
            dense_parts.extend(dense)
        self.angles = k_of
        self.base = np.concatenate([[0], np.cumsum(k_of)[:-1]]).astype(np.int32)
        self.C = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        self.P = np.concatenate(P_parts).astype(np.int16)
        self.V = np.concatenate(V_parts).astype(np.float32)
        self.fast = np.array(fast, np.uint8)
        self.dense_r = np.array([r for r, _, _ in dense_parts], np.int32)
        self.span_off = np.concatenate([[0], np.cumsum([len(sp) for _, sp, _ in dense_parts])]).astype(np.int64)
        self.span = np.concatenate([sp for _, sp, _ in dense_parts]).astype(np.int32)
        # values of each row's span only (a turned streak fills a small part of its square)
        self.dense_n = np.array([len(v) for _, _, v in dense_parts], np.int64)
        self.dense_off = np.concatenate([[0], np.cumsum(self.dense_n)]).astype(np.int64)
        self.dense_v = np.concatenate([v for _, _, v in dense_parts]).astype(np.float32)
        # the canvas pad of every entry of these cells, built or not, so that a frame's image does
        # not depend on which entries earlier frames built: a turned entry lies within its
        # reach, one pixel further when shared bilinearly; quarter turns and row differences
        # within the database's own pad (plus the half-turned rows' one column)
        turned = cell_reach(db, laplacian)[self.cells]
        bound = max(db.pad + 1, int(np.floor(turned.max())) + 2 if len(turned) else 0)
        reach = int(np.abs(self.P.astype(np.int64)).max()) if len(self.P) else 0
        self.pad = max(reach + 1, int(self.dense_r.max()) + 1, bound)

    @property
    def n_entries(self) -> int:
        """Turned PSFs in the bank (the sum of every cell's angle count)."""
        return int(self.angles.sum())

    @property
    def nbytes(self) -> int:
        """Host bytes of the bank's arrays."""
        return sum(a.nbytes for a in (self.C, self.P, self.V, self.fast, self.dense_r, self.dense_off,
                                      self.dense_v, self.span_off, self.span, self.dense_n, self.angles,
                                      self.base))


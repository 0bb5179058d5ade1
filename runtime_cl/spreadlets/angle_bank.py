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
energy-scaled exactly as ``rotate.cl`` resamples them, stored as plain dense crops. A pixel then
takes the bank entry of the angle nearest its own, and the kernel splats it with the unrotated
code (``BANK`` in ``kernels/spreadlets/splat.cl``); runs of pixels with the same cell and angle
index form as in a still image.

The price is the angle quantisation: a PSF point at distance R from the centre moves by at most
R pi / K_i. K_i is chosen per cell so that this stays below ``angle_error_px`` for the cell's
farthest point, rounded up to a multiple of 4 (quarter and half turns, the ``coc_sign``
symmetry's pi among them, stay exact).
"""
from __future__ import annotations

import math

import numpy as np

from runtime_cl.errors import InputError
from runtime_cl.psf.database import SpreadletDatabase

__all__ = ["ANGLE_ERROR_PX", "AngleBank", "angles_for_reach", "turned_dense", "turned_spreadlets"]

# Largest displacement (px) of a PSF's farthest point by the angle rounding; see the module docstring
# and README ("Where a spreadlet frame's time goes") for the SSIM it costs on whirl.
ANGLE_ERROR_PX = 0.5
MAX_ANGLES = 1024   # bounds the bank's size (a 160 px PSF at 0.5 px)


def angles_for_reach(reach_px: float, error_px: float) -> int:
    """K: the number of angles (a multiple of 4, at least 4) whose rounding moves a point at
    ``reach_px`` from the centre by at most ``error_px`` (half a step: reach pi / K)."""
    k = math.ceil(math.pi * max(reach_px, 1.0) / error_px / 4.0) * 4
    return int(min(max(k, 4), MAX_ANGLES))


def bank_cs(k: int, K: int) -> tuple:
    """(cos, sin) of 2 pi k / K, exact (0, +-1) at quarter turns as ``rotation_cs`` makes them."""
    if (4 * k) % K == 0:
        q = (4 * k // K) % 4
        return ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))[q]
    a = 2.0 * math.pi * k / K
    return math.cos(a), math.sin(a)


def turned_spreadlets(P: np.ndarray, V: np.ndarray, cs: tuple) -> tuple:
    """Spreadlets (P int (n, 2) offsets (dx, dy), V (n, C)) turned by cs and shared bilinearly
    among the four pixels around each turned offset (``splat_spreadlets_rotated``), the shares
    summed per pixel. Returns (P int16 (m, 2), V float32 (m, C)) sorted by (dy, dx)."""
    c, s = cs
    x, y = P[:, 0].astype(np.float64), P[:, 1].astype(np.float64)
    fx, fy = c * x + s * y, c * y - s * x   # rotate_xy
    ix, iy = np.floor(fx), np.floor(fy)
    wx, wy = fx - ix, fy - iy
    ix, iy = ix.astype(np.int64), iy.astype(np.int64)
    px = np.concatenate([ix, ix + 1, ix, ix + 1])
    py = np.concatenate([iy, iy, iy + 1, iy + 1])
    w = np.concatenate([(1 - wx) * (1 - wy), wx * (1 - wy), (1 - wx) * wy, wx * wy])
    vals = np.tile(V.astype(np.float64), (4, 1)) * w[:, None]
    keep = w != 0.0   # quarter turns: one share of weight 1
    px, py, vals = px[keep], py[keep], vals[keep]
    if not len(px):
        return np.zeros((0, 2), np.int16), np.zeros((0, V.shape[1]), np.float32)
    lo = min(px.min(), py.min())
    span = max(px.max(), py.max()) - lo + 1
    key = (py - lo) * span + (px - lo)
    uniq, inv = np.unique(key, return_inverse=True)
    out = np.zeros((len(uniq), V.shape[1]))
    np.add.at(out, inv, vals)
    pts = np.column_stack([uniq % span + lo, uniq // span + lo]).astype(np.int16)
    return pts, out.astype(np.float32)


def turned_dense(psf: np.ndarray, cs: tuple) -> np.ndarray:
    """A dense PSF ((2r+1, 2r+1, C), centre [r, r]) turned by cs as ``rotate.cl`` turns it:
    destination offset d takes the stored PSF bilinearly at R^-1 d (zero outside the crop's
    support |R^-1 d| < r + 1), scaled per channel to keep the stored sum. Returns the turned
    PSF cropped to the smallest centred square holding its non-zero pixels, float32."""
    r = psf.shape[0] // 2
    c, s = cs
    reach = int(math.floor((r + 1) * (abs(c) + abs(s))))
    d = np.arange(-reach, reach + 1, dtype=np.float64)
    dx, dy = np.meshgrid(d, d)
    sx, sy = c * dx - s * dy, s * dx + c * dy
    inside = (np.abs(sx) < r + 1) & (np.abs(sy) < r + 1)
    ix, iy = np.floor(sx).astype(np.int64), np.floor(sy).astype(np.int64)
    wx, wy = sx - ix, sy - iy
    f = psf.astype(np.float64)
    padded = np.zeros((f.shape[0] + 4, f.shape[1] + 4, f.shape[2]))
    padded[2:-2, 2:-2] = f   # taps one outside the crop read zeros

    def tap(xx, yy):
        return padded[np.clip(yy + r + 2, 0, padded.shape[0] - 1), np.clip(xx + r + 2, 0, padded.shape[1] - 1)]

    out = (tap(ix, iy) * ((1 - wx) * (1 - wy))[..., None] + tap(ix + 1, iy) * (wx * (1 - wy))[..., None]
           + tap(ix, iy + 1) * ((1 - wx) * wy)[..., None] + tap(ix + 1, iy + 1) * (wx * wy)[..., None])
    out[~inside] = 0.0
    stored, turned = f.sum(axis=(0, 1)), out.sum(axis=(0, 1))
    ok = (stored > 0) & (turned > 0)
    out *= np.where(ok, stored / np.where(ok, turned, 1.0), 1.0)
    nz = np.argwhere(np.any(out != 0, axis=2))
    keep = int(np.abs(nz - reach).max()) if len(nz) else 0
    return out[reach - keep:reach + keep + 1, reach - keep:reach + keep + 1].astype(np.float32)


class AngleBank:
    """Host arrays of the turned PSFs, laid out as a database of ``sum(K_i)`` samples.

    Entry ``base[i] + k`` is cell i turned by 2 pi k / K_i (``k = 0`` the stored PSF). The
    arrays have the names and layouts of :class:`~runtime_cl.psf.upload.DeviceDatabase`'s
    buffers (``C, P, V, fast, dense_r, dense_off, dense_v``), spreadlets sorted by (dy, dx).

    Parameters
    ----------
    db : SpreadletDatabase
        The database.
    angle_error_px : float
        Largest displacement of a cell's farthest point by the angle rounding (> 0; default
        :data:`ANGLE_ERROR_PX`).
    """

    def __init__(self, db: SpreadletDatabase, angle_error_px: float = ANGLE_ERROR_PX):
        if isinstance(angle_error_px, bool) or not (isinstance(angle_error_px, (int, float))
                                                    and 0.01 <= angle_error_px <= 10.0):
            raise InputError(f"angle_error_px = {angle_error_px!r}: must be a number in [0.01, 10] px "
                             "(the largest displacement of a PSF point by the angle rounding)")
        self.angle_error_px = float(angle_error_px)
        n, ch = db.n_samples, db.channels
        k_of = np.zeros(n, np.int32)
        P_parts, V_parts, counts, fast, radii, dense_parts = [], [], [], [], [], []
        for i in range(n):
            is_fast = bool(db.fast_track[i])
            if is_fast:
                psf = db.dense_psf(i)
                reach = math.sqrt(2.0) * (int(db.dense_radius[i]) + 1)
            else:
                p, v = db.spreadlets(i)
                reach = float(np.sqrt((p.astype(np.float64) ** 2).sum(axis=1)).max()) if len(p) else 0.0
            K = angles_for_reach(reach, self.angle_error_px)
            k_of[i] = K
            for k in range(K):
                cs = bank_cs(k, K)
                if is_fast:
                    dense = turned_dense(psf, cs)
                    P_parts.append(np.zeros((0, 2), np.int16))
                    V_parts.append(np.zeros((0, ch), np.float32))
                else:
                    pts, vals = turned_spreadlets(p, v, cs)
                    P_parts.append(pts)
                    V_parts.append(vals)
                    dense = np.zeros((1, 1, ch), np.float32)
                counts.append(len(P_parts[-1]))
                fast.append(is_fast)
                radii.append(dense.shape[0] // 2)
                dense_parts.append(dense.reshape(-1, ch))
        self.angles = k_of
        self.base = np.concatenate([[0], np.cumsum(k_of)[:-1]]).astype(np.int32)
        self.C = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        self.P = np.concatenate(P_parts).astype(np.int16)
        self.V = np.concatenate(V_parts).astype(np.float32)
        self.fast = np.array(fast, np.uint8)
        self.dense_r = np.array(radii, np.int32)
        self.dense_off = np.concatenate([[0], np.cumsum([len(x) for x in dense_parts])]).astype(np.int64)
        self.dense_v = np.concatenate(dense_parts).astype(np.float32)
        reach = int(np.abs(self.P.astype(np.int64)).max()) if len(self.P) else 0
        self.pad = max(reach, int(self.dense_r.max())) + 1

    def dense_view(self) -> "_DenseView":
        """The bank's dense crops as :func:`runtime_cl.psf.upload.dense_row_spans` reads a database."""
        return _DenseView(self.dense_r, self.dense_off, self.dense_v)

    @property
    def n_entries(self) -> int:
        """Turned PSFs in the bank (the sum of every cell's angle count)."""
        return int(self.angles.sum())

    @property
    def nbytes(self) -> int:
        """Host bytes of the bank's arrays."""
        return sum(a.nbytes for a in (self.C, self.P, self.V, self.fast, self.dense_r, self.dense_off,
                                      self.dense_v, self.angles, self.base))


class _DenseView:
    """``dense_radius`` and ``dense_psf(i)`` of the bank's entries (what the span tables read)."""

    def __init__(self, radius, offsets, values):
        self.dense_radius, self._off, self._v = radius, offsets, values

    def dense_psf(self, i: int) -> np.ndarray:
        side = 2 * int(self.dense_radius[i]) + 1
        return self._v[self._off[i]:self._off[i + 1]].reshape(side, side, -1)

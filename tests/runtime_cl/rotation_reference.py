"""Plain numpy references for the rotating kernels (float64), mirroring ``kernels/spreadlets/rotate.cl``."""
from __future__ import annotations

import numpy as np
from cl_reference import _broadcast, cells


def cos_sin(angle: float) -> tuple:
    """(cos, sin) with quarter turns exact, as ``rotation_cs``."""
    a = float(np.fmod(np.float32(angle), np.float32(2 * np.pi)))
    q = np.rint(a / (np.pi / 2))
    if abs(a - q * (np.pi / 2)) <= 2.0 ** -19:
        return [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)][int(q) % 4]
    return np.cos(a), np.sin(a)


def turned_psf(psf: np.ndarray, angle: float) -> np.ndarray:
    """The (2R+1)^2 crop of ``psf`` (2r+1, 2r+1, C) turned by ``angle``: destination offset d
    takes the bilinear interpolation of the stored PSF at R^-1 d; scaled per channel to the
    stored sum (unless a quarter turn or a sum is not positive)."""
    c, s = cos_sin(angle)
    r = psf.shape[0] // 2
    reach = int(np.floor((r + 1) * (abs(c) + abs(s))))
    d = np.arange(-reach, reach + 1, dtype=np.float64)
    dy, dx = np.meshgrid(d, d, indexing="ij")
    sx, sy = c * dx - s * dy, s * dx + c * dy
    inside = (np.abs(sx) < r + 1) & (np.abs(sy) < r + 1)
    ix, iy = np.floor(sx).astype(int), np.floor(sy).astype(int)
    wx, wy = sx - ix, sy - iy
    padded = np.pad(psf.astype(np.float64), ((1, 2), (1, 2), (0, 0)))  # taps outside the crop are 0

    def tap(x, y):
        x, y = np.clip(x + r + 1, 0, padded.shape[1] - 1), np.clip(y + r + 1, 0, padded.shape[0] - 1)
        return padded[y, x]

    out = (tap(ix, iy) * ((1 - wx) * (1 - wy))[..., None] + tap(ix + 1, iy) * (wx * (1 - wy))[..., None]
           + tap(ix, iy + 1) * ((1 - wx) * wy)[..., None] + tap(ix + 1, iy + 1) * (wx * wy)[..., None])
    out[~inside] = 0.0
    if c != 0 and s != 0:
        stored, turned = psf.sum(axis=(0, 1)), out.sum(axis=(0, 1))
        ok = (stored > 0) & (turned > 0)
        out *= np.where(ok, stored / np.where(ok, turned, 1.0), 1.0)
    return out


def turned_splat_image(db, colour, coords, angle) -> np.ndarray:
    """The Splat baseline with each pixel's dense PSF turned by its angle, cropped to the image."""
    col, oc = _broadcast(db, colour)
    h, w = colour.shape[:2]
    pad = db.rotated_pad
    out = np.zeros((h + 2 * pad, w + 2 * pad, oc))
    cell = cells(db, coords)
    for y in range(h):
        for x in range(w):
            if not np.any(col[y, x]):
                continue
            t = turned_psf(db.dense_psf(cell[y, x]), angle[y, x])
            k = t.shape[0] // 2
            out[y + pad - k:y + pad + k + 1, x + pad - k:x + pad + k + 1] += t * col[y, x]
    return out[pad:pad + h, pad:pad + w]


def turned_filter_image(db, colour, coords, angle) -> np.ndarray:
    """Gather: out(x) = sum_d turned_x(d) in(x - d), in = 0 outside the image."""
    col, oc = _broadcast(db, colour)
    h, w = colour.shape[:2]
    cell = cells(db, coords)
    out = np.zeros((h, w, oc))
    big = int(np.ceil((db.dense_radius.max() + 1) * np.sqrt(2)))
    padded = np.zeros((h + 2 * big, w + 2 * big, oc))
    padded[big:big + h, big:big + w] = col
    for y in range(h):
        for x in range(w):
            t = turned_psf(db.dense_psf(cell[y, x]), angle[y, x])
            k = t.shape[0] // 2
            window = padded[y + big - k:y + big + k + 1, x + big - k:x + big + k + 1]
            out[y, x] = np.sum(t * window[::-1, ::-1], axis=(0, 1))
    return out


def turned_spreadlet_canvas(db, colour, coords, angle, shape, bilinear=True, pad=None) -> np.ndarray:
    """The Laplacian canvas (``pad``, default the rotated padding) of the non-fast-tracked pixels,
    spreadlets turned."""
    col, oc = _broadcast(db, colour)
    h, w = colour.shape[:2]
    pad = db.rotated_pad if pad is None else pad
    lap = np.zeros(shape + (oc,))
    cell = cells(db, coords)
    for y in range(h):
        for x in range(w):
            i = cell[y, x]
            if not np.any(col[y, x]) or db.fast_track[i]:
                continue
            p, v = db.spreadlets(i)
            c, s = cos_sin(angle[y, x])
            fx = c * p[:, 0] + s * p[:, 1]
            fy = c * p[:, 1] - s * p[:, 0]
            vals = v.astype(np.float64) * col[y, x]
            if bilinear and c != 0 and s != 0:
                ix, iy = np.floor(fx).astype(int), np.floor(fy).astype(int)
                wx, wy = fx - ix, fy - iy
                for ox, oy, wt in ((0, 0, (1 - wx) * (1 - wy)), (1, 0, wx * (1 - wy)), (0, 1, (1 - wx) * wy),
                                   (1, 1, wx * wy)):
                    np.add.at(lap, (y + pad + iy + oy, x + pad + ix + ox), vals * wt[:, None])
            else:
                np.add.at(lap, (y + pad + np.rint(fy).astype(int), x + pad + np.rint(fx).astype(int)), vals)
    return lap

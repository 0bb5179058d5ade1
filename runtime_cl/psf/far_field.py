"""The far field of a volume database: every pixel's halo beyond its PSF window, coarse, by FFT.

A ``volume`` database holds each point light's PSF at full resolution inside its window (255 px
by default); in fog the halo reaches much farther (across a 1024^2 frame). A ``volume_far``
database (``lab.psf_tracing.models.volume_far``) holds the rest of it, binned in PSF pixels of
``pixel_scale`` x ``pixel_scale`` image pixels, with the volume window left out; the two add up.

Here the far field of a whole frame is

    far(B') = sum_k sum_B C_k(B) F_k(B' - B) / s^2,

B, B' blocks of s x s image pixels, F_k the far PSF of sample k (flux per PSF pixel), and C_k(B)
the block's summed colour, each pixel's colour shared between the two samples whose distances
bracket its own (linear interpolation in distance: the halo changes slowly with it). Every sum
over B is a convolution, so: one forward FFT per sample with pixels, the products summed in the
frequency domain, one inverse FFT, then a bilinear upsampling from block centres to pixels. A
pixel is placed at its block's centre: at most s/2 px off, against a halo that varies over tens
of pixels.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from runtime_cl.coords.lens import light_distance
from runtime_cl.errors import InputError
from runtime_cl.psf.database import SpreadletDatabase

try:  # pocketfft on all cores, as runtime_cl.integrate.poisson; the runtime needs only numpy
    import scipy.fft as _fft

    _WORKERS = {"workers": -1}
    _fast_len = _fft.next_fast_len
except ImportError:
    _fft = np.fft
    _WORKERS = {}

    def _fast_len(n: int, real: bool = True) -> int:
        return n

MODEL = "volume_far"


class Prepared(NamedTuple):
    """:meth:`FarField.prepare`'s per-pixel samples: ``k0``, ``k1`` (indices into the sorted
    distances), ``f`` (the weight of ``k1``), ``blocks`` (rows, columns of blocks) and ``bins``:
    for each of the two samples, every pixel's index into the (sample, block) sums and its weight."""

    k0: np.ndarray
    k1: np.ndarray
    f: np.ndarray
    blocks: tuple
    bins: tuple


def sample_distances(db: SpreadletDatabase) -> np.ndarray:
    """Each cell's distance (m): the centre of its box in grid units (the box it was traced over)."""
    grid = db.grid
    g = (np.arange(grid.n * 64) + 0.5) / 64.0
    cell = grid.index_of_grid(g[:, None])
    centre = np.bincount(cell, weights=g, minlength=grid.size) / np.maximum(np.bincount(cell, minlength=grid.size), 1)
    return grid.from_grid(centre[:, None])[:, 0]


def check_pair(near: SpreadletDatabase, far: SpreadletDatabase) -> None:
    """InputError unless ``far`` completes ``near``: a ``volume`` database traced for the same
    medium and camera (fingerprint) over the same distances, whose kept window (psf_resolution
    // 2 less the tracer's 2 px margin) is the far field's hole."""
    if near.model != "volume":
        raise InputError(f"far_field: completes a 'volume' database, not {near.model!r}")
    same = near.params.get("fingerprint") == far.params.get("fingerprint") and \
        tuple(near.grid.ranges) == tuple(far.grid.ranges)
    hole = far.params.get("config", {}).get("hole_half_px")
    kept = near.psf_resolution // 2 - 2
    if not same or hole != kept:
        raise InputError(f"far_field: the volume_far database (hole {hole} px, distances {far.grid.ranges[0]}, "
                         f"{far.params.get('fingerprint')}) does not complete the volume database (window "
                         f"+-{kept} px, distances {near.grid.ranges[0]}, {near.params.get('fingerprint')}); "
                         "precompute both from the same scene")


class FarField:
    """Adds a ``volume_far`` database's halos to a frame rendered with its ``volume`` database.

    Parameters
    ----------
    db : SpreadletDatabase
        A ``volume_far`` database (its dense PSFs are the far field).
    near : SpreadletDatabase, optional
        The ``volume`` database it completes: it must have been traced for the same medium,
        camera and distances, and its window must be the far field's hole.
    """

    def __init__(self, db: SpreadletDatabase, near: SpreadletDatabase | None = None):
        if db.model != MODEL:
            raise InputError(f"far field database: model {db.model!r}, need a {MODEL!r} database "
                             "(splatlab precompute of the scene's volume_far model)")
        if near is not None:
            check_pair(near, db)
        self.db = db
        self.scale = int(db.params.get("config", {}).get("pixel_scale", 0))
        if self.scale < 2:
            raise InputError(f"far field database {db.path or ''}: no pixel_scale >= 2 in its config; rebuild it")
        distance = sample_distances(db)
        self.order = np.argsort(distance)
        self.distance = distance[self.order]
        self._spectra: dict = {}

    def prepare(self, camera, depth) -> "Prepared":
        """Per pixel: its two samples and their weights (linear in distance, clamped at the ends),
        and where each lands in the per-sample block sums (not timed: the frame's geometry)."""
        d = light_distance(camera, depth)
        h, w = d.shape
        n_k = len(self.distance)
        x = np.interp(d, self.distance, np.arange(n_k))
        k0 = np.minimum(np.floor(x).astype(np.int64), n_k - 1)
        k1 = np.minimum(k0 + 1, n_k - 1)
        f = (x - k0).astype(np.float32)
        s = self.scale
        hc, wc = -(-h // s), -(-w // s)
        block = ((np.arange(h) // s)[:, None] * wc + (np.arange(w) // s)[None, :]).ravel()
        bins = tuple((k.ravel() * (hc * wc) + block, weight.ravel()) for k, weight in ((k0, 1.0 - f), (k1, f)))
        return Prepared(k0, k1, f, (hc, wc), bins)

    def _psf_spectra(self, shape: tuple) -> np.ndarray:
        """(K, fy, fx, C) complex: the rfft2 of every sample's far PSF, centred at (0, 0), on ``shape``."""
        if shape not in self._spectra:
            spectra = []
            for i in self.order:
                psf = self.db.dense_psf(int(i)).astype(np.float32)  # (2r+1, 2r+1, C), centre at r
                r = psf.shape[0] // 2
                canvas = np.zeros(shape + psf.shape[2:], np.float32)
                canvas[:2 * r + 1, :2 * r + 1] = psf
                canvas = np.roll(canvas, (-r, -r), axis=(0, 1))
                spectra.append(_fft.rfft2(canvas, axes=(0, 1), **_WORKERS))
            self._spectra = {shape: np.stack(spectra)}
        return self._spectra[shape]

    def render(self, rgb, prepared) -> np.ndarray:
        """(H, W, C) float32: the far field of colours ``rgb`` (H, W, CC) given :meth:`prepare`'s."""
        rgb = np.asarray(rgb, np.float32)
        h, w = rgb.shape[:2]
        s = self.scale
        hc, wc = prepared.blocks
        r = max(int(self.db.dense_radius.max()), 0)
        shape = (_fast_len(hc + 2 * r, True), _fast_len(wc + 2 * r, True))
        n_k = len(self.distance)
        channels = max(rgb.shape[2], self.db.channels)
        colour = np.broadcast_to(rgb, (h, w, channels)).reshape(-1, channels)
        summed = np.zeros((n_k, hc, wc, channels), np.float32)
        for index, weight in prepared.bins:
            for c in range(channels):
                summed[..., c] += np.bincount(index, colour[:, c] * weight, minlength=n_k * hc * wc).reshape(n_k, hc, wc)
        used = np.flatnonzero(summed.reshape(n_k, -1).any(axis=1))
        spectra = self._psf_spectra(shape)
        total = None
        for k in used:
            term = _fft.rfft2(summed[k], s=shape, axes=(0, 1), **_WORKERS) * spectra[k]
            total = term if total is None else total + term
        if total is None:
            return np.zeros((h, w, channels), np.float32)
        coarse = _fft.irfft2(total, s=shape, axes=(0, 1), **_WORKERS)
        # circular wrap: offsets up to +-r blocks land within the padded canvas, negatives at its end
        coarse = coarse[:hc, :wc] / float(s * s)
        return _upsample(coarse.astype(np.float32), h, w, s)


def _upsample(coarse: np.ndarray, h: int, w: int, s: int) -> np.ndarray:
    """Bilinear from block centres to pixel centres (blocks of s x s pixels; clamped at the edges)."""
    def axis(n, blocks):
        u = np.clip((np.arange(n) + 0.5) / s - 0.5, 0.0, blocks - 1)
        i0 = np.floor(u).astype(np.int64)
        i1 = np.minimum(i0 + 1, blocks - 1)
        return i0, i1, (u - i0).astype(np.float32)

    y0, y1, fy = axis(h, coarse.shape[0])
    x0, x1, fx = axis(w, coarse.shape[1])
    rows = coarse[y0] * (1.0 - fy)[:, None, None] + coarse[y1] * fy[:, None, None]
    return rows[:, x0] * (1.0 - fx)[None, :, None] + rows[:, x1] * fx[None, :, None]

"""Apertures given as transmittance images: a user's PNG (``image``); the built-in ``star`` and
``heart`` (:mod:`lab.optics.aperture.builtin`) are images too.

A pixel's transmittance is its luminance times its alpha (white and opaque = open, black or
transparent = blocked), so rays pass through a pixel in proportion to its value: grey pixels
dim the bokeh. Two exact samplers of the image's piecewise-constant density:

- :meth:`ImageAperture.sample` (two uniform numbers, the :class:`Aperture` contract) inverts it
  like pbrt's ``PiecewiseConstant2D``: a binary search over the cumulative row masses picks the
  row, one over that row's cumulative pixel masses the column, and the leftover fractions place
  the point inside the pixel. About 2 log2(side) dependent gathers per point.
- :meth:`ImageAperture.sample_rng` (what the tracer calls; four PCG32 steps) uses Walker's alias
  table over all pixels: one float64 picks a pixel and, with its leftover fraction, the pixel or
  its alias; two float32 place the point inside. Two gathers per point, several times faster.

Coordinates follow :mod:`lab.optics.aperture.base`: the image centre is the origin, x right, y up
(image rows run down), scaled so the farthest corner of a non-zero pixel lies on the unit circle
(circumradius 1). The image is placed upright: a lens traces it as it does any aperture, so in
the final image the PSF shows it upright behind the focal plane and rotated by 180 degrees in
front of it (see :mod:`lab.optics.thin_lens`).
"""
from __future__ import annotations

import abc
import hashlib
import io
from dataclasses import dataclass
from functools import cached_property, lru_cache

import drjit as dr
import numpy as np
from drjit.llvm import Array2f, Float, Float64, UInt32

from lab.errors import UserError
from runtime_cl.input_file import read_bytes
from lab.optics.aperture.base import Aperture, register_aperture

__all__ = ["ImageAperture", "FileImageAperture", "MAX_IMAGE_SIDE", "load_transmittance"]

MAX_IMAGE_SIDE = 4096  # larger images cost memory and add nothing a PSF of <= 1000 px can show


def _check_grey(img, path: str) -> None:
    """UserError if a colour image has colour: an aperture is one transmittance for every
    wavelength (grey saved as RGB passes)."""
    if img.mode in ("1", "L", "LA", "La", "I", "I;16", "F") or img.mode.startswith("I;"):
        return
    rgb = np.asarray(img.convert("RGB"), dtype=np.int16)
    coloured = int(np.count_nonzero(np.ptp(rgb, axis=-1) > 1))
    if coloured:
        raise UserError(f"aperture_image = {path!r} has colour ({coloured} pixel(s) whose R, G, B differ); an "
                        "aperture is one transmittance for every colour: save it as a grayscale PNG")


def load_transmittance(path: str) -> tuple[np.ndarray, str]:
    """Read a PNG (or any image Pillow reads) as transmittance: (H, W) float64 in [0, 1], sha256.

    Raises UserError naming the path and the fix if the file is missing, unreadable, too large,
    coloured or entirely dark.
    """
    from PIL import Image, UnidentifiedImageError

    data = read_bytes(path, "aperture_image", "give the path of a PNG whose bright pixels are the open aperture")
    try:
        with Image.open(io.BytesIO(data)) as img:
            if max(img.size) > MAX_IMAGE_SIDE:
                raise UserError(f"aperture_image = {path!r} is {img.size[0]} x {img.size[1]} pixels; "
                                f"at most {MAX_IMAGE_SIDE} per side: scale it down")
            img.load()
            _check_grey(img, path)
            if img.mode in ("P", "PA", "LA", "RGBA", "La", "RGBa") or "transparency" in img.info:
                rgba = img.convert("RGBA")
                alpha = np.asarray(rgba.getchannel("A"), dtype=np.float64) / 255.0
                lum = np.asarray(rgba.convert("RGB").convert("F"), dtype=np.float64) / 255.0
            else:
                alpha = 1.0
                peak = 65535.0 if img.mode.startswith("I") else 255.0
                lum = np.asarray(img.convert("F"), dtype=np.float64) / peak
    except (OSError, UnidentifiedImageError, ValueError, Image.DecompressionBombError) as exc:
        # Pillow names its in-memory stream, not the file, when it knows no format for the bytes
        why = ("an empty file" if not data else "no image format Pillow reads") \
            if isinstance(exc, UnidentifiedImageError) else str(exc)
        raise UserError(f"aperture_image = {path!r} cannot be read ({why}); give the path of a PNG "
                        "whose bright pixels are the open aperture") from None
    w = np.clip(lum * alpha, 0.0, None)
    if not np.any(w > 0):
        raise UserError(f"aperture_image = {path!r} has no open pixel: bright, opaque pixels let light "
                        "through, black or transparent ones block it")
    return w, hashlib.sha256(data).hexdigest()


def _vose(p):
    """Vose's alias table for probabilities ``p`` * n (float64, mean 1): (threshold, alias).

    Pixel i is kept when u < threshold[i], else alias[i] is taken; zero-weight pixels get
    threshold 0, so they are never returned.
    """
    n = p.size
    q = p.copy()
    prob = np.ones(n)
    alias = np.arange(n)
    small = np.empty(n, np.int64)
    large = np.empty(n, np.int64)
    ns = 0
    nl = 0
    for i in range(n):
        if q[i] < 1.0:
            small[ns] = i
            ns += 1
        else:
            large[nl] = i
            nl += 1
    while ns > 0 and nl > 0:
        ns -= 1
        s = small[ns]
        g = large[nl - 1]
        prob[s] = q[s]
        alias[s] = g
        q[g] = q[g] + q[s] - 1.0
        if q[g] < 1.0:
            nl -= 1
            small[ns] = g
            ns += 1
    # leftovers are 1 up to rounding; a zero-weight pixel cannot be one (its deficit is 1), but
    # make sure: never keep a pixel without light
    for i in range(n):
        if p[i] == 0.0:
            prob[i] = 0.0
    return prob, alias


@lru_cache(maxsize=None)
def _alias_builder():
    """:func:`_vose` compiled by numba (imported on first use; cached in NUMBA_CACHE_DIR)."""
    import numba

    return numba.njit(cache=True)(_vose)


class ImageAperture(Aperture):
    """An aperture whose transmittance is an image (subclasses supply :attr:`weights`)."""

    @property
    @abc.abstractmethod
    def weights(self) -> np.ndarray:
        """(H, W) float64 transmittance >= 0, row 0 at the top, not all zero."""

    @cached_property
    def _geometry(self) -> tuple[int, int, float, float]:
        """H, W, circumradius in pixels, peak weight."""
        w = self.weights
        h, wd = w.shape
        rows, cols = np.nonzero(w > 0)
        # farthest corner of a non-zero pixel from the image centre (wd / 2, h / 2)
        dx = np.maximum(np.abs(cols - wd / 2.0), np.abs(cols + 1 - wd / 2.0))
        dy = np.maximum(np.abs(rows - h / 2.0), np.abs(rows + 1 - h / 2.0))
        return h, wd, float(np.sqrt(dx * dx + dy * dy).max()), float(w.max())

    @cached_property
    def _tables(self) -> tuple[Float, Float]:
        """Cumulative row masses (H + 1) and per-row cumulative pixel masses (H x (W + 1)), float32.

        Entries after the last non-zero one are exactly 1, so float rounding can never select an
        empty trailing row or pixel (the searches pick the last index whose CDF <= u).
        """
        w = self.weights
        h, wd = w.shape
        rows = w.sum(axis=1)
        marginal = np.concatenate([[0.0], np.cumsum(rows) / rows.sum()])
        marginal[np.flatnonzero(rows)[-1] + 1:] = 1.0
        cond = np.zeros((h, wd + 1))
        cond[:, 1:] = np.cumsum(w, axis=1) / np.where(rows > 0, rows, 1.0)[:, None]
        last = np.where(rows > 0, wd - 1 - np.argmax(w[:, ::-1] > 0, axis=1), wd - 1)
        cond[np.arange(wd + 1)[None, :] > last[:, None]] = 1.0
        return Float(marginal.astype(np.float32)), Float(cond.astype(np.float32).ravel())

    @cached_property
    def _alias(self) -> tuple[Float, UInt32]:
        """Walker alias table over the flattened image (float32 thresholds, uint32 aliases)."""
        w = self.weights.ravel()
        prob, alias = _alias_builder()(w * (w.size / w.sum()))
        if np.any(w[alias[prob < 1.0]] == 0.0):
            raise AssertionError("alias table points at a blocked pixel")  # cannot happen (Vose)
        return Float(prob.astype(np.float32)), UInt32(alias.astype(np.uint32))

    @property
    def area(self) -> float:
        """Transmittance-weighted area at unit circumradius: sum(w) / max(w) pixel areas."""
        _, _, rc, peak = self._geometry
        return float(self.weights.sum() / peak / (rc * rc))

    def sample(self, u: Array2f) -> Array2f:
        h, wd, rc, _ = self._geometry
        marginal, cond = self._tables
        row = dr.binary_search(1, h, lambda i: dr.gather(Float, marginal, i) <= u.y) - 1
        m0, m1 = dr.gather(Float, marginal, row), dr.gather(Float, marginal, row + 1)
        fy = dr.clip((u.y - m0) / dr.maximum(m1 - m0, 1e-30), 0.0, 1.0)
        base = row * (wd + 1)
        col = dr.binary_search(1, wd, lambda j: dr.gather(Float, cond, base + j) <= u.x) - 1
        c0, c1 = dr.gather(Float, cond, base + col), dr.gather(Float, cond, base + col + 1)
        fx = dr.clip((u.x - c0) / dr.maximum(c1 - c0, 1e-30), 0.0, 1.0)
        x = (Float(col) + fx - 0.5 * wd) * (1.0 / rc)
        y = (0.5 * h - Float(row) - fy) * (1.0 / rc)
        return Array2f(x, y)

    def sample_rng(self, rng) -> Array2f:
        """Alias-table sample with the ray's PCG32: exact, two gathers (see the module docstring)."""
        h, wd, rc, _ = self._geometry
        prob, alias = self._alias
        n = h * wd
        u = rng.next_float64() * n
        i = UInt32(dr.minimum(dr.floor(u), n - 1))
        keep = Float(u - Float64(i)) < dr.gather(Float, prob, i)
        j = dr.select(keep, i, dr.gather(UInt32, alias, i))
        row = j // wd
        col = j - row * wd
        x = (Float(col) + rng.next_float32() - 0.5 * wd) * (1.0 / rc)
        y = (0.5 * h - Float(row) - rng.next_float32()) * (1.0 / rc)
        return Array2f(x, y)

    def weight(self, x, y) -> np.ndarray:
        """numpy transmittance at points (x, y) (unit circumradius), relative to the peak (0..1)."""
        h, wd, rc, peak = self._geometry
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        col = np.floor(x * rc + 0.5 * wd).astype(np.int64)
        row = np.floor(0.5 * h - y * rc).astype(np.int64)
        inside = (col >= 0) & (col < wd) & (row >= 0) & (row < h)
        out = np.zeros(x.shape)
        out[inside] = self.weights[row[inside], col[inside]] / peak
        return out

    def contains(self, x, y) -> np.ndarray:
        return self.weight(x, y) > 0


@register_aperture("image")
@dataclass(frozen=True, eq=False)
class FileImageAperture(ImageAperture):
    """A user's aperture image (PNG), read once when built.

    Parameters
    ----------
    path : str
        The image file (relative to the working directory).
    sha256 : str, optional
        Expected SHA-256 of the file; a different file is an error. The digest read is
        :attr:`digest` (configs record it, so a changed image changes the content hash).
    """

    path: str
    sha256: str | None = None

    def __post_init__(self):
        if not isinstance(self.path, str) or not self.path:
            raise UserError(f"aperture_image = {self.path!r}: give the path of a PNG file")
        w, digest = load_transmittance(self.path)
        if self.sha256 is not None and self.sha256 != digest:
            raise UserError(f"aperture_image = {self.path!r} has SHA-256 {digest}, but "
                            f"aperture_image_sha256 = {self.sha256!r}: the image changed; remove "
                            "aperture_image_sha256 (or set it to the new digest) to use it")
        object.__setattr__(self, "_w", w)
        object.__setattr__(self, "digest", digest)

    @property
    def weights(self) -> np.ndarray:
        return self._w

"""Step 1 of LSR18 section 5.5: the Laplacian of the PSF, its importance and its working box.

The Laplacian is the runtime's own operator (:func:`runtime_cl.integrate.poisson.laplacian5`, the 3x3
filter), evaluated in float64: a float32 PSF is then summed exactly, so constant and linear regions
give exact zeros and never become spreadlet candidates.

The importance that drives dart throwing and Lloyd is ``|Laplacian|`` measured in units of the
PSF's own intensity level, ``level_c = sum f_c^2 / sum f_c`` (the intensity-weighted mean value;
for a disc it is the disc's height). Normalising makes one mass-per-spreadlet setting mean the same
accuracy for a 5 px and a 250 px disc, whose raw Laplacians differ by 2500x. Channels are combined
by their maximum: a rim shared by all channels counts once, a rim of one channel alone still gets
its full density.

The level is taken locally (:func:`local_level`): the PSF's largest value within ``reach`` px,
leaving out peaks narrower than 2 px, where that is below the global level. A PSF made of one part (a disc, a capsule, a logo) has its
largest value near every pixel of its support at or above the level, so nothing changes; a faint
part far from the bright one (the scattering halo around the Volume model's sharp core, 10^-5 of
its height; the flare disc around a lens's sharp focus) is measured in units of its own height
and gets the spreadlets it would get alone. Against the global level it would get almost none:
its Laplacian is 10^-6 .. 10^-8 of the core's, one dart-throwing disk would cover ~100 px, and
collapsing such cells drops the halo's energy (an image's energy is a quarter of its Laplacian's
second moment, ``sum |x|^2 L / 4``, which a collapse over a large cell does not keep).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.ndimage

from runtime_cl.integrate.poisson import fft_friendly, laplacian5

__all__ = ["psf_laplacian", "local_level", "importance", "Box", "working_box", "LEVEL_REACH"]

# px searched for the local level: wider than a pre-filter ramp (about 3 px), so every pixel of a
# ramp (and the Laplacian 1 px beyond it) sees its plateau
LEVEL_REACH = 4


def psf_laplacian(psf: np.ndarray) -> np.ndarray:
    """Laplacian (3x3 / 5-point) of an (R, R, C) PSF in float64, per channel."""
    return laplacian5(np.asarray(psf, dtype=np.float64))


def local_level(psf: np.ndarray, reach: int | np.ndarray = LEVEL_REACH,
                level: np.ndarray | None = None) -> np.ndarray:
    """The PSF's level near each pixel, (R, R, C) float64.

    ``min(level_c, max(max f_c, max g_c))``: the largest value of ``f`` within 1 px and of ``g``
    within the (2 reach + 1)^2 window around the pixel, where ``g`` is ``f`` without the structures
    narrower than 2 px (a grey opening). A one-pixel peak or line thus sets the level of itself and
    its neighbours (its Laplacian's support) but not of the faint halo around it; a plateau and its
    ramps (at least 2 px wide) are unchanged by the opening. Zero where no light is that near.

    Parameters
    ----------
    psf : ndarray, (R, R, C)
        The PSF (non-negative, each channel with a positive sum).
    reach : int or ndarray of int (R, R), default LEVEL_REACH
        Half-width of the window, px, for all pixels or per pixel.
    level : ndarray, (C,), optional
        The global level; default ``sum f_c^2 / sum f_c`` of ``psf``.
    """
    f = np.asarray(psf, dtype=np.float64)
    if level is None:
        level = (f * f).sum(axis=(0, 1)) / f.sum(axis=(0, 1))
    wide = scipy.ndimage.grey_opening(f, size=(2, 2, 1), mode="constant")
    reach = np.asarray(reach)
    near = scipy.ndimage.maximum_filter(f, size=(3, 3, 1), mode="constant")
    for r in np.unique(reach):
        at = slice(None) if reach.ndim == 0 else reach == r
        size = (2 * int(r) + 1, 2 * int(r) + 1, 1)
        near[at] = np.maximum(near, scipy.ndimage.maximum_filter(wide, size=size, mode="constant"))[at]
    return np.minimum(near, level)


def importance(psf: np.ndarray, lap: np.ndarray, floor: np.ndarray | None = None,
               coarse: np.ndarray | None = None,
               reach: int | np.ndarray = LEVEL_REACH) -> np.ndarray:
    """Spreadlet importance, (R, R) float64: max over channels of ``|lap_c| / local level_c``.

    Parameters
    ----------
    psf : ndarray, (R, R, C)
        The dense PSF (non-negative, each channel with a positive sum).
    lap : ndarray, (R, R, C)
        Its Laplacian from :func:`psf_laplacian`.
    floor : ndarray, (R, R, C), optional
        Noise floor subtracted from ``|lap|`` first (soft threshold, see :mod:`.noise`).
    coarse : ndarray, (R, R, C), optional
        |Laplacian| used where ``|lap|`` is below the floor: the below-floor part measured at a
        coarser scale (:func:`lab.sparsify.noise.coarse_laplacian`).
    reach : int or ndarray of int (R, R), default LEVEL_REACH
        Half-width in px of the window of :func:`local_level`; a blurred PSF needs its blur's
        reach added (:attr:`lab.sparsify.noise.Denoised.reach`).

    Returns
    -------
    ndarray, (R, R) float64
        Zero exactly where every channel's Laplacian is zero (or below the floor, with no
        coarse value).
    """
    mag = np.abs(lap) if floor is None else np.maximum(np.abs(lap) - floor, 0.0)
    if coarse is not None:
        mag = np.where(mag > 0, mag, coarse)
    level = local_level(psf, reach)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(mag > 0, mag / level, 0.0).max(axis=2)


@dataclass(frozen=True)
class Box:
    """A canvas window of the PSF image: rows ``y0 .. y0+h``, columns ``x0 .. x0+w``.

    It may reach outside the PSF image; :meth:`crop` pads with zeros there.
    """

    y0: int
    x0: int
    h: int
    w: int

    def crop(self, image: np.ndarray) -> np.ndarray:
        """The box's part of ``image`` (R, R, ...), zero where the box leaves the image."""
        out = np.zeros((self.h, self.w) + image.shape[2:], image.dtype)
        ys, xs = max(self.y0, 0), max(self.x0, 0)
        ye, xe = min(self.y0 + self.h, image.shape[0]), min(self.x0 + self.w, image.shape[1])
        if ye > ys and xe > xs:
            out[ys - self.y0:ye - self.y0, xs - self.x0:xe - self.x0] = image[ys:ye, xs:xe]
        return out


def working_box(psf: np.ndarray, lap: np.ndarray) -> Box:
    """Bounding box of the PSF and its Laplacian plus a margin, with FFT-friendly edges.

    The margin (4 px + 1/16 of the extent) lets the cost see the far field of the spreadlets (a
    dipole-like tail that decays with distance) without solving on the whole PSF image.
    """
    mask = (np.abs(lap) > 0).any(axis=2) | (np.asarray(psf) > 0).any(axis=2)
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if rows.size == 0:
        rows = cols = np.array([psf.shape[0] // 2])
    edges = []
    for idx in (rows, cols):
        lo, hi = int(idx[0]), int(idx[-1]) + 1
        extent = hi - lo
        size = fft_friendly(extent + 2 * (4 + extent // 16))
        edges.append((lo - (size - extent) // 2, size))
    (y0, h), (x0, w) = edges
    return Box(y0, x0, h, w)

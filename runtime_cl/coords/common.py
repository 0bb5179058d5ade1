"""What every per-model coordinate map shares: the registry, the result type and input checks.

A coordinate map turns a camera and labelled pixels into the PSF coordinates of a database's
model and the angle each pixel's PSF is turned by (``Renderer.render(angle=...)``); see
:mod:`runtime_cl.coords.maps`. Angles are radians counter-clockwise from image +x with y up,
the convention of the database's symmetry tags. Out-of-range coordinates are an error that says
how to rebuild the database, never a silent clamp.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, NamedTuple

import numpy as np

from runtime_cl.psf.database import SpreadletDatabase
from runtime_cl.errors import InputError

REBUILD = "rebuild it with `splatlab precompute SCENE`"


class PsfCoords(NamedTuple):
    """A coordinate map's result.

    Attributes
    ----------
    coords : ndarray, float32, (H, W, ns)
        PSF coordinates, inside the database's ranges.
    angle : ndarray, float32, (H, W), or None
        Radians each pixel's stored PSF is turned by, in [-pi, pi); None: the model needs no
        rotation.
    direct : ndarray, float32, (H, W), or None
        The fraction of each pixel's light that reaches its own pixel unscattered, added exactly
        beside the PSFs (which then hold the rest); None: the PSFs hold all of it.
    gain : ndarray, float32, (H, W), or None
        Each pixel's colour is multiplied by this before its PSF is drawn; None: 1.
    receive : ndarray, float32, (H, W), or None
        The drawn PSFs' image is multiplied by this per output pixel (where scattered light can
        arrive at all); None: 1.
    """

    coords: np.ndarray
    angle: np.ndarray | None
    direct: np.ndarray | None = None
    gain: np.ndarray | None = None
    receive: np.ndarray | None = None


@dataclass(frozen=True)
class CoordinateMap:
    """A registered map ``fn(camera, depth, db, motion) -> PsfCoords``; ``motion``: whether it
    needs per-pixel motion vectors; ``attenuates``: whether the model's light loses energy on the
    way (a medium's absorption and out-scatter), so its PSFs, with the ``direct`` term, do not sum to 1."""

    fn: Callable
    motion: bool
    attenuates: bool = False


COORDINATE_MAPS: dict = {}


def register(model: str, motion: bool = False, attenuates: bool = False):
    """Decorator: register a coordinate map for database model ``model`` (see :class:`CoordinateMap`)."""
    def wrap(fn):
        COORDINATE_MAPS[model] = CoordinateMap(fn, motion, attenuates)
        return fn
    return wrap


def expect_space(db: SpreadletDatabase, model: str, names: tuple) -> None:
    """InputError unless ``db`` holds ``model`` with PSF coordinates ``names``."""
    if db.model != model:
        raise InputError(f"database model {db.model!r}: these coordinates need a {model!r} database; {REBUILD}")
    if tuple(db.grid.names) != names:
        raise InputError(f"database {model!r} has PSF coordinates {list(db.grid.names)}, the runtime's {model} "
                         f"coordinate map makes {list(names)}; {REBUILD}")


def check_symmetries(db: SpreadletDatabase, applied: tuple, default: tuple | None = None) -> tuple:
    """The database's recorded symmetry tags (``default`` if it records none), which must be the
    ones this map applies (``applied``, any order)."""
    recorded = db.params.get("symmetries")
    tags = tuple(recorded) if recorded is not None else (default if default is not None else applied)
    if set(tags) != set(applied):
        raise InputError(f"database {db.model!r} records symmetries {list(tags)}, the runtime's coordinate map "
                         f"applies {list(applied)}; {REBUILD}")
    return tags


def as_depth(depth) -> np.ndarray:
    """Camera-space depth Z in metres as float64 (H, W): > 0, ``inf`` allowed."""
    z = np.asarray(depth, dtype=np.float64)
    if z.ndim != 2:
        raise InputError(f"depth: shape {z.shape}, need (H, W)")
    bad = ~(z > 0)  # catches NaN too
    if np.any(bad):
        raise InputError(f"depth Z = {float(z[bad].flat[0])!r} at {int(bad.sum())} pixel(s): depths must be > 0 "
                         "metres (use inf for background at infinity)")
    return z


def as_motion(motion, shape: tuple) -> np.ndarray:
    """Per-pixel motion vectors as float64 (H, W, 2): (X right, Y up) in pixels over the shutter."""
    m = np.asarray(motion, dtype=np.float64)
    if m.shape != shape + (2,):
        raise InputError(f"motion: shape {m.shape}, need {shape + (2,)} (motion.X, motion.Y per pixel)")
    if not np.all(np.isfinite(m)):
        raise InputError(f"motion: {int(np.count_nonzero(~np.isfinite(m)))} value(s) are NaN or infinite; "
                         "give every pixel a finite motion vector in pixels")
    return m


def pixel_offsets(height: int, width: int) -> tuple:
    """(x, y): each pixel centre's offset from the image centre in pixels, x right, y up."""
    y = (height / 2.0 - 0.5 - np.arange(height, dtype=np.float64))[:, None]
    x = (np.arange(width, dtype=np.float64) + 0.5 - width / 2.0)[None, :]
    return np.broadcast_to(x, (height, width)), np.broadcast_to(y, (height, width))


def in_range(name: str, values: np.ndarray, db: SpreadletDatabase, dim: int, unit: str,
             fix: Callable[[float, float], str]) -> np.ndarray:
    """``values`` (float64) as float32 inside the database's range of coordinate ``dim``.

    Raises an InputError naming ``name``, the range, the extremes found and ``fix(smallest,
    largest)`` (how to rebuild) if any value lies outside. float32 rounding that steps just past
    a range end that float64 respected is undone.
    """
    lo, hi = db.grid.ranges[dim]
    out = (values > hi) | (values < lo)
    if np.any(out):
        smallest, largest = float(values.min()), float(values.max())
        raise InputError(f"{name}: {int(np.count_nonzero(out))} pixel(s) outside the database range [{lo}, {hi}] "
                         f"{unit} (largest found {largest:.4g} {unit}, smallest {smallest:.4g} {unit}); "
                         f"{fix(smallest, largest)}")
    top, bottom = np.float32(hi), np.float32(lo)
    # compare in float64: NumPy 2 (NEP 50) would compare a float32 with a Python float in float32
    if float(top) > hi:
        top = np.nextafter(top, np.float32(-np.inf))
    if float(bottom) < lo:
        bottom = np.nextafter(bottom, np.float32(np.inf))
    return np.clip(values.astype(np.float32), bottom, top)


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Radians (float64) reduced to [-pi, pi), as float32."""
    return (np.remainder(angle + math.pi, 2.0 * math.pi) - math.pi).astype(np.float32)


def angle_bin(name: str, angle_deg: np.ndarray, db: SpreadletDatabase) -> tuple:
    """A database whose last PSF coordinate is a binned angle (a motion direction or a pixel's
    azimuth modulo a shaped aperture's turn period; :class:`~runtime_cl.psf.grid.NestedGrid`
    ``bins``): (``angle_deg`` modulo the period as float32 inside its range [lo, lo + period];
    the centre of its bin in degrees). Turning the bin's PSF by the angle minus that centre turns
    it by a multiple of the period (which maps the aperture onto itself) plus the coordinate's
    offset from the centre. The bin is found from the float32 coordinate exactly as
    ``psf/psf_space.cl`` finds it, so a turn always belongs to the PSF drawn."""
    grid = db.grid
    lo, hi = grid.ranges[-1]
    theta = in_range(name, np.remainder(angle_deg - lo, hi - lo) + lo, db, grid.ns - 1, "deg",
                     lambda *_: REBUILD)   # never called: the remainder lies inside
    b = grid.bin_index((theta.astype(np.float64) - lo) / (hi - lo))
    return theta, 0.5 * sum(grid.bin_range(b))

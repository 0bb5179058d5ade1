"""Per-pixel PSF coordinates from camera + labelled pixels, one function per PSF model.

Each model registers a function ``(camera, depth, db) -> coords (H, W, ns) float32`` under its
database model name; :func:`psf_coords` dispatches on ``db.model``. Out-of-range coordinates are
an error that says how to rebuild the database, never a silent clamp.
"""
from __future__ import annotations

import numpy as np

from .database import SpreadletDatabase
from .errors import InputError
from .thin_lens import ThinLens

COORDINATE_MAPS: dict = {}


def register(model: str):
    """Decorator: register a coordinate map for database model ``model``."""
    def wrap(fn):
        COORDINATE_MAPS[model] = fn
        return fn
    return wrap


def psf_coords(camera, depth, db: SpreadletDatabase) -> np.ndarray:
    """PSF coordinates for every pixel, by the database's model (see :data:`COORDINATE_MAPS`)."""
    fn = COORDINATE_MAPS.get(db.model)
    if fn is None:
        raise InputError(f"database model {db.model!r}: the runtime has no coordinate map for it; "
                         f"it knows {sorted(COORDINATE_MAPS)}")
    return fn(camera, depth, db)


@register("simple_lens")
def thin_lens_coords(camera: ThinLens, depth, db: SpreadletDatabase) -> np.ndarray:
    """|CoC radius| in pixels per pixel: the PSF coordinate of a ``simple_lens`` database.

    Parameters
    ----------
    camera : ThinLens
        The thin-lens camera.
    depth : array_like, (H, W)
        Camera-space depth Z in metres (> 0, ``inf`` allowed); the image width W sets the pixel
        scale.
    db : SpreadletDatabase
        A ``simple_lens`` database (one coordinate: CoC radius in pixels).

    Returns
    -------
    ndarray, float32, (H, W, 1)

    Raises
    ------
    InputError
        Bad depths, a database of another model, or CoC radii beyond the database's range.
    """
    if db.model != "simple_lens" or db.grid.ns != 1:
        raise InputError(f"database model {db.model!r} with {db.grid.ns} coordinate(s): the thin-lens "
                         "coordinates need a 'simple_lens' database; rebuild it with `splatlab "
                         "precompute SCENE` for a thin-lens scene")
    z = np.asarray(depth, dtype=np.float64)
    if z.ndim != 2:
        raise InputError(f"depth: shape {z.shape}, need (H, W)")
    r = np.abs(camera.coc_radius_px(z, z.shape[1]))
    lo, hi = db.grid.ranges[0]
    over = r > hi
    if np.any(over) or np.any(r < lo):
        bad = int(np.count_nonzero(over | (r < lo)))
        raise InputError(f"CoC radius: {bad} pixel(s) outside the database range [{lo}, {hi}] px "
                         f"(largest found {float(r.max()):.4g} px, smallest {float(r.min()):.4g} px); "
                         f"rebuild the database with a max CoC of at least {float(np.ceil(r.max()))} px "
                         "(`splatlab precompute SCENE`), or stop the lens down")
    out = r.astype(np.float32)
    # float32 rounding may step just past the range ends that float64 respected
    top = np.float32(hi)
    if top > hi:
        top = np.nextafter(top, np.float32(-np.inf))
    bottom = np.float32(lo)
    if bottom < lo:
        bottom = np.nextafter(bottom, np.float32(np.inf))
    return np.clip(out, bottom, top)[..., None]

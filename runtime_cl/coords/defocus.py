"""Coordinate maps of the thin-lens models: ``simple_lens``, ``stylized`` and ``combined``.

All three index PSFs by |CoC radius| in pixels (:mod:`runtime_cl.camera.thin_lens`) and store the PSFs
of points in front of the focal plane. Symmetry ``coc_sign``: a point behind it (signed CoC > 0)
is drawn with the stored PSF turned by 180 degrees. ``combined`` adds the motion length in
pixels and the symmetry ``motion_direction``: its PSFs are traced for motion along the config's
``motion_direction_deg``, so a pixel moving at angle phi is drawn turned by phi minus that. With a
shaped aperture it adds the motion angle modulo the aperture's turn period instead (symmetry
``motion_angle``, uniform bins): a pixel is drawn turned by phi minus its bin's centre.
"""
from __future__ import annotations

import math

import numpy as np

from runtime_cl.coords.common import (REBUILD, PsfCoords, angle_bin, as_motion, check_symmetries, expect_space,
                                      in_range, register, wrap_angle)
from runtime_cl.psf.database import SpreadletDatabase
from runtime_cl.errors import InputError
from runtime_cl.camera.thin_lens import ThinLens

COC = ("coc_radius_px",)


def _coc(camera: ThinLens, depth, db: SpreadletDatabase) -> tuple:
    """(signed CoC radius in pixels as float64 (H, W), |CoC| as float32 inside dimension 0's range)."""
    z = np.asarray(depth, dtype=np.float64)
    if z.ndim != 2:
        raise InputError(f"depth: shape {z.shape}, need (H, W)")
    coc = camera.coc_radius_px(z, z.shape[1])

    def fix(_, largest):
        return (f"rebuild the database with a max CoC of at least {float(np.ceil(largest))} px "
                "(`splatlab precompute SCENE`), or stop the lens down")

    return coc, in_range("CoC radius", np.abs(coc), db, 0, "px", fix)


def _behind_focus(coc: np.ndarray) -> np.ndarray:
    """The coc_sign turn: pi behind the focal plane (CoC > 0), else 0."""
    return np.where(coc > 0, math.pi, 0.0)


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
    return _coc(camera, depth, db)[1][..., None]


@register("simple_lens")
def simple_lens_coords(camera: ThinLens, depth, db: SpreadletDatabase, motion=None) -> PsfCoords:
    """``simple_lens``: :func:`thin_lens_coords`; the angle turns points behind the focal plane
    by 180 degrees if the database records ``coc_sign`` (non-circular apertures), else None
    (``rotation``: a circle, or a database that records no symmetries). ``motion`` is unused."""
    expect_space(db, "simple_lens", COC)
    tags = list(db.params.get("symmetries", ["rotation"]))
    if tags not in (["rotation"], ["coc_sign"]):
        raise InputError(f"database 'simple_lens' records symmetries {tags}; the runtime knows ['rotation'] "
                         f"(a circular aperture) and ['coc_sign'] (other apertures); {REBUILD}")
    coc, r = _coc(camera, depth, db)
    return PsfCoords(r[..., None], wrap_angle(_behind_focus(coc)) if tags == ["coc_sign"] else None)


@register("stylized")
def stylized_coords(camera: ThinLens, depth, db: SpreadletDatabase, motion=None) -> PsfCoords:
    """``stylized``: |CoC radius| in pixels; the angle turns points behind the focal plane by 180
    degrees (symmetry ``coc_sign``: the stored aperture image is upside down). ``motion`` is unused."""
    expect_space(db, "stylized", COC)
    check_symmetries(db, ("coc_sign",))
    coc, r = _coc(camera, depth, db)
    return PsfCoords(r[..., None], wrap_angle(_behind_focus(coc)))


@register("combined", motion=True)
def combined_coords(camera: ThinLens, depth, db: SpreadletDatabase, motion) -> PsfCoords:
    """``combined``: (|CoC radius| px, motion length px) and the angle of motion.

    Parameters
    ----------
    camera : ThinLens
        The thin-lens camera.
    depth : array_like, (H, W)
        Camera-space depth Z in metres.
    db : SpreadletDatabase
        A ``combined`` database; its config's ``motion_direction_deg`` (default 0) is the
        traced reference direction.
    motion : array_like, (H, W, 2)
        Per pixel, (X, Y): how far the point moves over the shutter in pixels, X right, Y up
        (the labelled image's ``motion.X``, ``motion.Y``).

    Returns
    -------
    PsfCoords
        ``angle`` = atan2(Y, X) - the reference direction, plus pi behind the focal plane
        (``coc_sign``; exact for the capsule, whose motion segment is centred). A still pixel
        (length 0) is turned by the ``coc_sign`` part alone. A shaped aperture's database
        (``motion_angle``) adds the third coordinate and turns by atan2(Y, X) minus its bin's
        centre instead (:func:`~runtime_cl.coords.common.angle_bin`).
    """
    binned = db.grid.bins > 0
    expect_space(db, "combined", COC + ("motion_px",) + (("motion_angle_deg",) if binned else ()))
    check_symmetries(db, ("motion_angle" if binned else "motion_direction", "coc_sign"))
    coc, r = _coc(camera, depth, db)
    m = as_motion(motion, coc.shape)
    length = np.hypot(m[..., 0], m[..., 1])

    def fix(_, largest):
        return f"rebuild the database with max_motion_px of at least {float(np.ceil(largest))}"

    length32 = in_range("motion length", length, db, 1, "px", fix)
    phi = np.arctan2(m[..., 1], m[..., 0])
    if binned:
        theta, centre = angle_bin("motion angle", np.degrees(phi), db)
        return PsfCoords(np.stack([r, length32, theta], axis=-1),
                         wrap_angle(phi - np.radians(centre) + _behind_focus(coc)))
    reference = math.radians(float(db.params.get("config", {}).get("motion_direction_deg", 0.0)))
    return PsfCoords(np.stack([r, length32], axis=-1), wrap_angle(phi - reference + _behind_focus(coc)))


"""Coordinate maps of the models without a thin lens: ``physical_lens`` and ``volume``.

``physical_lens``: (depth in metres, eccentricity in pixels from the image centre), and the
symmetry ``optical_axis``: the lens is rotation symmetric, so only pixels right of the centre
(image +x) are traced and a pixel at azimuth phi is drawn with the stored PSF turned by phi.
``volume``: the light-camera distance in metres; the PSF is rotation invariant.
"""
from __future__ import annotations

import numpy as np

from runtime_cl.coords.common import (PsfCoords, angle_bin, as_depth, check_symmetries, expect_space, in_range,
                                      pixel_offsets, register, wrap_angle)
from runtime_cl.psf.database import SpreadletDatabase
from runtime_cl.errors import InputError

# The traced direction of symmetry optical_axis: image +x (lab.psf_tracing.models.common)
OPTICAL_AXIS_REFERENCE_RAD = 0.0


@register("physical_lens")
def physical_lens_coords(camera, depth, db: SpreadletDatabase, motion=None) -> PsfCoords:
    """``physical_lens``: (depth m, eccentricity px) per pixel and its azimuth about the centre.

    Parameters
    ----------
    camera : object
        Unused: the database holds its lens, focus and sensor.
    depth : array_like, (H, W)
        Camera-space depth Z in metres, i.e. along the optical axis from the entrance pupil
        (the labelled image's pinhole sits there), inside the database's depth range.
    db : SpreadletDatabase
        A ``physical_lens`` database; the image must be as wide as its config's ``width_px``
        (its PSFs and eccentricities are in those pixels).
    motion : unused

    Returns
    -------
    PsfCoords
        ``coords`` (depth, distance of the pixel centre from the image centre, and for a shaped
        stop the azimuth in degrees modulo its period); ``angle`` the pixel's azimuth about the
        image centre (counter-clockwise from image +x, y up).
    """
    binned = db.grid.bins > 0   # a shaped stop: the pixel's azimuth modulo its period (symmetry stop_turn)
    expect_space(db, "physical_lens", ("depth_m", "eccentricity_px") + (("stop_turn_deg",) if binned else ()))
    check_symmetries(db, ("optical_axis", "stop_turn") if binned else ("optical_axis",))
    z = as_depth(depth)
    h, w = z.shape
    traced = db.params.get("config", {}).get("width_px")
    if traced is not None and traced != w:
        raise InputError(f"image width {w} px: the physical_lens database was traced for images {traced} px "
                         f"wide (its PSFs are in those pixels); render a {traced}-pixel-wide image or rebuild "
                         f"the database with width_px = {w}")
    x, y = pixel_offsets(h, w)
    ecc = np.hypot(x, y)
    def depth_fix(lo, hi):
        if not np.isfinite(hi):
            return "give the background a finite depth within the database's range (a lens has no PSF at infinity here)"
        return f"rebuild the database with near_m <= {lo:.4g} and far_m >= {hi:.4g}"

    depth32 = in_range("depth", z, db, 0, "m", depth_fix)
    ecc32 = in_range("eccentricity", ecc, db, 1, "px", lambda _, hi: "rebuild the database with "
                     f"max_eccentricity_px >= {float(np.ceil(hi))}")
    angle = np.arctan2(y, x) - OPTICAL_AXIS_REFERENCE_RAD
    coords = [depth32, ecc32]
    if binned:
        coords.append(angle_bin("stop turn", np.degrees(angle), db)[0])
    return PsfCoords(np.stack(coords, axis=-1), wrap_angle(angle))


@register("volume", attenuates=True)
def volume_coords(camera, depth, db: SpreadletDatabase, motion=None) -> PsfCoords:
    """``volume``: the distance in metres between the camera and the point each pixel sees.

    The pixel's ray leaves the camera's centre of projection with the pinhole input's field of
    view (``camera.focal_px``: a pinhole's, or a thin lens's image distance on its sensor); the
    distance is Z sqrt(1 + (x^2 + y^2) / f_px^2) for a pixel (x, y) pixels from the image
    centre. The PSFs keep the pixel scale of the database's own pinhole (``focal_length_mm``,
    ``width_px``). No angle: symmetry ``rotation``. ``motion`` is unused.
    """
    expect_space(db, "volume", ("distance_m",))
    check_symmetries(db, ("rotation",))
    distance = light_distance(camera, depth)
    coords = in_range("light distance", distance, db, 0, "m", lambda lo, hi: "rebuild the database with "
                      f"min_distance_m <= {lo:.4g} and max_distance_m >= {hi:.4g}")
    return PsfCoords(coords[..., None], None)


def light_distance(camera, depth) -> np.ndarray:
    """(H, W) float64: Z sqrt(1 + (x^2 + y^2) / f_px^2), the distance from the camera's centre of
    projection to the point each pixel sees (``volume`` and its far field)."""
    z = as_depth(depth)
    h, w = z.shape
    f_px = camera.focal_px(w)
    x, y = pixel_offsets(h, w)
    return z * np.sqrt(1.0 + (x * x + y * y) / (f_px * f_px))

"""Per-pixel PSF coordinates and rotation angles from a camera and labelled pixels.

Each database model has a coordinate map ``(camera, depth, db, motion) -> PsfCoords`` (the
coordinates and the angle each pixel's stored PSF is turned by, for the model's symmetries),
registered under the model's name; :func:`psf_coords` dispatches on ``db.model``:

=================  ===========================================  ================================
model              coordinates                                  angle
=================  ===========================================  ================================
``simple_lens``    |CoC| px                                     pi behind focus (non-circular
                                                                aperture: ``coc_sign``), or None
``stylized``       |CoC| px                                     pi behind focus
``combined``       |CoC| px, motion length px                   motion angle - reference
                                                                (+ pi behind focus)
``physical_lens``  depth m, eccentricity px                     azimuth about the image centre
``volume``         light-camera distance m                      None
``volume_box``     camera gap, length in the box, gap behind    None (and the exact unscattered
                   it (m)                                       ``direct``, ``gain``)
=================  ===========================================  ================================

Angles are radians, counter-clockwise from image +x with y up (image rows grow downward), as
``Renderer.render(angle=...)`` takes them; motion vectors are (X right, Y up) in pixels.
Out-of-range coordinates are an error that says how to rebuild the database, never a clamp.
"""
from __future__ import annotations

from runtime_cl.coords import defocus, lens, medium_box  # noqa: F401  (they register the maps)
from runtime_cl.coords.common import COORDINATE_MAPS, PsfCoords
from runtime_cl.coords.defocus import thin_lens_coords
from runtime_cl.psf.database import SpreadletDatabase
from runtime_cl.errors import InputError

__all__ = ["COORDINATE_MAPS", "PsfCoords", "attenuates", "needs_motion", "psf_coords", "thin_lens_coords"]


def _map(model: str):
    entry = COORDINATE_MAPS.get(model)
    if entry is None:
        raise InputError(f"database model {model!r}: the runtime has no coordinate map for it; "
                         f"it knows {sorted(COORDINATE_MAPS)}")
    return entry


def needs_motion(model: str) -> bool:
    """Whether a database of ``model`` needs per-pixel motion vectors (``combined``)."""
    return _map(model).motion


def attenuates(model: str) -> bool:
    """Whether a database of ``model`` carries a medium's energy loss (``volume``, ``volume_box``):
    its render of a white image is not white."""
    return _map(model).attenuates


def psf_coords(camera, depth, db: SpreadletDatabase, motion=None) -> PsfCoords:
    """PSF coordinates and angles for every pixel, by the database's model.

    Parameters
    ----------
    camera : ThinLens
        The camera of the labelled pixels.
    depth : array_like, (H, W)
        Camera-space depth Z in metres.
    db : SpreadletDatabase
        The database to render with.
    motion : array_like, (H, W, 2), optional
        Motion over the shutter in pixels, (X right, Y up); required if :func:`needs_motion`,
        ignored otherwise.

    Returns
    -------
    PsfCoords
        ``coords`` (H, W, ns) float32 and ``angle`` (H, W) float32 radians or None; pass both to
        :meth:`runtime_cl.spreadlets.renderer.Renderer.render`.
    """
    entry = _map(db.model)
    if entry.motion and motion is None:
        raise InputError(f"motion: a {db.model!r} database needs per-pixel motion vectors (motion.X, motion.Y: "
                         "pixels over the shutter, Y up); give the labelled image those channels")
    return entry.fn(camera, depth, db, motion)

"""A stylized aperture in a ``[camera]`` table: ``aperture = { shape = "star" }``.

LSR18's Stylized bokeh: the lens's aperture is a shape - a star, a heart, or any image whose
bright pixels are open (``aperture = { shape = "image", path = "logo.png" }``) - instead of a disc
or a polygonal iris. The thin camera renders it with the ``stylized`` PSF model against a Mitsuba
thin lens sampling the same shape (:mod:`lab.reference.aperture_lens`); both draw it from
:mod:`lab.optics.aperture`, so their bokeh is the same shape, orientation and size (the shape's
circumradius is the aperture radius f / 2N).
"""
from __future__ import annotations

from dataclasses import dataclass

from ..errors import UserError

__all__ = ["SHAPES", "ShapedAperture"]

SHAPES = ("star", "heart", "image")


@dataclass(frozen=True)
class ShapedAperture:
    """``[camera] aperture = { shape = ..., path = ... }``.

    Parameters
    ----------
    shape : {"star", "heart", "image"}
        The built-in pentagram (a tip up) or heart (point down), or an image.
    path : str, optional
        ``"image"`` only (required there): a PNG, bright = open.
    """

    shape: str
    path: str | None = None

    def __post_init__(self):
        if self.shape not in SHAPES:
            raise UserError(f"aperture shape = {self.shape!r}: use one of {list(SHAPES)} (or an iris: "
                            "aperture = {{ blades = 6 }}, or no aperture for a round one)")
        if (self.shape == "image") != (self.path is not None):
            raise UserError(f"aperture shape = {self.shape!r}, path = {self.path!r}: an image aperture needs "
                            "path = 'shape.png', and only it takes a path")
        self.aperture()                                   # an unreadable image is an error now

    def aperture(self):
        """The shape's sampler (:mod:`lab.optics.aperture`)."""
        from ..optics.aperture import make_aperture

        return make_aperture(self.shape, **({"path": self.path} if self.path else {}))

    def model_keys(self) -> dict:
        """The ``aperture*`` keys of a PSF model's configuration for this shape."""
        return {"aperture": self.shape, **({"aperture_image": self.path} if self.path else {})}

    def to_json(self) -> dict:
        """The header's ``aperture``: the shape, and an image's SHA-256 (what a database's
        fingerprint records, :meth:`lab.psf_tracing.models.common.ApertureKeys.header_aperture`)."""
        digest = getattr(self.aperture(), "digest", None)
        return {"shape": self.shape, **({"sha256": digest} if digest else {})}

    def sensor_params(self) -> dict:
        """The parameters of :mod:`lab.reference.aperture_lens`'s sensor."""
        return {"aperture": self.shape, **({"path": self.path} if self.path else {})}

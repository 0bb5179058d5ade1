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

__all__ = ["SHAPES", "ApertureTable", "ShapedAperture"]

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


class ApertureTable:
    """What a lens camera with an ``aperture`` key (thin or thick) makes of it: a polygonal iris
    ``{ blades = 6, rotation_deg = 0, rounding = 0 }``, a stylized shape ``{ shape = "star" }``, or
    None for the round aperture."""

    def iris(self):
        """The polygonal iris (:class:`lab.optics.iris.Iris`), ``None`` for a round or stylized aperture."""
        from ..config import from_table
        from ..optics.iris import Iris

        if self.aperture is not None and not isinstance(self.aperture, dict):
            raise UserError(f"aperture = {self.aperture!r}: write the iris as a table, e.g. aperture = "
                            "{ blades = 6, rotation_deg = 0 }, a shape as { shape = \"star\" }, or remove "
                            "it for a round aperture")
        if self.aperture is None or "shape" in self.aperture:
            return None
        return from_table(Iris, self.aperture, "aperture")

    def shaped(self) -> ShapedAperture | None:
        """The stylized aperture (``aperture = { shape = ... }``), ``None`` otherwise."""
        from ..config import from_table

        if not isinstance(self.aperture, dict) or "shape" not in self.aperture:
            return None
        return from_table(ShapedAperture, self.aperture, "aperture")

    def aperture_text(self) -> str:
        """The aperture as the plan states it."""
        iris, shaped = self.iris(), self.shaped()
        if iris is not None:
            return f"polygon ({iris.blades} blades, rotation {iris.rotation_deg:g} deg, rounding {iris.rounding:g})"
        return "circle" if shaped is None else f"{shaped.shape} (stylized)"

    def aperture_keys(self) -> dict:
        """The ``aperture*`` keys of a PSF model's configuration for this aperture."""
        iris, shaped = self.iris(), self.shaped()
        if iris is not None:
            return {"aperture": "polygon", "aperture_blades": iris.blades,
                    "aperture_rotation_deg": float(iris.rotation_deg), "aperture_rounding": float(iris.rounding)}
        return {"aperture": "circle"} if shaped is None else shaped.model_keys()

    def aperture_params(self) -> dict | None:
        """The aperture as the reference sensors and the stochastic input sample it: ``{"aperture":
        registered shape name, **its parameters}`` (:func:`lab.optics.aperture.make_aperture`);
        None for the round aperture."""
        iris, shaped = self.iris(), self.shaped()
        if shaped is not None:
            return shaped.sensor_params()
        if iris is not None:
            return {"aperture": "polygon", "blades": iris.blades, "rotation_deg": iris.rotation_deg,
                    "rounding": iris.rounding}
        return None

    def header_aperture(self) -> dict:
        """``{"aperture": ...}`` for the ``splatlab.camera`` header (empty for the round aperture)."""
        shape = self.iris() or self.shaped()
        return {} if shape is None else {"aperture": shape.to_json()}

    @staticmethod
    def check_header_aperture(data: dict, source: str) -> None:
        """A header's ``"aperture"`` (which the runtime cameras pass on unchecked): an iris or a shape."""
        from ..config import from_table
        from ..optics.iris import Iris

        aperture = data.get("aperture")
        if isinstance(aperture, dict) and "shape" in aperture:
            if aperture.get("shape") not in SHAPES or set(aperture) - {"shape", "sha256"}:
                raise UserError(f"{source} aperture = {aperture!r}: a stylized aperture is "
                                "{\"shape\": \"star\" | \"heart\" | \"image\"} (an image with its \"sha256\")")
        elif "aperture" in data:
            from_table(Iris, data["aperture"], f"{source} aperture")

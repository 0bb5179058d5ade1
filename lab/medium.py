"""A scene's participating medium: ``[medium]``, a homogeneous fog filling the scene or a box.

LSR18's Volume effect: light from the scene's emitters scatters on its way to the camera
(Henyey-Greenstein phase), and what arrives is attenuated by the extinction along the view ray.
The plan turns it into the ``volume`` PSF model (:mod:`lab.psf_tracing.models.volume`, the same
``sigma_t``, albedo and ``g``) and a Mitsuba ``volpath`` reference through the same medium
(:mod:`lab.reference.mitsuba_scene`); the labelled-pixel input is rendered without it, since the
runtime adds the medium.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .config import from_table
from .errors import UserError
from .medium_box import MediumBox, camera_frame

__all__ = ["Medium"]


@dataclass(frozen=True)
class Medium:
    """``[medium]``: a homogeneous medium filling the scene.

    Parameters
    ----------
    sigma_t : float
        Extinction coefficient per metre (> 0): a fraction exp(-sigma_t d) crosses d metres.
    albedo : (float, float, float), default (1, 1, 1)
        Single-scattering albedo per colour channel, each in [0, 1] (0: absorbing smoke).
    g : float, default 0
        Henyey-Greenstein anisotropy, in (-1, 1) (> 0 forward, as in fog).
    box : MediumBox or table, optional
        ``{ center = [x, y, z], size = [sx, sy, sz] }`` (metres, world axes): the medium fills this
        box only; without it, the whole scene.
    """

    sigma_t: float
    albedo: tuple[float, float, float] = (1.0, 1.0, 1.0)
    g: float = 0.0
    box: MediumBox | None = None

    def __post_init__(self):
        if isinstance(self.box, dict):
            object.__setattr__(self, "box", from_table(MediumBox, self.box, "box"))
        elif self.box is not None and not isinstance(self.box, MediumBox):
            raise UserError(f"box = {self.box!r} must be a table: box = {{ center = [x, y, z], size = [sx, sy, sz] }}")
        if isinstance(self.albedo, list):
            object.__setattr__(self, "albedo", tuple(float(a) for a in self.albedo))
        if not (isinstance(self.sigma_t, (int, float)) and math.isfinite(self.sigma_t) and self.sigma_t > 0):
            raise UserError(f"sigma_t = {self.sigma_t!r}: the extinction must be a finite number > 0 per "
                            "metre (remove [medium] for clear air)")
        if len(self.albedo) != 3 or not all(isinstance(a, (int, float)) and 0.0 <= a <= 1.0 for a in self.albedo):
            raise UserError(f"albedo = {list(self.albedo)!r}: give three numbers in [0, 1] (R, G, B)")
        if not (isinstance(self.g, (int, float)) and -1.0 < self.g < 1.0):
            raise UserError(f"g = {self.g!r}: the Henyey-Greenstein anisotropy must lie in (-1, 1)")

    def describe(self) -> str:
        where = "filling the scene" if self.box is None else self.box.describe()
        return f"homogeneous (sigma_t {self.sigma_t:g} /m, albedo {list(self.albedo)}, g {self.g:g}), {where}"

    @property
    def psf_model(self) -> str:
        """The PSF model of this medium's geometry: ``volume`` (filling) or ``volume_box``."""
        return "volume" if self.box is None else "volume_box"

    def header_json(self, camera) -> dict:
        """The labelled input header's ``"medium"``: the fog the runtime must add (the input is
        rendered without it), matched against a volume database's fingerprint; a box in the frame
        of ``camera`` (:func:`lab.medium_box.camera_frame`)."""
        out = {"sigma_t": float(self.sigma_t), "albedo": [float(a) for a in self.albedo], "g": float(self.g)}
        if self.box is not None:
            out["box"] = camera_frame(self.box, camera)
        return out

    def model_keys(self) -> dict:
        """The ``volume`` PSF model's keys for this medium."""
        return {"medium_density": float(self.sigma_t), "albedo": tuple(self.albedo), "g": float(self.g)}

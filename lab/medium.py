"""A scene's participating medium: ``[medium]``, a homogeneous fog filling the scene.

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

from .errors import UserError

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
    """

    sigma_t: float
    albedo: tuple[float, float, float] = (1.0, 1.0, 1.0)
    g: float = 0.0

    def __post_init__(self):
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
        return (f"homogeneous (sigma_t {self.sigma_t:g} /m, albedo {list(self.albedo)}, g {self.g:g}), "
                "filling the scene")

    def header_json(self) -> dict:
        """The labelled input header's ``"medium"``: the fog the runtime must add (the input is
        rendered without it), matched against a volume database's fingerprint."""
        return {"sigma_t": float(self.sigma_t), "albedo": [float(a) for a in self.albedo], "g": float(self.g)}

    def model_keys(self) -> dict:
        """The ``volume`` PSF model's keys for this medium."""
        return {"medium_density": float(self.sigma_t), "albedo": tuple(self.albedo), "g": float(self.g)}

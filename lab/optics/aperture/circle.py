"""The ``circle`` aperture: a fully open iris."""
from __future__ import annotations

import math
from dataclasses import dataclass

import drjit as dr
import numpy as np
from drjit.llvm import Array2f

from lab.optics.aperture.base import Aperture, register_aperture

__all__ = ["CircleAperture"]


@register_aperture("circle")
@dataclass(frozen=True)
class CircleAperture(Aperture):
    """The unit disc (a fully open iris)."""

    def sample(self, u: Array2f) -> Array2f:
        # Polar map: r = sqrt(u0) makes the density uniform in area; exact, no rejection.
        r = dr.sqrt(u.x)
        s, c = dr.sincos(2.0 * math.pi * u.y)
        return Array2f(r * c, r * s)

    @property
    def area(self) -> float:
        return math.pi

    @property
    def turn_period_deg(self) -> float:
        return 0.0

    def contains(self, x, y) -> np.ndarray:
        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        return x * x + y * y <= 1.0

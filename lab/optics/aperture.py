"""Aperture shapes as pluggable samplers, registered by name (Dr.Jit).

An aperture maps two uniform numbers u in [0, 1)^2 to a point distributed uniformly over its
shape, in units of the shape's circumradius (the circle has radius 1; a polygon with blades will
have its corners on the unit circle). Lenses scale the point by their aperture (or stop) radius,
so the same sampler serves the thin lens and, later, the stop surface of a thick lens.
Coordinates are lens-plane (x right, y up) as seen from the object side, looking along the axis.

Each shape also answers ``contains`` in numpy, the indicator that analytic references and
statistical tests integrate against.
"""
from __future__ import annotations

import abc
import math
from dataclasses import dataclass
from typing import ClassVar

import drjit as dr
import numpy as np
from drjit.llvm import Array2f

from lab.errors import UserError
from lab.registry import Registry

__all__ = ["Aperture", "CircleAperture", "register_aperture", "get_aperture", "aperture_names",
           "make_aperture"]

_APERTURES = Registry("aperture")
register_aperture = _APERTURES.register
aperture_names = _APERTURES.names
get_aperture = _APERTURES.get


def make_aperture(name: str, **params) -> "Aperture":
    """Build the aperture ``name`` with its shape parameters (none for ``"circle"``)."""
    cls = get_aperture(name)
    try:
        return cls(**params)
    except TypeError as exc:
        raise UserError(f"aperture {name!r}: bad parameters {sorted(params)}: {exc}") from None


class Aperture(abc.ABC):
    """A shape in the lens plane, circumradius 1, sampled uniformly by area."""

    name: ClassVar[str]

    @abc.abstractmethod
    def sample(self, u: Array2f) -> Array2f:
        """Map uniform ``u`` in [0, 1)^2 to a uniform point of the shape (unit circumradius)."""

    @property
    @abc.abstractmethod
    def area(self) -> float:
        """Area of the shape at unit circumradius."""

    @abc.abstractmethod
    def contains(self, x, y) -> np.ndarray:
        """numpy indicator of the closed shape at points (x, y) (unit circumradius)."""


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

    def contains(self, x, y) -> np.ndarray:
        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        return x * x + y * y <= 1.0

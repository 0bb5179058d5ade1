"""The aperture registry and the contract every shape fulfils (Dr.Jit).

An aperture maps two uniform numbers u in [0, 1)^2 to a point distributed uniformly over its
shape, in units of the shape's circumradius (the circle has radius 1; a polygon with blades will
have its corners on the unit circle). Lenses scale the point by their aperture (or stop) radius,
so the same sampler serves the thin lens and, later, the stop surface of a thick lens.
Coordinates are lens-plane (x right, y up) as seen from the object side, looking along the axis.

Each shape also answers ``contains`` in numpy, the indicator that analytic references and
statistical tests integrate against.

Each shape module subclasses :class:`Aperture` and registers it with :func:`register_aperture`
when imported; the package (:mod:`lab.optics.aperture`) imports them all.
"""
from __future__ import annotations

import abc
from typing import ClassVar

import numpy as np
from drjit.llvm import Array2f

from lab.errors import UserError
from runtime_cl.registry import Registry

__all__ = ["Aperture", "register_aperture", "get_aperture", "aperture_names", "make_aperture"]

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

    def sample_rng(self, rng) -> Array2f:
        """A point drawn with the ray's PCG32 ``rng``: what a tracer calls per ray.

        By default :meth:`sample` of two ``next_float32`` draws; shapes with a faster sampler
        that needs more random numbers (image apertures: an alias table) override it.
        """
        return self.sample(Array2f(rng.next_float32(), rng.next_float32()))

    @property
    @abc.abstractmethod
    def area(self) -> float:
        """Area of the shape at unit circumradius."""

    @property
    def turn_period_deg(self) -> float:
        """The smallest turn in degrees that maps the shape onto itself: 360 (none) unless the
        shape says otherwise, 0 for the circle (every turn). A moving lens traces motion
        directions modulo it (:mod:`lab.psf_tracing.models.combined`)."""
        return 360.0

    @abc.abstractmethod
    def contains(self, x, y) -> np.ndarray:
        """numpy indicator of the closed shape at points (x, y) (unit circumradius)."""

"""A shaped aperture stop in a thick lens: an iris or a stylized shape instead of the round opening.

The stop row of a :class:`~lab.optics.thick_lens.LensSystem` (radius 0) stays the round opening
of its semi-aperture; a :class:`StopShape` narrows it to a shape of :mod:`lab.optics.aperture`
whose circumradius is that semi-aperture. Lens x, y map to the image's right and up for the
bokeh of a point behind the focal plane (its rays cross before the sensor, which the image
turns back upright), so the shape is given as the thin lens gives it: upright in the image
behind the focal plane, turned by 180 degrees in front of it.

The shape is tested by nearest lookup in a boolean raster of the aperture's ``contains`` over
the circumscribed square (2048^2 cells: a shape 100 px wide on the sensor is off by at most
0.05 px at its edges), the same in numpy and Dr.Jit. A stop can be turned about the axis per ray
(by the ``(cos, sin)`` of the turn), which is how the ``physical_lens`` model traces the stop as a
pixel at another azimuth sees it.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import drjit as dr
import numpy as np
from drjit.llvm import UInt32

from lab.optics.aperture import Aperture

__all__ = ["StopShape", "RASTER"]

RASTER = 2048   # raster cells across the stop's circumscribed square


@dataclass(frozen=True, eq=False)
class StopShape:
    """The aperture ``shape`` (unit circumradius) scaled to ``radius_mm``.

    Attributes
    ----------
    shape : Aperture
    radius_mm : float
        The stop's semi-aperture: the shape's circumradius.
    raster : (RASTER, RASTER) bool
        ``contains`` at the cell centres, row 0 at the top (y = +radius).
    """

    shape: Aperture
    radius_mm: float
    raster: np.ndarray = field(init=False, repr=False)
    _flat: UInt32 = field(init=False, repr=False)      # the raster as Dr.Jit gathers it

    def __post_init__(self):
        c = (np.arange(RASTER) + 0.5) / RASTER * 2.0 - 1.0
        inside = np.asarray(self.shape.contains(c[None, :], -c[:, None]), dtype=bool)
        inside.setflags(write=False)
        object.__setattr__(self, "raster", inside)
        object.__setattr__(self, "_flat", UInt32(inside.ravel().astype(np.uint32)))

    @classmethod
    def from_params(cls, params: dict | None, radius_mm: float) -> "StopShape | None":
        """The shape ``{"aperture": name, **parameters}`` (a camera's ``aperture_params``) at
        ``radius_mm``; None for None (the round stop)."""
        if params is None:
            return None
        from lab.optics.aperture import make_aperture

        rest = {k: v for k, v in params.items() if k != "aperture"}
        return cls(make_aperture(params["aperture"], **rest), float(radius_mm))

    @property
    def turn_period_deg(self) -> float:
        """The shape's rotational symmetry (:attr:`lab.optics.aperture.Aperture.turn_period_deg`)."""
        return self.shape.turn_period_deg

    def inside(self, x, y, turn=None):
        """Whether stop-plane points (x, y) (mm; numpy arrays or Dr.Jit Floats) are open, the stop
        turned counter-clockwise by the angle whose ``(cos, sin)`` is ``turn`` (None: not turned).
        Points outside the circumscribed square are closed."""
        if turn is not None:   # the point in the unturned stop's frame: turned back by -angle
            c, s = turn
            x, y = c * x + s * y, c * y - s * x
        scale = RASTER / (2.0 * self.radius_mm)
        col, row = (x + self.radius_mm) * scale, (self.radius_mm - y) * scale
        ok = (col >= 0) & (col < RASTER) & (row >= 0) & (row < RASTER)
        if isinstance(x, np.ndarray) or np.isscalar(x):
            ci = np.clip(np.floor(col), 0, RASTER - 1).astype(np.int64)
            ri = np.clip(np.floor(row), 0, RASTER - 1).astype(np.int64)
            return ok & self.raster[ri, ci]
        ci = UInt32(dr.clip(col, 0, RASTER - 1))
        ri = UInt32(dr.clip(row, 0, RASTER - 1))
        return ok & (dr.gather(UInt32, self._flat, ri * RASTER + ci, ok) != 0)

    def mask(self, turn=None):
        """``inside`` with the turn bound: a function of (x, y), what :meth:`LensSystem.trace`
        takes as its ``stop_mask``."""
        return lambda x, y: self.inside(x, y, turn)

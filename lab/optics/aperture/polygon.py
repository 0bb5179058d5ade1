"""The ``polygon`` aperture: a regular iris of straight blades with optionally rounded corners."""
from __future__ import annotations

import math
from dataclasses import dataclass

import drjit as dr
import numpy as np
from drjit.llvm import Array2f

from lab.optics.aperture.base import Aperture, register_aperture
from lab.optics.iris import check_iris

__all__ = ["PolygonAperture"]


@register_aperture("polygon")
@dataclass(frozen=True)
class PolygonAperture(Aperture):
    """A regular iris of ``blades`` straight blades, optionally with rounded corners.

    The shape is the Minkowski sum of a regular polygon of circumradius 1 - rounding with a disc
    of radius ``rounding``: straight edges joined by circular fillets. Its corners (the middles of
    the fillets) lie on the unit circle, so the circumradius stays 1 whatever the rounding;
    rounding = 1 is the unit disc.

    Parameters
    ----------
    blades : int, default 6
        Number of blades = corners (>= 3, <= 64).
    rotation_deg : float, default 0
        Counter-clockwise rotation in degrees; at 0 a corner points to +y (up).
    rounding : float, default 0
        Fillet radius in units of the circumradius, in [0, 1]: 0 sharp corners, 1 a circle.
    """

    blades: int = 6
    rotation_deg: float = 0.0
    rounding: float = 0.0

    def __post_init__(self):
        check_iris(self.blades, self.rotation_deg, self.rounding)   # shared with scene cameras

    # Geometry of one wedge, the region between the rays through two neighbouring corners,
    # in a frame whose +x axis is the wedge's edge normal: the inner polygon's triangle
    # (apex at 0, edge at x = apothem, |y| <= half_edge), the edge's fillet rectangle
    # (apothem <= x <= apothem + rounding) and the two half corner sectors of angle pi / blades.
    @property
    def _wedge(self) -> tuple[float, float, float, float]:
        half = math.pi / self.blades
        s = 1.0 - self.rounding  # inner polygon circumradius
        return half, s * math.cos(half), s * math.sin(half), float(self.rounding)

    @property
    def area(self) -> float:
        half, apothem, h, rho = self._wedge
        return self.blades * (apothem * h + 2.0 * h * rho + rho * rho * half)

    @property
    def turn_period_deg(self) -> float:
        return 0.0 if self.rounding == 1.0 else 360.0 / self.blades

    def _wedge_normal_angle(self, k):
        """Angle (radians) of the edge normal of wedge k; corner 0 at rotation + 90 degrees."""
        return math.radians(self.rotation_deg) + math.pi / 2 + (2 * k + 1) * math.pi / self.blades

    def sample(self, u: Array2f) -> Array2f:
        # u.x picks the wedge and then its part (by area) and supplies one coordinate after
        # rescaling; u.y the other. Exact inverse maps, no rejection, so it is uniform by area.
        n = self.blades
        half, apothem, h, rho = self._wedge
        wedge_area = apothem * h + 2.0 * h * rho + rho * rho * half
        p_tri = apothem * h / wedge_area
        p_rect = 2.0 * h * rho / wedge_area
        p_sec = 0.5 * rho * rho * half / wedge_area
        k = dr.minimum(dr.floor(u.x * n), n - 1)
        v = u.x * n - k
        # the four parts in order: triangle, rectangle, upper sector, lower sector
        in_tri = v < p_tri
        in_rect = ~in_tri & (v < p_tri + p_rect)
        upper = ~in_tri & ~in_rect & (v < p_tri + p_rect + p_sec)
        start = dr.select(in_tri, 0.0, dr.select(in_rect, p_tri, dr.select(upper, p_tri + p_rect,
                                                                            p_tri + p_rect + p_sec)))
        width = dr.select(in_tri, p_tri, dr.select(in_rect, p_rect, p_sec))
        w = dr.clip((v - start) / dr.maximum(width, 1e-30), 0.0, 1.0)
        # triangle: density grows like x, so x = apothem sqrt(w)
        t = dr.sqrt(w)
        tri = Array2f(apothem * t, h * t * (2.0 * u.y - 1.0))
        rect = Array2f(apothem + rho * w, h * (2.0 * u.y - 1.0))
        rr = rho * dr.sqrt(w)
        s, c = dr.sincos(half * u.y)
        sign = dr.select(upper, 1.0, -1.0)
        sec = Array2f(apothem + rr * c, sign * (h + rr * s))
        p = dr.select(in_tri, tri, dr.select(in_rect, rect, sec))
        phi = math.radians(self.rotation_deg) + math.pi / 2 + (2.0 * k + 1.0) * half
        sp, cp = dr.sincos(phi)
        return Array2f(cp * p.x - sp * p.y, sp * p.x + cp * p.y)

    def contains(self, x, y) -> np.ndarray:
        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        half, apothem, h, rho = self._wedge
        # rotate every point into its wedge's frame (edge normal along +x)
        theta = np.arctan2(y, x) - self._wedge_normal_angle(0) + half
        k = np.floor(np.mod(theta, 2 * math.pi) / (2 * half))
        phi = self._wedge_normal_angle(k)
        px = np.cos(phi) * x + np.sin(phi) * y
        py = np.abs(-np.sin(phi) * x + np.cos(phi) * y)
        # distance to the inner polygon: 0 inside, to the edge, or to the corner (apothem, h)
        d_edge = px - apothem
        d_corner = np.hypot(px - apothem, py - h)
        d = np.where(px <= apothem, 0.0, np.where(py <= h, d_edge, d_corner))
        return d <= rho + 1e-12

"""A polygonal iris as plain parameters and outline (numpy only, no Dr.Jit).

The iris of :class:`lab.optics.aperture.polygon.PolygonAperture` (which samples it in Dr.Jit) as a
scene camera describes it, ``[camera] aperture = { blades = 6, rotation_deg = 0 }``: the same
parameters, checks and geometry, so scene files, EXR headers and the polygon runtime can use
it without loading Dr.Jit. Lens-plane coordinates: x right, y up, circumradius 1 (corner 0 at
``rotation_deg + 90`` degrees); the PSF of a point behind the focus plane is this shape upright
in the image, in front of it rotated by 180 degrees (:mod:`lab.optics.thin_lens`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from lab.errors import UserError

__all__ = ["Iris", "check_iris"]


def check_iris(blades, rotation_deg, rounding, prefix: str = "aperture_",
               round_hint: str = "use aperture = 'circle' for a round one") -> None:
    """UserError unless the parameters describe an iris; ``prefix`` names the keys in messages,
    ``round_hint`` says how to ask for a round aperture where the keys are written."""
    if isinstance(blades, bool) or not isinstance(blades, (int, np.integer)) or not 3 <= blades <= 64:
        raise UserError(f"{prefix}blades = {blades!r}: a polygonal iris needs an integer from 3 to 64 "
                        f"blades (real lenses have 5 to 9); {round_hint}")
    if isinstance(rounding, bool) or not isinstance(rounding, (int, float)) or not 0.0 <= rounding <= 1.0:
        raise UserError(f"{prefix}rounding = {rounding!r}: must be a number in [0, 1] "
                        "(0 sharp corners, 1 a circle)")
    if isinstance(rotation_deg, bool) or not isinstance(rotation_deg, (int, float)) \
            or not math.isfinite(rotation_deg):
        raise UserError(f"{prefix}rotation_deg = {rotation_deg!r}: must be a finite angle in degrees")


@dataclass(frozen=True)
class Iris:
    """A regular iris of ``blades`` straight blades with optionally rounded corners.

    Parameters
    ----------
    blades : int, default 6
        Corners, 3 to 64.
    rotation_deg : float, default 0
        Counter-clockwise rotation in degrees; at 0 a corner points up.
    rounding : float, default 0
        Corner fillet radius as a fraction of the circumradius, in [0, 1].
    """

    blades: int = 6
    rotation_deg: float = 0.0
    rounding: float = 0.0

    def __post_init__(self):
        check_iris(self.blades, self.rotation_deg, self.rounding, prefix="",
                   round_hint="remove the aperture table for a round one")

    @property
    def point_symmetric(self) -> bool:
        """True when a 180-degree turn maps the iris onto itself (an even number of blades)."""
        return self.blades % 2 == 0

    def outline(self, points_per_corner: int = 8) -> np.ndarray:
        """Counter-clockwise lens-plane vertices (x right, y up) at circumradius 1.

        Sharp corners give the ``blades`` corners; a rounded iris samples each fillet (the arc of
        radius ``rounding`` around the inner polygon's corner) with ``points_per_corner`` points.
        """
        corners = np.radians(self.rotation_deg + 90.0) + 2.0 * np.pi * np.arange(self.blades) / self.blades
        if self.rounding == 0.0:
            return np.stack([np.cos(corners), np.sin(corners)], axis=1)
        half = np.pi / self.blades
        t = np.linspace(-half, half, points_per_corner)
        ang = (corners[:, None] + t[None, :]).ravel()
        inner = np.repeat(corners, points_per_corner)
        r_in = 1.0 - self.rounding
        v = np.stack([r_in * np.cos(inner) + self.rounding * np.cos(ang),
                      r_in * np.sin(inner) + self.rounding * np.sin(ang)], axis=1)
        # Neighbouring fillets meet in one point when the straight edges vanish (rounding = 1).
        return v[np.linalg.norm(v - np.roll(v, 1, axis=0), axis=1) > 1e-12]

    def to_json(self) -> dict:
        return {"blades": int(self.blades), "rotation_deg": float(self.rotation_deg),
                "rounding": float(self.rounding)}

"""A pinhole camera in numpy: the runtime's mirror of the lab's ``model = "pinhole"``.

A pinhole has no aperture, so every point images to a point: the circle of confusion is 0 at
every depth and a pinhole image needs no defocus pass. The header (``"lens": "pinhole"``) only
records the horizontal field of view, which places the pixels, and for a scene in fog the
``"medium"`` the runtime adds (the input is rendered without it).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from runtime_cl.camera.common import depth_m, register_lens
from runtime_cl.errors import InputError
from runtime_cl.json_values import is_number


def _check_fov(value, where: str) -> None:
    if not (is_number(value) and 0 < value < 180):
        raise InputError(f"{where} = {value!r} must be a number of degrees in (0, 180)")


def _vector(v, positive: bool = False) -> bool:
    return isinstance(v, list) and len(v) == 3 and all(is_number(x) and (x > 0 if positive else True) for x in v)


def _check_box(value, where: str) -> None:
    """The medium's optional ``"box"`` in the camera's frame (metres): ``center``, ``axes`` (three
    unit edge directions, rows) and ``half_size`` (> 0)."""
    fix = ('write it as {"center": [x, y, z], "axes": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "half_size": [hx, hy, hz]} '
           "(camera frame: x right, y up, z forward), or leave it out for a medium filling the scene")
    if not (isinstance(value, dict) and set(value) == {"center", "axes", "half_size"} and _vector(value["center"])
            and _vector(value["half_size"], positive=True) and isinstance(value["axes"], list)
            and len(value["axes"]) == 3 and all(_vector(a) for a in value["axes"])):
        raise InputError(f"{where} = {value!r}: {fix}")
    axes = np.asarray(value["axes"], np.float64)
    if not np.allclose(axes @ axes.T, np.eye(3), atol=1e-6):
        raise InputError(f"{where} axes = {value['axes']!r}: the box's edge directions must be orthonormal; {fix}")


def _check_medium(value, where: str) -> None:
    """The header's ``"medium"`` (the fog a volume database adds): sigma_t > 0, albedo in [0, 1]^3,
    g in (-1, 1), and optionally the ``box`` holding it."""
    fix = 'write it as {"sigma_t": 0.25, "albedo": [0.9, 0.9, 0.85], "g": 0.6} (and optionally "box")'
    if not isinstance(value, dict) or not {"sigma_t", "albedo", "g"} <= set(value) <= {"sigma_t", "albedo", "g", "box"}:
        raise InputError(f"{where} = {value!r}: {fix}")
    if "box" in value:
        _check_box(value["box"], f"{where} box")
    num = is_number
    albedo = value["albedo"]
    if not (num(value["sigma_t"]) and value["sigma_t"] > 0 and num(value["g"]) and -1 < value["g"] < 1
            and isinstance(albedo, list) and len(albedo) == 3 and all(num(a) and 0 <= a <= 1 for a in albedo)):
        raise InputError(f"{where} = {value!r}: sigma_t > 0 per metre, albedo three numbers in [0, 1], "
                         f"g in (-1, 1); {fix}")


@register_lens("pinhole")
@dataclass(frozen=True)
class Pinhole:
    """A pinhole camera, units as in the ``splatlab.camera`` header (``"lens": "pinhole"``).

    Parameters
    ----------
    fov_deg : float
        Horizontal field of view in degrees, in (0, 180); the header writes it as ``fov_x_deg``.
    """

    lens: ClassVar[str]
    fov_deg: float

    def __post_init__(self):
        _check_fov(self.fov_deg, "camera fov_deg")

    def fov_x_deg(self) -> float:
        """Horizontal field of view in degrees."""
        return self.fov_deg

    def focal_px(self, width_px: int) -> float:
        """Focal distance in pixels of an image ``width_px`` wide (pixels per unit tangent)."""
        return width_px / (2.0 * math.tan(math.radians(self.fov_deg) / 2.0))

    def coc_radius_px(self, z_m, width_px: int):
        """Zeros shaped like ``z_m`` (metres; checked as :meth:`ThinLens.coc_radius_px` checks it):
        a pinhole has no defocus."""
        return np.zeros_like(depth_m(z_m))

    def to_json(self) -> dict:
        return {"lens": self.lens, "fov_x_deg": self.fov_deg}

    @classmethod
    def from_json(cls, data: dict, source: str = "camera") -> "Pinhole":
        """Build from the ``splatlab.camera`` JSON; ``source`` names where it came from in errors."""
        if data.get("lens") != cls.lens:
            raise InputError(f"{source}: lens = {data.get('lens')!r}, this runtime path needs {cls.lens!r}")
        unknown = sorted(set(data) - {"lens", "fov_x_deg", "shutter", "medium"})
        if unknown:
            raise InputError(f"{source}: unknown key(s) {unknown} for a pinhole; known: fov_x_deg, shutter, medium")
        _check_fov(data.get("fov_x_deg"), f"{source}: fov_x_deg")
        if "medium" in data:
            _check_medium(data["medium"], f"{source}: medium")
        return cls(fov_deg=data["fov_x_deg"])

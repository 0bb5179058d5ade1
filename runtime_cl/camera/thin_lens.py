"""Thin-lens circle of confusion in numpy: the runtime's mirror of ``lab.optics.thin_lens``.

Geometry (Mitsuba's ``thinlens`` sensor uses the same): a lens of focal length f and aperture
radius a = f / (2 N), focused at distance F, images the focus plane onto a sensor at the image
distance v = f F / (F - f). A point at camera-space depth z (along the optical axis) spreads into
a disc whose radius on the sensor is a v |1/F - 1/z|; in pixels of an image W pixels wide on a
sensor ``sensor_width`` wide:

    r(z) = a v W / sensor_width * (1/F - 1/z)

signed: positive behind the focus plane, negative in front. Written with 1/z and 1/F so z = inf
(background at infinity) and F = inf (focus at infinity: v = f, every finite depth in front) are
exact.

A tilted sensor (``sensor_tilt_deg``, Scheimpflug) or an expressive focal surface
(``focal_surface``, LES10 5.2) replaces 1/F by a per-pixel map w_f(p)
(:mod:`runtime_cl.camera.focal_surface`, :meth:`ThinLens.inverse_focus_map`): every pass takes
it from here, and ``coc_radius_px`` then needs the (H, W) depth map.
"""
from __future__ import annotations

import functools
import json
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from runtime_cl.camera.common import depth_m, register_lens
from runtime_cl.camera.focal_surface import check_tilt, expressive_inverse_focus, read_surface, tilt_inverse_focus
from runtime_cl.errors import InputError
from runtime_cl.json_values import is_number


@register_lens("thin")
@dataclass(frozen=True)
class ThinLens:
    """A thin lens camera, units as in the ``splatlab.camera`` header (``"lens": "thin"``).

    Parameters
    ----------
    focal_length_mm : float
        Focal length f in millimetres (> 0).
    f_number : float
        f-number N (> 0); the aperture radius is f / (2 N).
    focus_distance_m : float
        Distance F of the plane in focus, in metres; must exceed the focal length; ``inf``
        focuses at infinity.
    sensor_width_mm : float
        Sensor width in millimetres (> 0); the image width in pixels spans it.
    sensor_tilt_deg : (float, float), default (0, 0)
        Sensor tilt about the image's y and x axes (Scheimpflug; the focal plane tilts).
    focal_surface : str, optional
        An expressive focal surface as canonical JSON (:func:`runtime_cl.camera.focal_surface.read_surface`).
    focus_points : tuple of (int, int), default ()
        The pixels the focus was taken from (column, row from the top): what the header records.
    """

    lens: ClassVar[str]
    focal_length_mm: float
    f_number: float
    focus_distance_m: float
    sensor_width_mm: float = 36.0
    sensor_tilt_deg: tuple = (0.0, 0.0)
    focal_surface: str | None = None
    focus_points: tuple = ()

    def __post_init__(self):
        for name in ("focal_length_mm", "f_number", "focus_distance_m", "sensor_width_mm"):
            value = getattr(self, name)
            infinite_ok = name == "focus_distance_m"      # focus at infinity; NaN fails "> 0"
            if not (is_number(value, finite=not infinite_ok) and value > 0):   # a JSON true is not 1 mm
                raise InputError(f"camera {name} = {value!r}: must be a finite number > 0"
                                 + (" (or inf: focus at infinity)" if infinite_ok else ""))
        if self.focus_distance_m * 1000.0 <= self.focal_length_mm:
            raise InputError(
                f"camera focus_distance_m = {self.focus_distance_m}: a lens of focal length "
                f"{self.focal_length_mm} mm cannot focus closer than its focal length; "
                f"use a focus distance > {self.focal_length_mm / 1000.0} m")
        object.__setattr__(self, "sensor_tilt_deg", check_tilt(self.sensor_tilt_deg))
        if self.focal_surface is not None:
            surface = read_surface(json.loads(self.focal_surface) if isinstance(self.focal_surface, str)
                                   else self.focal_surface)
            object.__setattr__(self, "focal_surface", json.dumps(surface, sort_keys=True))
            if self.tilted:
                raise InputError(f"camera sensor_tilt_deg = {list(self.sensor_tilt_deg)} with a focal_surface: "
                                 "the surface sets the focus of every pixel; remove one of them")
        pts = self.focus_points
        if not (isinstance(pts, (list, tuple)) and all(
                isinstance(p, (list, tuple)) and len(p) == 2 and all(type(v) is int and v >= 0 for v in p)
                for p in pts)):
            raise InputError(f"camera focus_points = {pts!r}: give the focus pixels as [[x, y], ...] (integers >= 0)")
        object.__setattr__(self, "focus_points", tuple(tuple(p) for p in pts))

    @property
    def tilted(self) -> bool:
        return self.sensor_tilt_deg != (0.0, 0.0)

    @property
    def has_focal_map(self) -> bool:
        """True when the focus varies per pixel (a tilt or a focal surface)."""
        return self.tilted or self.focal_surface is not None

    def surface(self) -> dict | None:
        """The expressive focal surface (:func:`runtime_cl.camera.focal_surface.read_surface`), or None."""
        return None if self.focal_surface is None else json.loads(self.focal_surface)

    def inverse_focus_map(self, height: int, width: int) -> np.ndarray:
        """(H, W) float64, read-only: per pixel, 1 / the distance in focus along its chief ray (1/F
        untilted). Made once per lens and size (every pass's CoC asks for it; a focal surface's
        moving least squares costs a small solve per pixel)."""
        return _inverse_focus_map(self, int(height), int(width))

    @property
    def aperture_radius_m(self) -> float:
        return self.focal_length_mm / 2000.0 / self.f_number

    @property
    def image_distance_m(self) -> float:
        f = self.focal_length_mm / 1000.0
        if math.isinf(self.focus_distance_m):                # focused at infinity: the focal plane
            return f
        return f * self.focus_distance_m / (self.focus_distance_m - f)

    def fov_x_deg(self) -> float:
        """Horizontal field of view of the sensor at the image distance (focus breathing included)."""
        return math.degrees(2.0 * math.atan(self.sensor_width_mm / 2000.0 / self.image_distance_m))

    def focal_px(self, width_px: int) -> float:
        """Focal distance in pixels of an image ``width_px`` wide: the image distance on the sensor
        (pixels per unit tangent of the pinhole view at the lens centre)."""
        return self.image_distance_m * width_px / (self.sensor_width_mm / 1000.0)

    def coc_scale_px(self, width_px: int) -> float:
        """a v W / sensor_width: the CoC radius in pixels per dioptre of defocus (1/F - 1/z); an
        expressive focal surface divides it by its ``dof_extent``."""
        extent = 1.0 if self.focal_surface is None else self.surface()["dof_extent"]
        return self.aperture_radius_m * self.image_distance_m * width_px / (self.sensor_width_mm / 1000.0) / extent

    def coc_radius_px(self, z_m, width_px: int):
        """Signed circle-of-confusion radius in pixels for camera-space depth ``z_m`` (metres).

        ``z_m`` may be a scalar or array; ``inf`` is allowed (background), z <= 0 or NaN is not.
        With a per-pixel focus (:attr:`has_focal_map`) ``z_m`` must be the (H, W) depth map.
        """
        z = depth_m(z_m)
        if not self.has_focal_map:
            return self.coc_scale_px(width_px) * (1.0 / self.focus_distance_m - 1.0 / z)
        if z.ndim != 2 or z.shape[1] != width_px:
            raise InputError(f"depth of shape {z.shape}: a tilted or expressive focus differs per pixel; give the "
                             f"(H, {width_px}) depth map")
        return self.coc_scale_px(width_px) * (self.inverse_focus_map(*z.shape) - 1.0 / z)

    def to_json(self) -> dict:
        out = {"lens": self.lens, "focal_length_mm": self.focal_length_mm, "f_number": self.f_number,
               "focus_distance_m": self.focus_distance_m, "sensor_width_mm": self.sensor_width_mm}
        if self.tilted:   # written only when used: untilted headers stay as they were
            out["sensor_tilt_deg"] = list(self.sensor_tilt_deg)
        if self.focal_surface is not None:
            out["focal_surface"] = self.surface()
        if self.focus_points:
            out["focus_points"] = [list(p) for p in self.focus_points]
        return out

    @classmethod
    def from_json(cls, data: dict, source: str = "camera") -> "ThinLens":
        """Build from the ``splatlab.camera`` JSON; ``source`` names where it came from in errors.

        An ``aperture`` entry (a polygonal iris, ``{"blades": 6, ...}``) does not change the CoC,
        which is the iris's circumradius; the polygon path reads it.
        """
        if data.get("lens") != cls.lens:
            raise InputError(f"{source}: lens = {data.get('lens')!r}, this runtime path needs {cls.lens!r}")
        known = {"lens", "focal_length_mm", "f_number", "focus_distance_m", "sensor_width_mm", "shutter",
                 "aperture", "sensor_tilt_deg", "focal_surface", "focus_points"}
        unknown = sorted(set(data) - known)
        if unknown:
            raise InputError(f"{source}: unknown key(s) {unknown}; known keys are {sorted(known)}")
        missing = [k for k in ("focal_length_mm", "f_number", "focus_distance_m") if k not in data]
        if missing:
            raise InputError(f"{source}: missing key(s) {missing} for a thin lens")
        try:
            return cls(focal_length_mm=data["focal_length_mm"], f_number=data["f_number"],
                       focus_distance_m=data["focus_distance_m"],
                       sensor_width_mm=data.get("sensor_width_mm", 36.0),
                       sensor_tilt_deg=data.get("sensor_tilt_deg", (0.0, 0.0)),
                       focal_surface=data.get("focal_surface"), focus_points=data.get("focus_points", ()))
        except InputError as exc:
            raise InputError(f"{source}: {exc}") from None


@functools.lru_cache(maxsize=8)
def _inverse_focus_map(lens: ThinLens, height: int, width: int) -> np.ndarray:
    if lens.focal_surface is not None:
        out = expressive_inverse_focus(height, width, lens.surface())
    elif lens.tilted:
        out = tilt_inverse_focus(height, width, lens.focal_px(width), 1.0 / lens.focus_distance_m,
                                 lens.image_distance_m, lens.sensor_tilt_deg)
    else:
        out = np.full((height, width), 1.0 / lens.focus_distance_m)
    out = np.asarray(out, np.float64)
    out.setflags(write=False)
    return out

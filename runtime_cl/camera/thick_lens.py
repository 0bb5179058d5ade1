"""A thick lens in numpy: the runtime's mirror of the lab's ``model = "thick"``.

The header (``"lens": "thick"``) carries the lens itself -- its surfaces, object side first, as
rows ``[radius_mm, thickness_mm, glass, semi_aperture_mm]`` (radius 0: the aperture stop;
``Infinity``: a flat face), the focus distance, the focusing rule and the sensor width -- so a
file alone says which lens to render, and a ``physical_lens`` database's fingerprint is checked
against it (:mod:`runtime_cl.psf.fingerprint`). The runtime has no glass catalog, so the lab
also writes the paraxial figures it derives from the surfaces (at the d line):

- ``focal_length_mm``: the effective focal length;
- ``chief_scale_mm``: the labelled pixels' pinhole focal distance (the pinhole sits at the
  entrance pupil; the paraxial chief ray of field tangent t lands at ``chief_scale_mm * t``);
- ``pupil_radius_mm``: the entrance pupil's radius;
- ``sensor_z_mm``: the sensor plane behind the first vertex (where focusing put it);
- ``pupil_z_mm``: the entrance pupil's centre on the axis (lens coordinates, any sign): where the
  labelled pixels' pinhole sits, so lens rays traced in the runtime map into its image;
- ``wavelengths_nm`` and ``indices``: each channel's wavelength and the refractive index behind
  every surface there, for exact ray tracing (:mod:`runtime_cl.camera.lens_trace`);
- ``sensor_tilt_deg`` (optional, tilt-shift): the sensor plane tilted about the axis point
  ``sensor_z_mm``, its z growing by tan(tx) per mm of sensor x and tan(ty) per mm of sensor y
  (lens coordinates: x, y as seen from the camera); a pixel's sensor point keeps its (x, y) and
  lies on that plane (Scheimpflug, :mod:`lab.focus`). Only the lens-ray passes trace it.

Depths are measured from the entrance pupil. The paraxial circle of confusion about the focus
distance F is exact for any lens of thin-lens form, with the entrance pupil radius a as the
aperture and the chief-ray scale k as the image distance (the marginal ray of a point at z lands
at k a (1/z - 1/F) from the chief ray, linear optics):

    r(z) = a k W / sensor_width * (1/F - 1/z)

The ``physical_lens`` PSFs hold the rest (aberrations, vignetting, colour); this radius only
sizes things that need a number per depth.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from runtime_cl.camera.common import depth_m, register_lens
from runtime_cl.camera.focal_surface import check_tilt
from runtime_cl.errors import InputError
from runtime_cl.json_values import is_number

FOCUS_RULES = ("best", "paraxial")
ROW = "[radius_mm, thickness_mm, glass, semi_aperture_mm]"
NUMBERS = ("focus_distance_m", "sensor_width_mm", "focal_length_mm", "chief_scale_mm", "pupil_radius_mm",
           "sensor_z_mm")


def _number(value) -> bool:
    return is_number(value, finite=False) and not math.isnan(value)   # inf: a flat surface


def surface_rows(rows, where: str = "surfaces") -> tuple:
    """``rows`` as a tuple of (float, float, str, float); InputError naming ``where`` and the row."""
    if not isinstance(rows, (list, tuple)) or not rows:
        raise InputError(f"{where} = {rows!r}: give the lens as a list of {ROW} rows, object side first")
    out = []
    for i, row in enumerate(rows):
        if not (isinstance(row, (list, tuple)) and len(row) == 4 and isinstance(row[2], str)
                and all(_number(row[k]) for k in (0, 1, 3))):
            raise InputError(f"{where}[{i}] = {row!r}: a surface is {ROW}, e.g. [50.0, 8.0, \"N-BK7\", 12.0]")
        out.append((float(row[0]), float(row[1]), row[2], float(row[3])))
    return tuple(out)


@register_lens("thick")
@dataclass(frozen=True)
class ThickLens:
    """A thick lens camera, units as in the ``splatlab.camera`` header (``"lens": "thick"``).

    Parameters
    ----------
    surfaces : tuple of (radius_mm, thickness_mm, glass, semi_aperture_mm)
        The lens, object side first (as :class:`lab.optics.thick_lens.Surface`).
    focus_distance_m : float
        Distance in focus, metres from the entrance pupil.
    focus : {"best", "paraxial"}
        How the sensor was placed: the smallest spot of the focus distance, or its paraxial image.
    sensor_width_mm : float
        Sensor width; the image width spans it.
    focal_length_mm, chief_scale_mm, pupil_radius_mm, sensor_z_mm : float
        Paraxial figures of the surfaces and the sensor plane (the module docstring); all > 0.
    pupil_z_mm : float
        The entrance pupil's centre (mm, lens coordinates; finite, any sign).
    wavelengths_nm : tuple of float
        Each channel's wavelength (R, G, B).
    indices : tuple of tuple of float
        Per channel, the refractive index behind each surface (>= 1; 1 for air).
    """

    lens: ClassVar[str]
    surfaces: tuple
    focus_distance_m: float
    focus: str
    sensor_width_mm: float
    focal_length_mm: float
    chief_scale_mm: float
    pupil_radius_mm: float
    sensor_z_mm: float
    pupil_z_mm: float
    wavelengths_nm: tuple
    indices: tuple
    focus_points: tuple = ()   # the pixels the focus was taken from, [[x, y], ...] (what the header records)
    sensor_tilt_deg: tuple = (0.0, 0.0)   # Scheimpflug: the sensor plane's slopes (module docstring)

    def __post_init__(self):
        object.__setattr__(self, "surfaces", surface_rows(self.surfaces, "camera surfaces"))
        for name in NUMBERS:
            value = getattr(self, name)
            if not (_number(value) and math.isfinite(value) and value > 0):
                raise InputError(f"camera {name} = {value!r}: must be a finite number > 0")
        if not (_number(self.pupil_z_mm) and math.isfinite(self.pupil_z_mm)):
            raise InputError(f"camera pupil_z_mm = {self.pupil_z_mm!r}: must be a finite number (mm)")
        waves, idx = self.wavelengths_nm, self.indices
        if not (isinstance(waves, (list, tuple)) and waves and all(_number(w) and w > 0 for w in waves)):
            raise InputError(f"camera wavelengths_nm = {waves!r}: give one wavelength (nm, > 0) per channel")
        n = len(self.surfaces)
        if not (isinstance(idx, (list, tuple)) and len(idx) == len(waves) and all(
                isinstance(row, (list, tuple)) and len(row) == n and all(_number(v) and 1.0 <= v < 4.0 for v in row)
                for row in idx)):
            raise InputError(f"camera indices = {idx!r}: give, per wavelength ({len(waves)}), the refractive index "
                             f"behind each of the {n} surfaces (1 <= n < 4)")
        object.__setattr__(self, "wavelengths_nm", tuple(float(w) for w in waves))
        object.__setattr__(self, "indices", tuple(tuple(float(v) for v in row) for row in idx))
        pts = self.focus_points
        if not (isinstance(pts, (list, tuple)) and all(isinstance(p, (list, tuple)) and len(p) == 2 and all(
                type(v) is int and v >= 0 for v in p) for p in pts)):
            raise InputError(f"camera focus_points = {pts!r}: give the focus pixels as [[x, y], ...] (integers >= 0)")
        object.__setattr__(self, "focus_points", tuple(tuple(p) for p in pts))
        object.__setattr__(self, "sensor_tilt_deg", check_tilt(self.sensor_tilt_deg))
        if self.focus not in FOCUS_RULES:
            raise InputError(f"camera focus = {self.focus!r}: use one of {list(FOCUS_RULES)}")

    def fov_x_deg(self) -> float:
        """Horizontal field of view of the labelled pixels' pinhole (at the entrance pupil)."""
        return math.degrees(2.0 * math.atan(self.sensor_width_mm / (2.0 * self.chief_scale_mm)))

    def focal_px(self, width_px: int) -> float:
        """The pinhole's focal distance in pixels of an image ``width_px`` wide."""
        return self.chief_scale_mm * width_px / self.sensor_width_mm

    def coc_radius_px(self, z_m, width_px: int):
        """Signed paraxial circle-of-confusion radius in pixels at depths ``z_m`` (metres from the
        entrance pupil; ``inf`` allowed), positive behind the focus distance."""
        return self.coc_scale_px(width_px) * (1.0 / self.focus_distance_m - 1.0 / depth_m(z_m))

    def coc_scale_px(self, width_px: int) -> float:
        """The paraxial CoC radius in pixels per dioptre of defocus (a k W / sensor width)."""
        return self.pupil_radius_mm * self.chief_scale_mm / 1000.0 * width_px / self.sensor_width_mm

    def to_json(self) -> dict:
        return {"lens": self.lens, "surfaces": [list(row) for row in self.surfaces],
                **{name: getattr(self, name) for name in NUMBERS}, "pupil_z_mm": self.pupil_z_mm, "focus": self.focus,
                "wavelengths_nm": list(self.wavelengths_nm), "indices": [list(row) for row in self.indices],
                **({"focus_points": [list(p) for p in self.focus_points]} if self.focus_points else {}),
                **({"sensor_tilt_deg": list(self.sensor_tilt_deg)} if self.tilted else {})}

    @property
    def tilted(self) -> bool:
        return self.sensor_tilt_deg != (0.0, 0.0)

    def sensor_slopes(self) -> tuple:
        """(gx, gy): the sensor's z (lens coordinates, mm) grows by gx per mm of sensor x and gy per
        mm of sensor y (x, y as seen from the camera; the sensor sees the image inverted)."""
        return tuple(math.tan(math.radians(t)) for t in self.sensor_tilt_deg)

    @classmethod
    def from_json(cls, data: dict, source: str = "camera") -> "ThickLens":
        """Build from the ``splatlab.camera`` JSON; ``source`` names where it came from in errors. A
        shaped stop (``aperture``) changes no figure of the runtime's; the database fingerprint checks it."""
        if data.get("lens") != cls.lens:
            raise InputError(f"{source}: lens = {data.get('lens')!r}, this runtime path needs {cls.lens!r}")
        known = {"lens", "surfaces", "focus", "shutter", "wavelengths_nm", "indices", "pupil_z_mm", "focus_points",
                 "sensor_tilt_deg", "aperture", *NUMBERS}
        unknown = sorted(set(data) - known)
        if unknown:
            raise InputError(f"{source}: unknown key(s) {unknown}; known keys are {sorted(known)}")
        missing = sorted(known - {"shutter", "focus_points", "sensor_tilt_deg", "aperture"} - set(data))
        if missing:
            raise InputError(f"{source}: missing key(s) {missing} for a thick lens")
        try:
            return cls(**{k: v for k, v in data.items() if k not in ("lens", "shutter", "aperture")})
        except InputError as exc:
            raise InputError(f"{source}: {exc}") from None

"""Settings of the PhysicalLens model (a scene's ``[psf.physical_lens]`` table), validated before
any tracing: the lens rows, the glass names, whether the lens can focus, the depth range."""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

from lab.errors import UserError
from lab.optics.lens_camera import FOCUS_MODES, ThickLensCamera
from lab.optics.lenses import LENSES
from lab.optics.thick_lens import LensSystem
from lab.optics.stop_shape import StopShape
from lab.psf_tracing.models.common import ApertureKeys, check_angle_bins, check_common, check_number

__all__ = ["PhysicalLensConfig", "DEFAULT_SURFACES"]

# The built-in singlet (lab.optics.lenses): bi-convex N-BK7, EFL 49.7 mm, f/2.8, a hood in front of
# the iris (cat-eye bokeh off axis).
DEFAULT_SURFACES = LENSES["singlet"]


@dataclass(frozen=True)
class PhysicalLensConfig(ApertureKeys):
    """Settings of the PhysicalLens model.

    Parameters
    ----------
    surfaces : tuple of (radius_mm, thickness_mm, glass, aperture_radius_mm)
        The lens, object side first (:class:`lab.optics.thick_lens.Surface`): radius 0 is the
        aperture stop, ``inf`` a flat face; the last row's thickness is 0 (the sensor is placed by
        focusing). Default: a bi-convex N-BK7 singlet at f/2.8 (:data:`DEFAULT_SURFACES`).
    focus_distance_m : float, default 2.0
        Distance in focus, metres from the entrance pupil; beyond the front focal point.
    focus : {"best", "paraxial"}, default "best"
        Sensor at the smallest RMS spot of that distance, or at its paraxial image.
    focus_wavelength_nm : float, default 587.5618
        Wavelength of focusing and of the pinhole image scale (the d line).
    wavelengths_nm : (float, float, float), default (650, 510, 475)
        Wavelength of the R, G, B channels (LES10).
    near_m, far_m : float, default 0.5, 20.0
        Depth range of the database, metres from the entrance pupil (0 < near < far).
    max_eccentricity_px : float, optional
        Largest distance from the image centre in pixels (default: the half diagonal).
    width_px : int, default 1024
        Image width in pixels across the sensor.
    sensor_width_mm, sensor_height_mm : float, default 36, 24
        Sensor size in mm.
    samples : int, default 4000
        Minimum number of PSF samples (LSR18: 4000).
    beta : (float, float), default (2.5, 1.2)
        Power-remapping exponents of (depth, eccentricity) (LSR18).
    psf_resolution : int, default 181
        R, the PSF image edge in pixels; checked against the traced PSFs before the first trace
        (:meth:`~lab.psf_tracing.models.physical_lens.PhysicalLens.required_resolution`).
    rays_per_psf : int, default 2**22
        Minimum rays per PSF.
    rays_per_pixel : int, default 2048
        Rays per pixel and channel of the PSF's support: a cell gets
        max(rays_per_psf, 3 rays_per_pixel support / landed share) rays, whole launches.
    rays_per_launch : int, default 2**22
        Rays per Dr.Jit launch (1 .. 2**30), bounding memory.
    density : float, default 1.0
        Relative spreadlet density for the sparsifier (> 0).
    seed : int, default 0
        Random seed (>= 0); same seed, same PSFs bitwise.
    angle_bins : int, optional
        A shaped stop only: bins of the pixel's azimuth modulo the stop's turn period (symmetry
        ``stop_turn``); default: bins of at most 10 degrees. ``samples`` PSFs are traced per bin.

    The ``aperture*`` keys (:class:`~lab.psf_tracing.models.common.ApertureKeys`) shape the stop:
    an iris or a stylized shape of circumradius the stop's semi-aperture
    (:class:`lab.optics.stop_shape.StopShape`); default the round opening.
    """

    surfaces: tuple[tuple[float, float, str, float], ...] = DEFAULT_SURFACES
    focus_distance_m: float = 2.0
    focus: str = "best"
    focus_wavelength_nm: float = 587.5618
    wavelengths_nm: tuple[float, float, float] = (650.0, 510.0, 475.0)
    near_m: float = 0.5
    far_m: float = 20.0
    max_eccentricity_px: float | None = None
    width_px: int = 1024
    sensor_width_mm: float = 36.0
    sensor_height_mm: float = 24.0
    samples: int = 4000
    beta: tuple[float, float] = (2.5, 1.2)
    psf_resolution: int = 181
    rays_per_psf: int = 2 ** 22
    rays_per_pixel: int = 2048
    rays_per_launch: int = 2 ** 22
    density: float = 1.0
    seed: int = 0
    angle_bins: int | None = None

    def __post_init__(self):
        check_common(self)
        check_angle_bins(self, self.check_aperture().turn_period_deg)
        for name in ("focus_distance_m", "near_m", "far_m", "sensor_width_mm", "sensor_height_mm",
                     "focus_wavelength_nm"):
            check_number(name, getattr(self, name))
        check_number("width_px", self.width_px, integer=True)
        if len(self.beta) != 2:
            raise UserError(f"beta = {self.beta!r}: give two exponents, (depth, eccentricity)")
        for b in self.beta:
            check_number("beta", b)
        if len(self.wavelengths_nm) != 3:
            raise UserError(f"wavelengths_nm = {self.wavelengths_nm!r}: give three, for R, G and B")
        for w in self.wavelengths_nm:
            check_number("wavelengths_nm", w)
        if self.far_m <= self.near_m:
            raise UserError(f"near_m = {self.near_m}, far_m = {self.far_m}: need near_m < far_m")
        if self.max_eccentricity_px is not None:
            check_number("max_eccentricity_px", self.max_eccentricity_px)
        if self.focus not in FOCUS_MODES:
            raise UserError(f"focus = {self.focus!r}: use one of {list(FOCUS_MODES)}")
        try:
            lens = LensSystem(self.surfaces)
        except UserError as exc:
            raise UserError(f"surfaces: {exc}") from None
        except TypeError:
            raise UserError(f"surfaces = {self.surfaces!r}: each row is (radius_mm, thickness_mm, glass, "
                            "aperture_radius_mm)") from None
        for w in (*self.wavelengths_nm, self.focus_wavelength_nm):
            lens.indices(w)  # UserError naming the wavelength outside the glasses' Sellmeier range
        try:
            cam = self.camera
        except UserError as exc:
            raise UserError(f"focus_distance_m = {self.focus_distance_m}: {exc}") from None
        if self.near_m <= cam.min_depth_m():
            raise UserError(f"near_m = {self.near_m}: objects must lie in front of the lens, farther than "
                            f"{cam.min_depth_m():.4g} m from its entrance pupil; raise near_m")
        half_diag = 0.5 * math.hypot(self.width_px, self.width_px * self.sensor_height_mm / self.sensor_width_mm)
        if self.max_eccentricity > 2 * half_diag:
            raise UserError(f"max_eccentricity_px = {self.max_eccentricity_px}: more than twice the image's "
                            f"half diagonal ({half_diag:.1f} px); use at most {half_diag:.1f}")

    @property
    def max_eccentricity(self) -> float:
        """The eccentricity range's upper end in pixels (default: the image's half diagonal)."""
        if self.max_eccentricity_px is not None:
            return float(self.max_eccentricity_px)
        return 0.5 * math.hypot(self.width_px, self.width_px * self.sensor_height_mm / self.sensor_width_mm)

    @cached_property
    def camera(self) -> ThickLensCamera:
        """The lens focused at ``focus_distance_m`` with this sensor (UserError if it cannot focus)."""
        lens = LensSystem(self.surfaces)
        shape = None
        if self.aperture != "circle":
            shape = StopShape(self.build_aperture(), lens.surfaces[lens.stop].aperture_radius_mm)
        return ThickLensCamera.focused(lens, self.focus_distance_m, self.wavelengths_nm, self.focus_wavelength_nm,
                                       self.width_px, self.sensor_width_mm, self.focus, shape)

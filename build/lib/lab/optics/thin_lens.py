"""Thin-lens optics in Dr.Jit: THE lab's source of truth (PSF tracing now, Mitsuba-side code later).

Same parameters, validation and numpy CoC as the runtime's mirror :class:`runtime_cl.camera.thin_lens.ThinLens`
(this class extends it), plus the Dr.Jit versions used per ray.

Conventions. The optical axis is z; an object point lies at depth z > 0 in front of the lens
(``inv_depth`` = 1/z, so 0 is a point at infinity); lateral coordinates (x, y) are metres with x
right and y up as seen from the camera. A ray is (height h at the lens, slope dh/dz). The paraxial
thin lens is exact for this model: it bends a ray by slope_out = slope_in - h / f, and the sensor
sits at the image distance v = f F / (F - f) behind the lens, where the focus plane F is sharp.

The sensor image is inverted; :meth:`ThinLens.sensor_to_image_px` rotates it by 180 degrees so the
PSF appears as in the final image, with image columns to the right and image rows downward. Then a
lens point h (aperture radius a) lands at (h / a) * r(z) pixels from the chief ray (in image axes x
right, y up; the row offset is minus the y part), r the signed CoC radius: behind the focus plane (r > 0) the PSF is the aperture upright, in front of it
(r < 0) rotated by 180 degrees (it matters for polygonal apertures with odd blade counts).
"""
from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
from drjit.llvm import Array2f

from runtime_cl.camera.thin_lens import ThinLens as _ThinLensParameters

__all__ = ["ThinLens"]


@dataclass(frozen=True)
class ThinLens(_ThinLensParameters):
    """A thin lens camera (focal length mm, f-number, focus distance m, sensor width mm).

    Parameters
    ----------
    focal_length_mm : float
        Focal length f in millimetres (> 0).
    f_number : float
        f-number N (> 0); the aperture radius is a = f / (2 N).
    focus_distance_m : float
        Distance F of the plane in focus, metres (> f).
    sensor_width_mm : float, default 36
        Sensor width in millimetres; an image ``width_px`` pixels wide spans it.
    """

    # --- scalar geometry (metres) ------------------------------------------------------------
    @property
    def focal_length_m(self) -> float:
        return self.focal_length_mm / 1000.0

    @property
    def sensor_width_m(self) -> float:
        return self.sensor_width_mm / 1000.0

    def pixels_per_metre(self, width_px: int) -> float:
        """Sensor sampling density: pixels per metre on the sensor for an image ``width_px`` wide."""
        return width_px / self.sensor_width_m

    def max_far_coc_px(self, width_px: int) -> float:
        """CoC radius in pixels of a point at infinity: the largest positive (far-side) CoC."""
        return self.coc_scale_px(width_px) / self.focus_distance_m

    # --- Dr.Jit, per ray ---------------------------------------------------------------------
    def coc_radius_px_dr(self, z, width_px: int):
        """Signed CoC radius in pixels of depth ``z`` (metres, Dr.Jit float array; inf allowed).

        r(z) = a v W / sensor_width (1/F - 1/z): positive behind the focus plane. Returns the
        type of ``z`` (Float or Float64); depths must be > 0 (not checked per ray).
        """
        return self.coc_scale_px(width_px) * (1.0 / self.focus_distance_m - dr.rcp(z))

    def inv_depth_for_coc_px(self, r, width_px: int):
        """1/z (1/metres) of the depth whose signed CoC radius is ``r`` pixels (Dr.Jit array).

        The inverse of :meth:`coc_radius_px_dr`; 1/z is returned rather than z so the point at
        infinity (r = :meth:`max_far_coc_px`) is exact. 1/z <= 0 means no real depth has that CoC.
        """
        return 1.0 / self.focus_distance_m - r * (1.0 / self.coc_scale_px(width_px))

    def refract(self, h: Array2f, slope_in: Array2f) -> Array2f:
        """Paraxial thin-lens transfer: slope_out = slope_in - h / f (h in metres)."""
        return slope_in - h * (1.0 / self.focal_length_m)

    def trace_to_sensor(self, h: Array2f, inv_depth, field_slope: Array2f | None = None) -> Array2f:
        """Sensor hit (metres) of the ray from an object point through lens point ``h`` (metres).

        The object point lies at 1/z = ``inv_depth`` in the direction ``field_slope`` (lateral
        position / depth; default on axis), so it may be at infinity. The chief ray (h = 0) hits
        the sensor at -v * field_slope whatever the depth; subtract it for the PSF.
        """
        slope_in = h * inv_depth
        if field_slope is not None:
            slope_in = slope_in - field_slope
        slope_out = self.refract(h, slope_in)
        return h + slope_out * self.image_distance_m

    def sensor_to_image_px(self, offset: Array2f, width_px: int) -> Array2f:
        """Sensor offset (metres, x right / y up) -> image offset in pixels (column, row).

        Undoes the lens inversion (180 degree rotation) and flips y so rows grow downward.
        """
        k = self.pixels_per_metre(width_px)
        return Array2f(-k * offset.x, k * offset.y)

    def psf_offset_px(self, h: Array2f, inv_depth, width_px: int) -> Array2f:
        """Where lens point ``h`` (metres) sends an on-axis point, relative to the chief ray, in
        image pixels (column, row): the PSF as it appears in the image."""
        return self.sensor_to_image_px(self.trace_to_sensor(h, inv_depth), width_px)

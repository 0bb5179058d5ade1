"""A Mitsuba 3 sensor that traces the lab's thick lens: the reference for ``model = "thick"``.

The same :class:`~lab.optics.thick_lens.LensSystem`, focused by the same rule
(:meth:`~lab.optics.lens_camera.ThickLensCamera.focused`), as the ``physical_lens`` PSF model
traces. A camera ray starts at the film point on the sensor, is aimed at a point drawn
uniformly in the box behind the rear element that its sensor radius can see through, and is
refracted backward through every surface at the sensor's one wavelength
(:class:`~lab.optics.exit_pupil.ExitPupil`, Dr.Jit). Rays that are blocked or totally reflected
get weight 0; the others ``cos^4 * box area / A(r)``, which renormalises vignetting as the PSF
model's normalised PSFs do (the exit-pupil module says why).
A tilted sensor (the header's ``sensor_tilt_deg``, tilt-shift) moves each film point along the axis
to its plane (:class:`~lab.optics.exit_pupil.ExitPupil`'s slopes), as the runtime's tracer does.
Chromatic aberration: one render per channel wavelength (:class:`lab.reference.chromatic.
ChromaticJob`).

Orientation. The film's x runs right and its y down; the sensor sees the image inverted, so
film point (fx, fy) in [0, 1]^2 is the sensor point (-(fx - 1/2) W, (fy - 1/2) H) mm in lens
coordinates (x right and y up as seen from the camera, z from the scene into it). Mitsuba's
camera space looks along +z with +x on the image's left, so a lens point (x, y, z) is the camera
point (-x, y, z_pupil - z) / 1000 m: the camera (``to_world``) sits at the entrance pupil, where
the labelled pixels' pinhole is and depths are measured from.
"""
from __future__ import annotations

import functools
import json
import math

from .backend import mitsuba
from .python_sensor import point_bbox, ray_differential, traverse_to_world

PLUGIN = "splatlab_thick_lens"


@functools.cache
def register() -> str:
    """Register the sensor plugin (once per process); returns its ``type`` name for scene dicts.

    Parameters of the plugin: ``camera`` (the ``splatlab.camera`` JSON of a thick lens, a
    string: :meth:`lab.cameras.thick.ThickCamera.camera_json`), ``wavelength_nm`` (the one
    wavelength traced), optionally ``aperture`` (the JSON of the camera's ``aperture_params``: a
    shaped stop), ``to_world``, a film and a sampler.
    """
    mi = mitsuba()
    import drjit as dr
    from drjit.llvm import Float

    from ..cameras.thick import FOCUS_WAVELENGTH_NM
    from ..optics.exit_pupil import ExitPupil
    from ..optics.lens_camera import ThickLensCamera
    from ..optics.stop_shape import StopShape
    from ..optics.thick_lens import DRJIT, LensSystem

    class ThickLensSensor(mi.Sensor):
        def __init__(self, props):
            super().__init__(props)
            data = json.loads(props.get("camera"))
            self.wavelength = float(props.get("wavelength_nm"))
            film = self.film()
            self.size, self.crop_size, self.crop_offset = film.size(), film.crop_size(), film.crop_offset()
            width_mm = float(data["sensor_width_mm"])
            self.sensor_mm = (width_mm, width_mm * self.size[1] / self.size[0])
            lens = LensSystem(data["surfaces"])
            shape = StopShape.from_params(json.loads(props.get("aperture")) if "aperture" in props
                                          else None, lens.surfaces[lens.stop].aperture_radius_mm)
            cam = ThickLensCamera.focused(lens, data["focus_distance_m"], (self.wavelength,),
                                          FOCUS_WAVELENGTH_NM, int(self.size[0]), width_mm, data["focus"], shape)
            self.pupil_z = cam.pupil_z_mm
            # tilt-shift: the sensor point (sx, sy) lies gx sx + gy sy beyond the axial sensor plane
            slopes = tuple(math.tan(math.radians(t)) for t in data.get("sensor_tilt_deg", (0.0, 0.0)))
            shift = 0.5 * (abs(slopes[0]) * self.sensor_mm[0] + abs(slopes[1]) * self.sensor_mm[1])
            self.pupil = ExitPupil.build(cam, self.wavelength, 0.5 * math.hypot(*self.sensor_mm), slopes=slopes,
                                         shift_mm=shift)
            self.m_needs_sample_3 = True

        def sample_ray(self, time, sample1, sample2, sample3, active=True):
            fx = (self.crop_offset[0] + Float(sample2.x) * self.crop_size[0]) / self.size[0]
            fy = (self.crop_offset[1] + Float(sample2.y) * self.crop_size[1]) / self.size[1]
            sx, sy = -(fx - 0.5) * self.sensor_mm[0], (fy - 0.5) * self.sensor_mm[1]
            qx, qy, scale = self.pupil.sample(sx, sy, Float(sample3.x), Float(sample3.y), DRJIT)
            (ox, oy, oz), (dx, dy, dz), ok, cos4 = self.pupil.trace(sx, sy, qx, qy, DRJIT)
            weight = dr.select(ok, cos4 * scale, 0.0)
            origin = mi.Point3f(mi.Float(dr.select(ok, -ox, 0.0)) / 1000.0, mi.Float(dr.select(ok, oy, 0.0)) / 1000.0,
                                mi.Float(dr.select(ok, self.pupil_z - oz, 0.0)) / 1000.0)
            direction = mi.Vector3f(mi.Float(dr.select(ok, -dx, 0.0)), mi.Float(dr.select(ok, dy, 0.0)),
                                    mi.Float(dr.select(ok, -dz, 1.0)))
            to_world = self.world_transform()
            ray = mi.Ray3f(mi.Point3f(to_world @ origin), mi.Vector3f(to_world @ direction), time, mi.Color0f())
            return ray, mi.Spectrum(mi.Float(weight))

        sample_ray_differential = ray_differential
        bbox = point_bbox
        traverse = traverse_to_world

        def to_string(self):
            return (f"ThickLensSensor[wavelength_nm={self.wavelength}, sensor_z_mm={self.pupil.sensor_z_mm:.4f}, "
                    f"plane_z_mm={self.pupil.plane_z_mm:.4f}]")

    mi.register_sensor(PLUGIN, lambda props: ThickLensSensor(props))
    return PLUGIN

"""A Mitsuba 3 thin-lens sensor with a tilted sensor plane (Scheimpflug): the tilt-shift reference.

The film is rectified onto the pinhole grid of the lens centre, as the labelled input is: film
position u picks the chief ray direction d (z = 1) of Mitsuba's ``perspective`` projection with the
same fov, and the film point is where that chief ray, continued behind the lens, meets the tilted
sensor plane. The sensor plane (camera space, metres; x image-right, y up, z forward) is

    z = -(v + gx X + gy Y),     gx, gy = tan(sensor_tilt_deg),

through the on-axis image point v = f F / (F - f) of the focus distance F. The ray is traced
physically: from the sensor point s = -v_s d (v_s = v / (1 + gx dx + gy dy)) to the lens point
L (uniform on the disc of radius a = f / 2N), where the ideal thin lens bends it by -L / f in
slope. So nothing here uses the focal plane; that every sensor point's rays converge on the plane
the focus points fit (Scheimpflug) is what the tests check against
:mod:`runtime_cl.camera.focal_surface`. Weight 1, near/far clipping as Mitsuba's ``thinlens``.

Mitsuba's camera space has +x on the image's left: image-right dx is -x there.
"""
from __future__ import annotations

import functools
import math

from .backend import mitsuba
from .python_sensor import clipped_ray, point_bbox, ray_differential, traverse_to_world

PLUGIN = "splatlab_tilted_thinlens"


@functools.cache
def register() -> str:
    """Register the sensor plugin (once per process); returns its ``type`` name for scene dicts.

    Parameters: ``fov`` (horizontal, degrees), ``to_world``, ``aperture_radius``,
    ``focal_length``, ``focus_distance`` (metres), ``tilt_x_deg``, ``tilt_y_deg``, optional
    ``near_clip``/``far_clip``, a film and a sampler.
    """
    mi = mitsuba()
    import drjit as dr

    class TiltedThinLens(mi.Sensor):
        def __init__(self, props):
            super().__init__(props)
            self.radius = float(props.get("aperture_radius"))
            self.f = float(props.get("focal_length"))
            focus = float(props.get("focus_distance"))
            self.v = self.f * focus / (focus - self.f)
            self.gx = math.tan(math.radians(float(props.get("tilt_x_deg"))))
            self.gy = math.tan(math.radians(float(props.get("tilt_y_deg"))))
            self.near, self.far = float(props.get("near_clip", 1e-2)), float(props.get("far_clip", 1e4))
            film = self.film()
            self.sample_to_camera = mi.perspective_projection(
                film.size(), film.crop_size(), film.crop_offset(), float(props.get("fov")),
                self.near, self.far).inverse()
            self.m_needs_sample_3 = True

        def sample_ray(self, time, sample1, sample2, sample3, active=True):
            near_p = self.sample_to_camera @ mi.Point3f(sample2.x, sample2.y, 0.0)
            chief = mi.Vector3f(near_p / near_p.z)                       # camera space, z = 1
            # Image-right is camera -x: the sensor's depth behind the lens grows by gx per image-right metre.
            v_s = self.v / (1.0 + self.gx * (-chief.x) + self.gy * chief.y)
            sensor = -v_s * chief                                        # behind the lens (z = -v_s)
            disc = mi.warp.square_to_uniform_disk_concentric(sample3)
            lens = mi.Point3f(self.radius * disc.x, self.radius * disc.y, 0.0)
            inward = (lens - sensor) / v_s                               # slope (z = 1) before the lens
            d = dr.normalize(mi.Vector3f(inward.x - lens.x / self.f, inward.y - lens.y / self.f, 1.0))
            return clipped_ray(self, lens, d, time), mi.Spectrum(1.0)

        sample_ray_differential = ray_differential
        bbox = point_bbox
        traverse = traverse_to_world

        def to_string(self):
            return (f"TiltedThinLens[aperture_radius={self.radius}, focal_length={self.f}, "
                    f"tilt=({self.gx}, {self.gy})]")

    mi.register_sensor(PLUGIN, lambda props: TiltedThinLens(props))
    return PLUGIN

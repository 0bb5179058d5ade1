"""What every Python ``mi.Sensor`` of the lab shares (the thin lens through an aperture shape,
the tilted thin lens, the thick lens): a ray differential without differentials, a point bounding
box at the sensor's origin, the ``to_world`` transform as a scene parameter (so the motion
reference's sub-frames can move the camera; assign them in the class body:
``sample_ray_differential = ray_differential``), and a thin lens's camera-space ray clipped to
the near and far planes."""
from __future__ import annotations

from .backend import mitsuba

__all__ = ["clipped_ray", "point_bbox", "ray_differential", "traverse_to_world"]


def ray_differential(self, time, sample1, sample2, sample3, active=True):
    """``sample_ray`` wrapped as a ray differential (no differentials: the box filter needs none)."""
    ray, weight = self.sample_ray(time, sample1, sample2, sample3, active)
    return mitsuba().RayDifferential3f(ray), weight


def traverse_to_world(self, callback):
    """``mi.traverse`` lists ``to_world`` (Mitsuba's C++ sensors do; a Python one must say so)."""
    mi = mitsuba()
    mi.Sensor.traverse(self, callback)
    callback.put("to_world", self.m_to_world, mi.ParamFlags.NonDifferentiable)


def point_bbox(self):
    """The sensor's bounding box: the point at its origin in world space."""
    mi = mitsuba()
    p = self.world_transform() @ mi.Point3f(0.0, 0.0, 0.0)
    return mi.ScalarBoundingBox3f(mi.ScalarPoint3f(p.x[0], p.y[0], p.z[0]))


def clipped_ray(self, lens_point, d, time):
    """The world ray from camera-space ``lens_point`` along the unit camera-space direction ``d``
    (d.z > 0), starting at the sensor's near plane and ending at its far plane."""
    mi = mitsuba()
    import drjit as dr

    to_world = self.world_transform()
    direction = to_world @ mi.Vector3f(d)
    inv_z = dr.rcp(d.z)
    near_t, far_t = self.near * inv_z, self.far * inv_z
    origin = to_world @ mi.Point3f(lens_point) + direction * near_t
    return mi.Ray3f(mi.Point3f(origin), direction, far_t - near_t, time, mi.Color0f())

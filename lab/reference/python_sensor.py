"""What every Python ``mi.Sensor`` of the lab shares (the thin lens through an aperture shape,
the thick lens): a ray differential without differentials, and a point bounding box at the
sensor's origin. Assign them in the class body: ``sample_ray_differential = ray_differential``."""
from __future__ import annotations

from .backend import mitsuba

__all__ = ["point_bbox", "ray_differential"]


def ray_differential(self, time, sample1, sample2, sample3, active=True):
    """``sample_ray`` wrapped as a ray differential (no differentials: the box filter needs none)."""
    ray, weight = self.sample_ray(time, sample1, sample2, sample3, active)
    return mitsuba().RayDifferential3f(ray), weight


def point_bbox(self):
    """The sensor's bounding box: the point at its origin in world space."""
    mi = mitsuba()
    p = self.world_transform() @ mi.Point3f(0.0, 0.0, 0.0)
    return mi.ScalarBoundingBox3f(mi.ScalarPoint3f(p.x[0], p.y[0], p.z[0]))

"""A Mitsuba 3 thin-lens sensor with any aperture shape: the reference for shaped bokeh.

Mitsuba's ``thinlens`` samples a disc. This Python sensor (``mi.register_sensor``; a thin-lens
camera with an iris or a stylized aperture chooses it, :meth:`lab.cameras.thin.ThinCamera.
mitsuba_sensor`) is the same camera with the lens point drawn uniformly from the lab's own
aperture sampler (:mod:`lab.optics.aperture`: a polygonal iris, a star, a heart, an image; the
one the PSF models trace) scaled to the aperture radius, its circumradius: the pinhole ray of
the position sample fixes the point on the planar focus plane at ``focus_distance`` (camera
space z), and the ray runs from the lens point through it, as in Mitsuba's ``thinlens.cpp``
(same projection, near/far clip handling and weight 1). A point at planar depth z then images
to the iris scaled to the CoC radius of :class:`runtime_cl.camera.thin_lens.ThinLens`, upright behind
the focus plane and rotated by 180 degrees in front of it.

Orientation: the aperture is given as seen in the image (x right, y up); Mitsuba's camera space
has +x on the image's left, so the lens point is mirrored in x.
"""
from __future__ import annotations

import functools

from .backend import mitsuba
from .python_sensor import clipped_ray, point_bbox, ray_differential, traverse_to_world

PLUGIN = "splatlab_aperture_thinlens"
SHAPE_PARAMS = ("blades", "rotation_deg", "rounding", "path")   # plugin properties an aperture takes


@functools.cache
def register() -> str:
    """Register the sensor plugin (once per process); returns its ``type`` name for scene dicts.

    Parameters of the plugin: ``fov`` (horizontal, degrees), ``to_world``, ``aperture_radius``
    (metres), ``focus_distance`` (metres), ``aperture`` (a registered shape name) with its
    parameters (``blades``, ``rotation_deg``, ``rounding`` for ``"polygon"``, the iris of
    :class:`lab.optics.iris.Iris`; ``path`` for ``"image"``), optional ``near_clip``/``far_clip``,
    a film and a sampler.
    """
    mi = mitsuba()
    import drjit as dr
    from drjit.llvm import Array2f, Float

    from ..optics.aperture import make_aperture

    class ApertureThinLens(mi.Sensor):
        def __init__(self, props):
            super().__init__(props)
            name = props.get("aperture")
            params = {k: props.get(k) for k in SHAPE_PARAMS if k in props}
            self.iris = make_aperture(name, **params)
            self.radius = float(props.get("aperture_radius"))
            self.focus = float(props.get("focus_distance"))
            self.near, self.far = float(props.get("near_clip", 1e-2)), float(props.get("far_clip", 1e4))
            film = self.film()
            self.sample_to_camera = mi.perspective_projection(
                film.size(), film.crop_size(), film.crop_offset(), float(props.get("fov")),
                self.near, self.far).inverse()
            self.m_needs_sample_3 = True

        def sample_ray(self, time, sample1, sample2, sample3, active=True):
            near_p = self.sample_to_camera @ mi.Point3f(sample2.x, sample2.y, 0.0)
            lens = self.iris.sample(Array2f(Float(sample3.x), Float(sample3.y)))
            aperture_p = mi.Point3f(-self.radius * mi.Float(lens.x), self.radius * mi.Float(lens.y), 0.0)
            focus_p = near_p * (self.focus / near_p.z)
            d = dr.normalize(mi.Vector3f(focus_p - aperture_p))
            return clipped_ray(self, aperture_p, d, time), mi.Spectrum(1.0)

        sample_ray_differential = ray_differential
        bbox = point_bbox
        traverse = traverse_to_world

        def to_string(self):
            return (f"ApertureThinLens[aperture={self.iris}, aperture_radius={self.radius}, "
                    f"focus_distance={self.focus}]")

    mi.register_sensor(PLUGIN, lambda props: ApertureThinLens(props))
    return PLUGIN

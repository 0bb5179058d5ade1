"""Scene dataclasses -> one Mitsuba scene dict, shared by the reference and the pinhole input.

Both renders see the same objects, lights and view (look-at frame, horizontal field of view);
only the sensor differs: the input's is a ``perspective`` (pinhole) sensor, the reference's the
one the scene's camera model makes of it (:meth:`lab.cameras.Camera.mitsuba_sensor`: e.g.
``thinlens``, or the thin lens with a polygonal iris). The box pixel filter makes each pixel the
exact integral over its own area, the same footprint for the reference and the input.
"""
from __future__ import annotations

from ..medium_box import shapes_inside
from ..scene import Scene
from ..scene_objects import Material, Shape
from .backend import mitsuba

SENSORS = ("scene", "pinhole")


def _rgb(value):
    return {"type": "rgb", "value": [float(c) for c in value]}


def _texture(m: Material, default=(0.5, 0.5, 0.5)):
    if m.checkerboard is None:
        return _rgb(m.reflectance or default)
    c = m.checkerboard
    mi = mitsuba()
    return {"type": "checkerboard", "color0": _rgb(c.color0), "color1": _rgb(c.color1),
            "to_uv": mi.ScalarTransform4f().scale([*c.uv_scale(), 1.0])}


# One builder per material / emitter type (registered by name, as Mitsuba's plugins are).
MATERIALS = {
    "diffuse": lambda m: {"type": "diffuse", "reflectance": _texture(m)},
    "roughplastic": lambda m: {"type": "roughplastic", "distribution": "ggx",
                               "diffuse_reflectance": _texture(m),
                               "alpha": 0.1 if m.alpha is None else m.alpha},
    "conductor": lambda m: {"type": "conductor", "material": m.metal},
}
EMITTERS = {
    "constant": lambda e: {"type": "constant", "radiance": _rgb(e.radiance)},
    "point": lambda e: {"type": "point", "position": list(e.position), "intensity": _rgb(e.intensity)},
    "directional": lambda e: {"type": "directional", "direction": list(e.direction),
                              "irradiance": _rgb(e.irradiance)},
}


def _emitter(e) -> dict:
    return {**EMITTERS[e.type](e), "sampling_weight": e.sampling_weight}
BLACK = {"type": "diffuse", "reflectance": _rgb((0.0, 0.0, 0.0))}


def _shape(shape: Shape, material_ids: dict) -> dict:
    mi = mitsuba()
    out = {"type": shape.type, "to_world": mi.ScalarTransform4f(shape.to_world_matrix().tolist())}
    out["bsdf"] = BLACK if shape.material is None else {"type": "ref", "id": material_ids[shape.material]}
    if shape.emitter is not None:
        out["emitter"] = {"type": "area", "radiance": _rgb(shape.emitter.radiance),
                          "sampling_weight": shape.emitter.sampling_weight}
    return out


def sensor_dict(scene: Scene, sensor: str = "scene", spp: int = 1, crop=None) -> dict:
    """The Mitsuba sensor: the scene's camera (``"scene"``) or a pinhole with the same view;
    ``crop`` = (x, y, width, height) renders only that window of the film (its pixels sampled as
    in the whole frame: the sensors map the window into the full film)."""
    if sensor not in SENSORS:
        raise ValueError(f"sensor = {sensor!r}: use one of {SENSORS}")
    mi = mitsuba()
    cam = scene.camera
    out = {
        "type": "perspective", "fov": cam.fov_x_deg(), "fov_axis": "x",
        "to_world": mi.ScalarTransform4f().look_at(origin=list(cam.position), target=list(cam.look_at),
                                                   up=list(cam.up)),
        "film": {"type": "hdrfilm", "width": scene.width, "height": scene.height,
                 "pixel_format": "rgb", "component_format": "float32", "rfilter": {"type": "box"}},
        "sampler": {"type": "independent", "sample_count": int(spp)},
    }
    if crop is not None:
        x, y, w, h = (int(v) for v in crop)
        if not (0 <= x and 0 <= y and w >= 1 and h >= 1 and x + w <= scene.width and y + h <= scene.height):
            raise ValueError(f"crop = {crop}: the window must lie inside the {scene.width}x{scene.height} film")
        out["film"].update(crop_offset_x=x, crop_offset_y=y, crop_width=w, crop_height=h)
    return cam.mitsuba_sensor(out) if sensor == "scene" else out


def _medium(m) -> dict:
    return {"type": "homogeneous", "sigma_t": float(m.sigma_t), "albedo": _rgb(m.albedo),
            "phase": {"type": "hg", "g": float(m.g)}}


def _box_boundary(box) -> dict:
    """The box's wall: a ``cube`` ([-1, 1]^3 scaled and moved onto the box) with the ``null`` BSDF
    (index-matched: light crosses it unchanged) and the medium as its interior (Mitsuba's
    participating-media docs: a shape marks the transition into its ``interior`` medium)."""
    mi = mitsuba()
    to_world = mi.ScalarTransform4f().translate(list(box.center)).scale([0.5 * s for s in box.size])
    return {"type": "cube", "to_world": to_world, "bsdf": {"type": "null"},
            "interior": {"type": "ref", "id": "medium"}}


def scene_dict(scene: Scene, sensor: str = "scene", spp: int = 1, medium: bool = False, crop=None) -> dict:
    """The whole Mitsuba scene dict (``mi.load_dict`` it) with a ``path`` integrator.

    Parameters
    ----------
    scene : Scene
        A validated scene.
    sensor : {"scene", "pinhole"}
        ``"scene"``: the scene's own camera (its model's :meth:`~lab.cameras.Camera.mitsuba_sensor`,
        ``thinlens`` for a thin lens); ``"pinhole"``: a ``perspective`` sensor with the same
        position, orientation and horizontal fov.
    spp : int
        Samples per pixel stored in the sampler (``mi.render(spp=...)`` may override it).
    medium : bool, default False
        Fill the scene with its ``[medium]`` (the reference; the labelled input is rendered
        without it): a ``volpath`` integrator, the medium around the sensor and outside every shape;
        a medium with a ``box``: the interior of a null-BSDF cube (:func:`_box_boundary`), around
        the sensor and the shapes inside the box only.
    crop : (x, y, width, height), optional
        Render only this window of the film (:func:`sensor_dict`).
    """
    fog = medium and scene.medium is not None
    out = {"type": "scene", "integrator": {"type": "volpath" if fog else "path",
                                           "max_depth": scene.render.max_depth},
           "sensor": sensor_dict(scene, sensor, spp, crop)}
    box = scene.medium.box if fog else None
    inside = [True] * len(scene.shapes) if box is None else shapes_inside(box, scene.shapes, scene.source)
    if fog:
        out["medium"] = _medium(scene.medium)
        if box is None or box.contains(scene.camera.position):
            out["sensor"]["medium"] = {"type": "ref", "id": "medium"}
        if box is not None:
            out["medium_box"] = _box_boundary(box)
    material_ids = {name: f"material_{i}" for i, name in enumerate(sorted(scene.materials))}
    for name, key in material_ids.items():
        m = scene.materials[name]
        out[key] = MATERIALS[m.type](m)
    for i, shape in enumerate(scene.shapes):
        out[f"shape_{i}"] = _shape(shape, material_ids)
        if fog and inside[i]:   # the medium surrounds it (filling the scene, or its box holds it)
            out[f"shape_{i}"]["exterior"] = {"type": "ref", "id": "medium"}
    for i, emitter in enumerate(scene.emitters):
        out[f"emitter_{i}"] = _emitter(emitter)
    return out

"""Scene-file objects: ``[materials.NAME]``, ``[[shapes]]`` and ``[[emitters]]`` as frozen dataclasses.

Shapes follow Mitsuba's canonical shapes: ``sphere`` (unit sphere), ``rectangle`` ([-1, 1]^2 in
the xy plane, normal +z), ``cube`` ([-1, 1]^3) and ``disk`` (unit disc in the xy plane, normal +z),
placed either by ``to_world`` (a 4x4 row-major matrix) or by ``center`` / ``scale`` / ``rotate``
/ ``radius``: world = T(center) Rz Ry Rx S(scale * radius), rotations in degrees about the world
axes, x first. So a rectangle with ``scale = [5, 3, 1]`` is 10 m x 6 m and ``rotate = [-90, 0, 0]``
turns its normal from +z to +y (a floor).
"""
from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, fields

import numpy as np

from .config import from_table
from .errors import UserError
from .motion import check_vector, rigid_motion

Vec3 = tuple[float, float, float]
SHAPE_TYPES = ("sphere", "rectangle", "cube", "disk")
# Mitsuba's measured conductor data (spectral; RGB variants integrate it). A subset, the common ones.
METALS = ("Ag", "Al", "Au", "Cr", "Cu", "Hg", "Ir", "Li", "Mo", "Rh", "W", "none")


def strip_none(value):
    """Drop ``None`` entries recursively, so canonical dicts only hold what was set."""
    if isinstance(value, dict):
        return {k: strip_none(v) for k, v in value.items() if v is not None}
    if isinstance(value, list):
        return [strip_none(v) for v in value]
    return value


def _check_colour(key, value, where=""):
    if value is not None and not all(math.isfinite(c) and c >= 0 for c in value):
        raise UserError(f"{where}{key} = {list(value)}: colour components must be finite and >= 0")


def _check_weight(value):
    if not (math.isfinite(value) and value > 0):
        raise UserError(f"sampling_weight = {value} must be a finite number > 0")


def _only(obj, allowed: set[str], kind: str):
    """Keys set (not None) beyond ``allowed`` for this type are errors, not silently ignored."""
    extra = sorted(f.name for f in fields(obj) if f.name not in allowed | {"type"}
                   and getattr(obj, f.name) is not None)
    if extra:
        raise UserError(f"{extra} do not apply to {kind} = {obj.type!r}; allowed keys: {sorted(allowed)}")


@dataclass(frozen=True)
class Checkerboard:
    """Two-colour checkerboard texture over a shape's uv range [0, 1]^2.

    ``scale`` (one number, or ``[su, sv]`` for non-square shapes) repeats it: 2 * scale squares
    across u (and v), e.g. a 40 m x 10 m wall with ``scale = [40, 10]`` has 0.5 m squares.
    """

    color0: Vec3
    color1: Vec3
    scale: float | tuple[float, float] = 1.0

    def __post_init__(self):
        _check_colour("color0", self.color0)
        _check_colour("color1", self.color1)
        if not all(math.isfinite(v) and v > 0 for v in self.uv_scale()):
            raise UserError(f"scale = {self.scale} must be > 0")

    def uv_scale(self) -> tuple[float, float]:
        """(su, sv): how many times the two-square pattern repeats along u and v."""
        return (self.scale, self.scale) if isinstance(self.scale, float) else self.scale


@dataclass(frozen=True)
class Material:
    """``[materials.NAME]``: ``diffuse`` or ``roughplastic`` (``reflectance`` rgb or ``checkerboard``;
    roughplastic adds GGX roughness ``alpha``), or ``conductor`` (``metal``, one of ``METALS``)."""

    type: str = "diffuse"
    reflectance: Vec3 | None = None
    checkerboard: Checkerboard | None = None
    alpha: float | None = None
    metal: str | None = None

    def __post_init__(self):
        allowed = {"diffuse": {"reflectance", "checkerboard"},
                   "roughplastic": {"reflectance", "checkerboard", "alpha"}, "conductor": {"metal"}}
        if self.type not in allowed:
            raise UserError(f"type = {self.type!r} is not a material; use one of {sorted(allowed)}")
        _only(self, allowed[self.type], "type")
        _check_colour("reflectance", self.reflectance)
        if self.reflectance is not None and self.checkerboard is not None:
            raise UserError("give reflectance or checkerboard, not both")
        if self.type == "diffuse" and self.reflectance is None and self.checkerboard is None:
            raise UserError("a diffuse material needs reflectance = [r, g, b] or a checkerboard table")
        if self.alpha is not None and not 0 < self.alpha <= 1:
            raise UserError(f"alpha = {self.alpha}: GGX roughness must be in (0, 1]")
        if self.type == "conductor" and self.metal not in METALS:
            raise UserError(f"metal = {self.metal!r}: use one of {list(METALS)}")


@dataclass(frozen=True)
class AreaLight:
    """``emitter = {radiance = [r, g, b]}`` on a shape: a diffuse area light (W m^-2 sr^-1).

    ``sampling_weight`` (default 1) is the relative chance that next-event estimation picks this
    light; lower it for small lights that matter when seen directly (bokeh) but light little.
    """

    radiance: Vec3
    sampling_weight: float = 1.0

    def __post_init__(self):
        _check_colour("radiance", self.radiance)
        _check_weight(self.sampling_weight)


@dataclass(frozen=True)
class Shape:
    """``[[shapes]]``: a canonical shape, its placement, material and optional area light.

    ``material`` may be omitted only for a pure light (``emitter`` given): it is then black.
    ``layer`` (0 = nearest) puts the shape into that layer of the layered labelled input; shapes
    without one form the last layer with the environment (:meth:`lab.scene.Scene.input_layers`).
    ``velocity`` (m per time unit) and ``angular_velocity_deg`` (a rotation vector, degrees per
    time unit, about an axis through the shape's centre) move it while the shutter is open
    (:mod:`lab.motion`).
    """

    type: str
    material: str | None = None
    center: Vec3 | None = None
    radius: float | None = None
    scale: float | Vec3 | None = None
    rotate: Vec3 | None = None
    to_world: tuple[tuple[float, float, float, float], ...] | None = None
    emitter: AreaLight | None = None
    layer: int | None = None
    velocity: Vec3 | None = None
    angular_velocity_deg: Vec3 | None = None

    def __post_init__(self):
        check_vector("velocity", self.velocity)
        check_vector("angular_velocity_deg", self.angular_velocity_deg)
        if self.layer is not None and self.layer < 0:
            raise UserError(f"layer = {self.layer}: input layers are numbered from 0 (the nearest)")
        if self.type not in SHAPE_TYPES:
            raise UserError(f"type = {self.type!r} is not a shape; use one of {list(SHAPE_TYPES)}")
        if self.material is None and self.emitter is None:
            raise UserError("missing material = 'NAME' (only a pure light, with emitter, may omit it)")
        if self.to_world is not None:
            placed = [k for k in ("center", "radius", "scale", "rotate") if getattr(self, k) is not None]
            if placed:
                raise UserError(f"to_world and {placed} both place the shape; keep one")
            m = np.asarray(self.to_world, dtype=np.float64)
            if m.shape != (4, 4) or not np.all(np.isfinite(m)) or abs(np.linalg.det(m[:3, :3])) < 1e-12:
                raise UserError(f"to_world = {self.to_world!r} must be an invertible 4x4 matrix (4 rows)")
        if self.radius is not None and self.type not in ("sphere", "disk"):
            raise UserError(f"radius applies to spheres and disks, not a {self.type}; use scale")
        if self.radius is not None and not self.radius > 0:
            raise UserError(f"radius = {self.radius} must be > 0")
        s = self._scale3()
        if not np.all(s > 0):
            raise UserError(f"scale = {self.scale} must be > 0 (rotate to flip a shape)")
        if self.type == "sphere" and self.to_world is None and not np.allclose(s, s[0]):
            raise UserError(f"scale = {self.scale}: Mitsuba spheres allow uniform scale only; "
                            "use radius or a single number")

    def _scale3(self) -> np.ndarray:
        s = 1.0 if self.scale is None else self.scale
        s = np.broadcast_to(np.asarray(s, dtype=np.float64), (3,))
        return s * (1.0 if self.radius is None else self.radius)

    def to_world_matrix(self) -> np.ndarray:
        """The 4x4 object-to-world matrix (row-major, float64)."""
        if self.to_world is not None:
            return np.asarray(self.to_world, dtype=np.float64)
        rx, ry, rz = np.radians(self.rotate or (0.0, 0.0, 0.0))
        cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
        r_x = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
        r_y = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
        r_z = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
        m = np.eye(4)
        m[:3, :3] = r_z @ r_y @ r_x @ np.diag(self._scale3())
        m[:3, 3] = self.center or (0.0, 0.0, 0.0)
        return m

    def to_world_at(self, t: float) -> np.ndarray:
        """The 4x4 object-to-world matrix at time t (:func:`lab.motion.rigid_motion` of the
        placement at time 0, about the shape's centre)."""
        m = self.to_world_matrix()
        return rigid_motion(m[:3, 3], self.velocity, self.angular_velocity_deg, t) @ m


@dataclass(frozen=True)
class Emitter:
    """``[[emitters]]``: ``constant`` (``radiance``), ``point`` (``position``, ``intensity`` W/sr)
    or ``directional`` (``direction`` it travels, ``irradiance`` W/m^2); each with an optional
    ``sampling_weight`` (see :class:`AreaLight`)."""

    type: str
    radiance: Vec3 | None = None
    position: Vec3 | None = None
    intensity: Vec3 | None = None
    direction: Vec3 | None = None
    irradiance: Vec3 | None = None
    sampling_weight: float = 1.0

    def __post_init__(self):
        needs = {"constant": {"radiance"}, "point": {"position", "intensity"},
                 "directional": {"direction", "irradiance"}}
        if self.type not in needs:
            raise UserError(f"type = {self.type!r} is not an emitter; use one of {sorted(needs)}")
        _only(self, needs[self.type] | {"sampling_weight"}, "type")
        _check_weight(self.sampling_weight)
        missing = sorted(k for k in needs[self.type] if getattr(self, k) is None)
        if missing:
            raise UserError(f"a {self.type} emitter needs {missing}")
        for key in ("radiance", "intensity", "irradiance"):
            _check_colour(key, getattr(self, key))
        if self.direction is not None and not np.linalg.norm(self.direction) > 0:
            raise UserError("direction = [0, 0, 0]: give the direction the light travels")


def parse_material(table: dict, where: str) -> Material:
    """``[materials.NAME]`` -> :class:`Material`; the nested checkerboard is checked on its own."""
    if isinstance(table, dict) and "checkerboard" in table:
        table = dict(table, checkerboard=from_table(Checkerboard, table["checkerboard"],
                                                    f"{where}.checkerboard"))
    return from_table(Material, table, where)


def parse_shape(table: dict, where: str, materials: dict) -> Shape:
    """One ``[[shapes]]`` entry -> :class:`Shape`, checking its material is defined."""
    if isinstance(table, dict) and "emitter" in table:
        table = dict(table, emitter=from_table(AreaLight, table["emitter"], f"{where}.emitter"))
    shape = from_table(Shape, table, where)
    if shape.material is not None and shape.material not in materials:
        bare = re.fullmatch(r"[A-Za-z0-9_-]+", shape.material)   # else TOML quotes the key (and JSON's escapes are TOML's)
        key = shape.material if bare else json.dumps(shape.material)
        raise UserError(f"{where}: material = {shape.material!r} is not defined; defined: "
                        f"{sorted(materials)}; add a [materials.{key}] table or fix the name")
    return shape

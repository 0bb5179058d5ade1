"""Scene files (TOML) -> validated, frozen dataclasses.

A scene file has the tables ``[scene]`` (name, resolution), ``[camera]``, ``[render]``,
``[materials.NAME]``, ``[[shapes]]``, ``[[emitters]]``, ``[psf.MODEL]`` and ``[precompute]``.
Every table goes through :func:`lab.config.from_table`, so unknown keys are errors that name the
file, the table and the known keys. Materials, shapes and emitters live in
:mod:`lab.scene_objects`; the camera is here because the EXR header and the PSF models need it.

Units: positions in metres, focal length and sensor width in millimetres, angles in degrees.
"""
from __future__ import annotations

import math
import tomllib
import typing
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from runtime_cl.camera.thin_lens import ThinLens

from .config import from_table, to_table
from .errors import UserError
from .optics.iris import Iris
from .scene_objects import Emitter, Material, Shape, parse_material, parse_shape, strip_none

Vec3 = tuple[float, float, float]
CAMERA_MODELS = ("pinhole", "thin")
SECTIONS = ("scene", "camera", "render", "materials", "shapes", "emitters", "psf", "precompute")


@dataclass(frozen=True)
class SceneInfo:
    """``[scene]``: a name for reports and the image size ``resolution = [width, height]`` (px)."""

    name: str
    resolution: tuple[int, int]

    def __post_init__(self):
        w, h = self.resolution
        if w <= 0 or h <= 0:
            raise UserError(f"resolution = {list(self.resolution)}: width and height must be > 0 "
                            "pixels, e.g. resolution = [1024, 1024]")


@dataclass(frozen=True)
class Camera:
    """``[camera]``: a pinhole or thin-lens camera placed with a look-at frame.

    Parameters
    ----------
    model : {"pinhole", "thin"}
    position, look_at, up : (3,) float
        Camera position and target in metres; ``up`` (default +y) fixes the roll. Mitsuba's
        look-at frame is right-handed: looking along +z with up +y, world +x is on the image's left.
    focal_length_mm : float, optional
        Required for "thin"; for "pinhole" an alternative to ``fov_deg``.
    f_number, aperture_radius_mm : float, optional
        Thin lens only, exactly one of them; the aperture radius is f / (2 N).
    focus_distance_m : float, optional
        Thin lens only: distance of the plane in focus along the optical axis (> focal length).
    sensor_width_mm : float
        Sensor width (default 36 mm); the image width spans it.
    fov_deg : float, optional
        Pinhole only: horizontal field of view in degrees (0 < fov < 180).
    aperture : dict, optional
        Thin lens only: a polygonal iris instead of the round aperture,
        ``{ blades = 6, rotation_deg = 0, rounding = 0 }`` (:class:`lab.optics.iris.Iris`); its
        circumradius is the aperture radius f / (2 N).
    """

    model: str
    position: Vec3
    look_at: Vec3
    up: Vec3 = (0.0, 1.0, 0.0)
    focal_length_mm: float | None = None
    f_number: float | None = None
    aperture_radius_mm: float | None = None
    focus_distance_m: float | None = None
    sensor_width_mm: float = 36.0
    fov_deg: float | None = None
    aperture: typing.Any = None

    def __post_init__(self):
        if self.model not in CAMERA_MODELS:
            raise UserError(f"model = {self.model!r} is not a camera model; use one of {list(CAMERA_MODELS)}")
        view = np.subtract(self.look_at, self.position)
        if not np.linalg.norm(view) > 0:
            raise UserError(f"look_at = {list(self.look_at)} equals position; look at another point")
        if np.linalg.norm(np.cross(view, self.up)) <= 1e-9 * np.linalg.norm(view) * np.linalg.norm(self.up):
            raise UserError(f"up = {list(self.up)} is zero or parallel to the view direction; "
                            "use a vector across it, e.g. up = [0, 1, 0]")
        for key in ("focal_length_mm", "f_number", "focus_distance_m", "sensor_width_mm"):
            value = getattr(self, key)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise UserError(f"{key} = {value!r} must be a finite number > 0")
        if self.aperture_radius_mm is not None and not (math.isfinite(self.aperture_radius_mm)
                                                        and self.aperture_radius_mm > 0):
            raise UserError(f"aperture_radius_mm = {self.aperture_radius_mm!r}: the aperture radius "
                            "must be > 0 mm (use model = 'pinhole' for an all-sharp image)")
        (self._check_thin if self.model == "thin" else self._check_pinhole)()
        self.iris()  # validates the aperture table

    def iris(self) -> Iris | None:
        """The polygonal iris of ``aperture``, ``None`` for a round aperture (or a pinhole)."""
        if self.aperture is not None and not isinstance(self.aperture, dict):
            raise UserError(f"aperture = {self.aperture!r}: write the iris as a table, e.g. aperture = "
                            "{ blades = 6, rotation_deg = 0 }, or remove it for a round aperture")
        return None if self.aperture is None else from_table(Iris, self.aperture, "aperture")

    def _check_thin(self):
        if self.focal_length_mm is None or self.focus_distance_m is None:
            raise UserError("a thin lens needs focal_length_mm and focus_distance_m")
        if (self.f_number is None) == (self.aperture_radius_mm is None):
            raise UserError(f"give exactly one of f_number ({self.f_number}) and aperture_radius_mm "
                            f"({self.aperture_radius_mm}); remove the other")
        if self.fov_deg is not None:
            raise UserError(f"fov_deg = {self.fov_deg}: a thin lens's field of view follows from "
                            "focal_length_mm, sensor_width_mm and focus_distance_m; remove fov_deg")
        if self.focus_distance_m * 1000.0 <= self.focal_length_mm:
            raise UserError(f"focus_distance_m = {self.focus_distance_m} is closer than the focal length "
                            f"({self.focal_length_mm} mm); use a focus distance > "
                            f"{self.focal_length_mm / 1000.0} m")

    def _check_pinhole(self):
        thin_only = [k for k in ("f_number", "aperture_radius_mm", "focus_distance_m", "aperture")
                     if getattr(self, k) is not None]
        if thin_only:
            raise UserError(f"{thin_only} describe a lens aperture; a pinhole has none: remove them "
                            "or set model = 'thin'")
        if (self.fov_deg is None) == (self.focal_length_mm is None):
            raise UserError("a pinhole needs exactly one of fov_deg and focal_length_mm "
                            "(with sensor_width_mm)")
        if self.fov_deg is not None and not 0.0 < self.fov_deg < 180.0:
            raise UserError(f"fov_deg = {self.fov_deg} must be between 0 and 180 degrees")

    def thin_lens(self) -> ThinLens | None:
        """The :class:`runtime_cl.camera.thin_lens.ThinLens` of a thin-lens camera, ``None`` for a pinhole."""
        if self.model != "thin":
            return None
        n = self.f_number
        if n is None:  # aperture radius a = f / (2 N)
            n = self.focal_length_mm / (2.0 * self.aperture_radius_mm)
        return ThinLens(focal_length_mm=self.focal_length_mm, f_number=n,
                        focus_distance_m=self.focus_distance_m, sensor_width_mm=self.sensor_width_mm)

    def fov_x_deg(self) -> float:
        """Horizontal field of view in degrees (a thin lens includes focus breathing)."""
        lens = self.thin_lens()
        if lens is not None:
            return lens.fov_x_deg()
        if self.fov_deg is not None:
            return self.fov_deg
        return math.degrees(2.0 * math.atan(self.sensor_width_mm / (2.0 * self.focal_length_mm)))

    def forward(self) -> np.ndarray:
        """Unit optical axis (world space): depth Z is measured along it."""
        view = np.subtract(self.look_at, self.position, dtype=np.float64)
        return view / np.linalg.norm(view)

    def camera_json(self) -> dict:
        """The ``splatlab.camera`` EXR header contents (DESIGN.md contract)."""
        lens = self.thin_lens()
        data = lens.to_json() if lens is not None else {"lens": "pinhole", "fov_x_deg": self.fov_x_deg()}
        if self.aperture is not None:
            data["aperture"] = self.iris().to_json()
        data["shutter"] = [0.0, 1.0]
        return data


@dataclass(frozen=True)
class RenderSettings:
    """``[render]``: samples per pixel of the reference and of the input, seed, path length."""

    reference_spp: int = 256
    input_spp: int = 64
    seed: int = 0
    max_depth: int = 8

    def __post_init__(self):
        for key in ("reference_spp", "input_spp", "max_depth"):
            if getattr(self, key) < 1:
                raise UserError(f"{key} = {getattr(self, key)} must be >= 1")
        if not 0 <= self.seed < 2**31:
            raise UserError(f"seed = {self.seed} must be in [0, 2^31)")


@dataclass(frozen=True)
class Scene:
    """A validated scene file; ``source`` is the file it came from (messages only, not compared)."""

    source: str = field(compare=False)
    info: SceneInfo
    camera: Camera
    render: RenderSettings
    materials: dict[str, Material]
    shapes: tuple[Shape, ...]
    emitters: tuple[Emitter, ...]
    psf: dict[str, dict]
    precompute: dict

    @property
    def name(self) -> str:
        return self.info.name

    @property
    def width(self) -> int:
        return self.info.resolution[0]

    @property
    def height(self) -> int:
        return self.info.resolution[1]

    def input_layers(self) -> list[list[int]]:
        """Shape indices per layer of the layered labelled input, nearest first; empty when no
        shape has a ``layer`` key. The last layer holds the shapes without one (and the sky)."""
        tagged = sorted({s.layer for s in self.shapes if s.layer is not None})
        if not tagged:
            return []
        return [[i for i, s in enumerate(self.shapes) if s.layer == k] for k in tagged] + \
            [[i for i, s in enumerate(self.shapes) if s.layer is None]]

    def to_dict(self) -> dict:
        """Canonical, JSON-serialisable contents (no file name; ``None`` dropped) for hashing.

        ``parse_scene(scene.to_dict(), ...)`` gives back an equal scene.
        """
        return strip_none({
            "scene": to_table(self.info), "camera": to_table(self.camera),
            "render": to_table(self.render),
            "materials": {k: to_table(m) for k, m in sorted(self.materials.items())},
            "shapes": [to_table(s) for s in self.shapes],
            "emitters": [to_table(e) for e in self.emitters],
            "psf": {k: dict(v) for k, v in sorted(self.psf.items())}, "precompute": dict(self.precompute),
        })


def _table(data: dict, key: str, source: str, kind=dict, default=None):
    value = data.get(key, default)
    if not isinstance(value, kind):
        shape = f"[{key}]" if kind is dict else f"[[{key}]]"
        raise UserError(f"{source}: {key} must be written as {shape} table(s), got {value!r}")
    return value


def parse_scene(data: dict, source: str = "<scene>") -> Scene:
    """Validate a scene given as a dict (parsed TOML, or :meth:`Scene.to_dict`).

    Parameters
    ----------
    data : dict
        Tables as in a scene file.
    source : str
        Names the scene in error messages (the file path for :func:`load_scene`).

    Raises
    ------
    UserError
        Unknown tables or keys, wrong types, bad values, undefined material names.
    """
    unknown = sorted(set(data) - set(SECTIONS))
    if unknown:
        raise UserError(f"{source}: unknown table(s) {unknown}; known tables are {list(SECTIONS)}")
    for key in ("scene", "camera"):
        if key not in data:
            raise UserError(f"{source}: missing the [{key}] table")
    info = from_table(SceneInfo, _table(data, "scene", source), f"{source} [scene]")
    camera = from_table(Camera, _table(data, "camera", source), f"{source} [camera]")
    render = from_table(RenderSettings, _table(data, "render", source, default={}), f"{source} [render]")
    materials = {name: parse_material(table, f"{source} [materials.{name}]")
                 for name, table in _table(data, "materials", source, default={}).items()}
    shapes = tuple(parse_shape(t, f"{source} [[shapes]] #{i + 1}", materials)
                   for i, t in enumerate(_table(data, "shapes", source, list, [])))
    emitters = tuple(from_table(Emitter, t, f"{source} [[emitters]] #{i + 1}")
                     for i, t in enumerate(_table(data, "emitters", source, list, [])))
    psf = _table(data, "psf", source, default={})
    for model, table in psf.items():
        if not isinstance(table, dict):
            raise UserError(f"{source}: psf.{model} must be a [psf.{model}] table, got {table!r}")
    if not shapes and not emitters:
        raise UserError(f"{source}: the scene is empty; add [[shapes]] or [[emitters]]")
    layers = sorted({s.layer for s in shapes if s.layer is not None})
    if layers != list(range(len(layers))):
        raise UserError(f"{source}: [[shapes]] use layer = {layers}; number the input layers 0, 1, ... "
                        "from the nearest without gaps (untagged shapes form the last layer)")
    return Scene(source=source, info=info, camera=camera, render=render, materials=materials,
                 shapes=shapes, emitters=emitters, psf={k: dict(v) for k, v in psf.items()},
                 precompute=dict(_table(data, "precompute", source, default={})))


def _read_toml(path) -> dict:
    path = Path(path)
    try:
        with path.open("rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise UserError(f"{path}: no such scene file; check the path (scenes live in scenes/)") from None
    except tomllib.TOMLDecodeError as exc:
        raise UserError(f"{path}: not valid TOML ({exc}); fix the syntax there") from None


def load_scene(path) -> Scene:
    """Read and validate a scene file.

    Parameters
    ----------
    path : str or Path
        A TOML scene file, e.g. ``scenes/demo.toml``.

    Returns
    -------
    Scene

    Raises
    ------
    UserError
        Missing file, bad TOML, or any validation error; the message names the file, the table
        and the key.
    """
    return parse_scene(_read_toml(path), str(path))


def load_camera(path) -> Camera:
    """The ``[camera]`` table of a TOML file, for ``--camera FILE.toml``.

    Parameters
    ----------
    path : str or Path
        A scene file or a file holding only a ``[camera]`` table (other tables are ignored).

    Returns
    -------
    Camera
        Use ``load_camera(path).camera_json()`` as the EXR camera override.
    """
    data = _read_toml(path)
    if "camera" not in data:
        raise UserError(f"{path}: no [camera] table; a --camera file needs one (see scenes/demo.toml)")
    return from_table(Camera, _table(data, "camera", str(path)), f"{path} [camera]")

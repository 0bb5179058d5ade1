"""Camera models: the registry (by the ``[camera]`` table's ``model``) and the base class.

A camera model is a frozen dataclass of its ``[camera]`` keys, subclassing :class:`Camera` (which
holds the keys every camera has: the look-at frame and the sensor width), registered with
:func:`register_camera`. It declares, in its one module:

- its scene keys: its fields, checked in :meth:`Camera.check` (and :meth:`Camera.parse` for
  messages about keys it does not take);
- its runtime twin: ``runtime``, the :mod:`runtime_cl.camera` class registered under the same
  name as the model, which is also the header's ``"lens"``; :meth:`Camera.runtime_camera` builds it;
- its EXR header: :meth:`Camera.camera_json`, and :meth:`Camera.check_header` for what the lab
  checks in a header beyond the twin's ``from_json``;
- its plan rule: :meth:`Camera.plan` (see :func:`lab.plan.make_plan`);
- its Mitsuba sensor: :meth:`Camera.mitsuba_sensor`.
"""
from __future__ import annotations

import abc
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from runtime_cl.camera import from_header

from ..config import from_table
from ..errors import UserError
from ..motion import check_vector
from runtime_cl.registry import Registry

__all__ = ["Camera", "Vec3", "camera_names", "get_camera", "header_camera", "motion_plan", "parse_camera",
           "register_camera"]

Vec3 = tuple[float, float, float]

_CAMERAS = Registry("camera model")
register_camera = _CAMERAS.register
camera_names = _CAMERAS.names
get_camera = _CAMERAS.get
LENS_RAYS = 100    # lens rays per pixel of the layered pass when [render] lens_rays is not given


def check_focus_keys(table: dict, where: str) -> None:
    """One way to focus a lens camera: a distance, a pixel, or >= 3 pixels (which set the tilt)."""
    given = [k for k in ("focus_distance_m", "focus_point", "focus_points") if k in table]
    if len(given) > 1:
        raise UserError(f"{where}: {given}: give one way to focus (a distance, a pixel, or >= 3 pixels for a "
                        "tilted focal plane); remove the others")
    if "focus_points" in table and "sensor_tilt_deg" in table:
        raise UserError(f"{where}: focus_points and sensor_tilt_deg: the focus points set the tilt; remove "
                        "sensor_tilt_deg")


def check_focus_pixels(focus_point, focus_points) -> None:
    """Focus pixels are [column, row] from the top left; a focal plane needs >= 3 of them."""
    for p in ([focus_point] if focus_point is not None else []) + list(focus_points or ()):
        if min(p) < 0:
            raise UserError(f"focus pixel {list(p)}: pixels are [column, row] counted from 0 at the top left")
    if focus_points is not None and len(focus_points) < 3:
        raise UserError(f"focus_points = {[list(p) for p in focus_points]}: a focal plane needs >= 3 "
                        "points; give more, or one focus_point = [x, y]")


def with_layered_pass(rule: dict, scene) -> dict:
    """``rule`` plus, with ``[render] peel_layers``, LES10's lens rays through the umbra-peeled
    layers of the input: the ``layered`` pass with ``[render] lens_rays`` rays."""
    r = scene.render
    if r.peel_layers is not None:
        rule["runtime_passes"] += ("layered",)
        rule["pass_runs"] = {**rule.get("pass_runs", {}),
                             "layered": ("layered", {"rays": r.lens_rays or LENS_RAYS, "layered_input": True})}
    return rule


@dataclass(frozen=True)
class Camera(abc.ABC):
    """``[camera]``: a camera placed with a look-at frame; subclasses add their model's keys.

    Parameters
    ----------
    model : str
        The registered name of the subclass, e.g. ``"thin"``.
    position, look_at, up : (3,) float
        Camera position and target in metres; ``up`` (default +y) fixes the roll. Mitsuba's
        look-at frame is right-handed: looking along +z with up +y, world +x is on the image's left.
    sensor_width_mm : float
        Sensor width (default 36 mm); the image width spans it.
    shutter : (float, float)
        Shutter open and close times (default [0, 1]; :mod:`lab.motion` says what moves).
    velocity : (3,) float, optional
        Linear camera motion in metres per time unit (the view direction stays).
    """

    name: ClassVar[str]
    runtime: ClassVar[type]
    model: str
    position: Vec3
    look_at: Vec3
    up: Vec3 = (0.0, 1.0, 0.0)
    sensor_width_mm: float = 36.0
    shutter: tuple[float, float] = (0.0, 1.0)
    velocity: Vec3 | None = None

    def __post_init__(self):
        if self.model != self.name:
            raise ValueError(f"model = {self.model!r}: a {type(self).__name__} is model {self.name!r}")
        for key in ("position", "look_at", "up", "velocity"):
            check_vector(key, getattr(self, key))
        if not (all(math.isfinite(t) for t in self.shutter) and self.shutter[0] <= self.shutter[1]):
            raise UserError(f"shutter = {list(self.shutter)}: give [open, close] as finite times with "
                            "open <= close, e.g. shutter = [0, 1]")
        view = np.subtract(self.look_at, self.position)
        if not np.linalg.norm(view) > 0:
            raise UserError(f"look_at = {list(self.look_at)} equals position; look at another point")
        if np.linalg.norm(np.cross(view, self.up)) <= 1e-9 * np.linalg.norm(view) * np.linalg.norm(self.up):
            raise UserError(f"up = {list(self.up)} is zero or parallel to the view direction; "
                            "use a vector across it, e.g. up = [0, 1, 0]")
        self.check()

    def check_positive(self, *keys: str) -> None:
        """UserError unless each of ``keys`` is None or a finite number > 0."""
        for key in keys:
            value = getattr(self, key)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise UserError(f"{key} = {value!r} must be a finite number > 0")

    @classmethod
    def parse(cls, table: dict, where: str) -> "Camera":
        """The camera of a ``[camera]`` table; ``where`` names the file and table in errors.

        Models override it to explain keys that belong to another model before
        :func:`lab.config.from_table` rejects them as unknown.
        """
        return from_table(cls, table, where)

    @abc.abstractmethod
    def check(self) -> None:
        """UserError unless the model's keys describe a camera (called on construction)."""

    @abc.abstractmethod
    def runtime_camera(self):
        """The runtime twin (an instance of ``runtime``) with this camera's parameters."""

    def thin_lens(self):
        """The :class:`runtime_cl.camera.thin_lens.ThinLens` that models this camera's defocus
        (what the thin-lens PSF models and CoC ranges use); ``None`` for a camera without defocus."""
        return None

    def fov_x_deg(self) -> float:
        """Horizontal field of view in degrees (a thin lens includes focus breathing)."""
        return self.runtime_camera().fov_x_deg()

    def position_at(self, t: float) -> np.ndarray:
        """The camera position (metres) at time t: ``position + velocity * t``."""
        v = np.zeros(3) if self.velocity is None else np.asarray(self.velocity, dtype=np.float64)
        return np.asarray(self.position, dtype=np.float64) + v * t

    def header_shutter(self) -> list[float]:
        """The header's ``"shutter"``: [open, close] as the scene gives them."""
        return [float(self.shutter[0]), float(self.shutter[1])]

    def forward(self) -> np.ndarray:
        """Unit optical axis (world space): depth Z is measured along it."""
        view = np.subtract(self.look_at, self.position, dtype=np.float64)
        return view / np.linalg.norm(view)

    @abc.abstractmethod
    def camera_json(self) -> dict:
        """The ``splatlab.camera`` EXR header contents (DESIGN.md contract)."""

    @classmethod
    def check_header(cls, data: dict, source: str) -> None:
        """UserError naming ``source`` for header entries the runtime twin does not check; by
        default there are none."""

    @abc.abstractmethod
    def plan(self, scene) -> dict:
        """This camera's part of :func:`lab.plan.make_plan` for ``scene`` (a :class:`lab.scene.Scene`).

        Returns
        -------
        dict
            ``dof`` and ``aperture`` (str: the effects), ``psf_models`` (tuple of str),
            ``references`` (tuple of :class:`lab.plan.Step`), ``runtime_passes`` (tuple of str
            labels), optionally ``pass_runs`` (label -> (registered runtime pass, options), for
            labels that are not a pass's own name), ``effects`` (effect -> description, merged
            over the plan's defaults, e.g. ``{"chromatic": "sellmeier (...)"}``) and ``skipped``
            (tuple of Step).
        """

    @abc.abstractmethod
    def mitsuba_sensor(self, sensor: dict) -> dict:
        """This camera's Mitsuba sensor dict, from ``sensor``: a ``perspective`` sensor with the
        same view (look-at frame, horizontal fov), film and sampler (not modified)."""


def motion_plan(scene, dof: str, aperture: str = "circle") -> dict:
    """The plan rule of a moving scene seen through a thin lens or a pinhole (``dof`` describes
    it; ``aperture`` the lens's aperture): LSR18's Combined PSFs (defocus + linear motion: the
    aperture swept along the motion) through the spreadlet passes, against Mitsuba sub-frames
    through the camera's own sensor (:mod:`lab.reference.motion`)."""
    from ..plan import Step

    r = scene.render
    sensor = "" if aperture == "circle" else f" through the thin lens with the {aperture} aperture " \
                                              "(lab.reference.aperture_lens)"
    return {
        "dof": dof,
        "aperture": aperture if dof != "none" else "none (pinhole)",
        "psf_models": ("combined",),
        "references": (Step("mitsuba_motion", f"Mitsuba sub-frames over the shutter{sensor} (one per pixel of "
                                              f"the largest motion), {r.reference_spp} spp in all, max depth "
                                              f"{r.max_depth}"),),
        "runtime_passes": ("spreadlets", "splat", "filter"),
        "skipped": (),
    }


def parse_camera(table: dict, where: str) -> Camera:
    """Validate a ``[camera]`` table by its ``model``.

    Parameters
    ----------
    table : dict
        The table as parsed from TOML (or :meth:`lab.scene.Scene.to_dict`).
    where : str
        The file and table, e.g. ``"scenes/demo.toml [camera]"``, for error messages.

    Raises
    ------
    UserError
        A missing or unknown model (the message lists the models), unknown keys (it lists the
        model's keys) or bad values.
    """
    if "model" not in table:
        raise UserError(f"{where}: missing key(s) ['model']")
    model = table["model"]
    if not isinstance(model, str):
        raise UserError(f"{where}: model = {model!r} must be a string")
    if model not in camera_names():
        raise UserError(f"{where}: model = {model!r} is not a camera model; use one of {camera_names()}")
    return get_camera(model).parse(table, where)


def header_camera(data, source: str):
    """The runtime camera of a ``splatlab.camera`` JSON object, checked by its runtime twin
    (:func:`runtime_cl.camera.from_header`) and by its lab model's :meth:`Camera.check_header`.

    Raises
    ------
    UserError
        Naming ``source``: not an object, an unknown lens (listing the known ones), bad entries.
    """
    camera = from_header(data, source)
    get_camera(camera.lens).check_header(data, source)
    return camera

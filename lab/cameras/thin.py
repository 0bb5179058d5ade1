"""The thin lens, round, with a polygonal iris or a stylized aperture: ``[camera] model = "thin"``.

- Scene keys: ``focal_length_mm``, exactly one of ``f_number`` and ``aperture_radius_mm``
  (a = f / 2N), ``focus_distance_m``, and ``aperture``: ``{ blades, rotation_deg, rounding }``
  for a polygonal iris (:class:`lab.optics.iris.Iris`) or ``{ shape = "star" | "heart" |
  "image", path }`` for a stylized one (:class:`lab.cameras.shaped_aperture.ShapedAperture`);
  either's circumradius is the aperture radius. Instead of ``focus_distance_m``: ``focus_point =
  [x, y]`` (focus on what that pixel sees) or ``focus_points = [[x, y], ...]`` (>= 3: the sensor
  tilts to focus their least-squares plane, Scheimpflug), resolved by :mod:`lab.focus`;
  ``sensor_tilt_deg = [tx, ty]`` tilts the sensor by hand; ``focal_surface`` (with ``focus_distance_m``)
  focuses each pixel on an expressive surface (:mod:`lab.focal_constraints`).
- Runtime twin: :class:`runtime_cl.camera.thin_lens.ThinLens` (the aperture's shape does not
  change its CoC).
- Header: the twin's JSON, the iris or the shape as ``"aperture"``, the shutter.
- Plan: a round aperture runs the spreadlet passes on a ``simple_lens`` database against
  Mitsuba's ``thinlens`` (a moving scene: a ``combined`` database against sub-frames, see
  :func:`lab.cameras.base.motion_plan`; a tilted sensor renders through :mod:`lab.reference.
  tilted_lens`), and with ``[render] peel_layers`` also LES10's lens rays
  through the umbra-peeled layers (the ``layered`` pass); a focal surface runs the same passes with no
  reference (step ``none``: nothing physical has that focus); an iris runs MHU21's exact polygon passes (no PSF database), a shape
  the spreadlet passes on a ``stylized`` database, both against the same lens through that
  aperture (:mod:`lab.reference.aperture_lens`).
"""
from __future__ import annotations

import math
import typing
from dataclasses import dataclass

from runtime_cl.camera.focal_surface import scheimpflug_tilt
from runtime_cl.camera.thin_lens import ThinLens

from ..errors import UserError
from ..focal_constraints import check_table, unresolved
from ..motion import scene_moves
from ..plan import NO_REFERENCE, Step
from .base import Camera, check_focus_keys, check_focus_pixels, motion_plan, register_camera, with_layered_pass
from .shaped_aperture import ApertureTable

DEPTH_LAYERS = 8   # global depth layers of the layered polygon passes (LSR18 section 6)


@register_camera("thin")
@dataclass(frozen=True)
class ThinCamera(ApertureTable, Camera):
    """A thin-lens camera (the look-at keys of :class:`lab.cameras.base.Camera` too).

    Parameters
    ----------
    focal_length_mm : float
        Focal length f in millimetres.
    f_number, aperture_radius_mm : float
        Exactly one of them; the aperture radius is f / (2 N).
    focus_distance_m : float
        Distance of the plane in focus along the optical axis (> focal length).
    aperture : dict, optional
        Instead of the round aperture, a polygonal iris ``{ blades = 6, rotation_deg = 0,
        rounding = 0 }`` (:class:`lab.optics.iris.Iris`) or a stylized shape ``{ shape = "star" }``
        (:class:`lab.cameras.shaped_aperture.ShapedAperture`); its circumradius is the aperture radius.
    focus_point : (int, int), optional
        Instead of ``focus_distance_m``: the pixel (column, row from the top) whose depth is in focus.
    focus_points : list of (int, int), optional
        Instead of ``focus_distance_m``: >= 3 pixels; the sensor tilts to focus their plane.
    sensor_tilt_deg : (float, float), default (0, 0)
        Sensor tilt (Scheimpflug) about the image's y and x axes, by hand or from ``focus_points``.
    focal_surface : dict, optional
        Expressive focus (LES10 5.2): ``{ points = [[x, y, depth_m], ...], blur = [[x, y, r_px], ...],
        beta = 2, dof_extent = 1 }`` (:mod:`lab.focal_constraints`; ``blur`` is resolved from the depths
        its pixels see). No physical reference: the plan's reference step is ``none`` and the report
        shows the methods unscored.
    """

    runtime = ThinLens
    focal_length_mm: float | None = None
    f_number: float | None = None
    aperture_radius_mm: float | None = None
    focus_distance_m: float | None = None
    aperture: typing.Any = None
    focus_point: tuple[int, int] | None = None
    focus_points: tuple[tuple[int, int], ...] | None = None
    sensor_tilt_deg: tuple[float, float] = (0.0, 0.0)
    focal_surface: dict | None = None

    @classmethod
    def parse(cls, table: dict, where: str) -> "ThinCamera":
        check_focus_keys(table, where)
        if "fov_deg" in table:
            fov = table["fov_deg"]
            fov = float(fov) if type(fov) is int else fov   # shown as from_table would convert it
            raise UserError(f"{where}: fov_deg = {fov}: a thin lens's field of view follows from "
                            "focal_length_mm, sensor_width_mm and focus_distance_m; remove fov_deg")
        return super().parse(table, where)

    def check(self) -> None:
        self.check_positive("focal_length_mm", "f_number", "focus_distance_m", "sensor_width_mm")
        if self.aperture_radius_mm is not None and not (math.isfinite(self.aperture_radius_mm)
                                                        and self.aperture_radius_mm > 0):
            raise UserError(f"aperture_radius_mm = {self.aperture_radius_mm!r}: the aperture radius "
                            "must be > 0 mm (use model = 'pinhole' for an all-sharp image)")
        if self.focal_length_mm is None or (self.focus_distance_m is None and self.focus_point is None
                                            and self.focus_points is None):
            raise UserError("a thin lens needs focal_length_mm and focus_distance_m (or focus_point = [x, y])")
        check_focus_pixels(self.focus_point, self.focus_points)
        if self.focal_surface is not None:
            object.__setattr__(self, "focal_surface", check_table(self.focal_surface, ""))
            if self.focus_distance_m is None:
                raise UserError("focal_surface: give focus_distance_m too (it sets the lens's image distance, so the "
                                "field of view)")
            if self.sensor_tilt_deg != (0.0, 0.0):
                raise UserError(f"sensor_tilt_deg = {list(self.sensor_tilt_deg)} with a focal_surface: the surface "
                                "sets the focus of every pixel; remove one of them")
        tilt = self.sensor_tilt_deg != (0.0, 0.0) or self.focus_points is not None
        if tilt and self.aperture is not None:
            raise UserError(f"aperture = {self.aperture!r} with a tilted sensor: the tilt-shift reference traces a "
                            "round aperture; remove the aperture table, or the tilt")
        if (self.f_number is None) == (self.aperture_radius_mm is None):
            raise UserError(f"give exactly one of f_number ({self.f_number}) and aperture_radius_mm "
                            f"({self.aperture_radius_mm}); remove the other")
        if self.focus_distance_m is not None and self.focus_distance_m * 1000.0 <= self.focal_length_mm:
            raise UserError(f"focus_distance_m = {self.focus_distance_m} is closer than the focal length "
                            f"({self.focal_length_mm} mm); use a focus distance > "
                            f"{self.focal_length_mm / 1000.0} m")
        self.iris(), self.shaped()  # validates the aperture table

    def plane_focus(self, points, normal, offset: float, width_px: int) -> tuple:
        """(focus distance m, sensor tilt deg) that focus the plane ``normal . X = offset`` (camera
        space, m): the lens equation (:func:`runtime_cl.camera.focal_surface.scheimpflug_tilt`)."""
        return scheimpflug_tilt(normal, offset, self.focal_length_mm / 1000.0)

    def runtime_camera(self) -> ThinLens:
        n = self.f_number
        if n is None:  # aperture radius a = f / (2 N)
            n = self.focal_length_mm / (2.0 * self.aperture_radius_mm)
        if self.focus_distance_m is None:
            raise UserError("focus_point(s): the focus is not resolved yet; load the scene with "
                            "lab.pipeline.load_scene_and_plan (lab.focus.resolve_focus)")
        if unresolved(self.focal_surface):
            raise UserError("focal_surface blur: the constraints are not resolved yet; load the scene with "
                            "lab.pipeline.load_scene_and_plan (lab.focus.resolve_focus)")
        pixels = [self.focus_point] if self.focus_point is not None else list(self.focus_points or ())
        return ThinLens(focal_length_mm=self.focal_length_mm, f_number=n,
                        focus_distance_m=self.focus_distance_m, sensor_width_mm=self.sensor_width_mm,
                        sensor_tilt_deg=self.sensor_tilt_deg, focus_points=tuple(tuple(p) for p in pixels),
                        focal_surface=self.focal_surface)

    def thin_lens(self) -> ThinLens:
        return self.runtime_camera()

    def camera_json(self) -> dict:
        return {**self.runtime_camera().to_json(), **self.header_aperture(), "shutter": self.header_shutter()}

    @classmethod
    def check_header(cls, data: dict, source: str) -> None:
        """The iris or the shape (``"aperture"``), which :meth:`ThinLens.from_json` passes on unchecked."""
        cls.check_header_aperture(data, source)

    def plan(self, scene) -> dict:
        if scene.medium is not None:
            raise UserError(f"{scene.source} [medium]: a medium with a thin lens; no PSF model combines "
                            "defocus and scattering (LSR18's Volume PSFs are a pinhole's): set [camera] "
                            "model = \"pinhole\" for fog, or remove [medium]")
        rule = self._plan(scene)
        if self.focal_surface is None:
            return rule
        # LES10 5.2: no lens has this focus, so nothing renders a reference to score against
        n = len(self.focal_surface["points"])
        return dict(rule, references=(Step(NO_REFERENCE, f"expressive focus (LES10 5.2, a focal surface from {n} "
                                                         "constraints) has no physical reference: the methods' "
                                                         "images are shown unscored"),),
                    skipped=tuple(rule["skipped"]) + (Step(f"scores against {rule['references'][0].name}",
                                                           "no lens focuses on an expressive surface, so a path "
                                                           "trace of the scene is no reference for it; its "
                                                           "properties are tested instead (tests/lab/"
                                                           "test_expressive_focus.py)"),))

    def _plan(self, scene) -> dict:
        if scene_moves(scene):
            if self.runtime_camera().tilted or self.focal_surface is not None:
                raise UserError(f"{scene.source} [camera]: a tilted sensor or a focal_surface in a moving scene; the "
                                "motion model traces an untilted lens: remove the velocities, or the tilt")
            return motion_plan(scene, self._dof(), self.aperture_text())
        if self.iris() is not None:
            return self._plan_iris(scene)
        if self.shaped() is not None:
            return self._plan_shaped(scene)
        r = scene.render
        rule = {
            "dof": self._dof(),
            "aperture": "circle",
            "psf_models": ("simple_lens",),
            "references": (Step("mitsuba_thinlens", f"Mitsuba path trace through the thin lens"
                                                    f"{self._tilt_note()}, {r.reference_spp} spp, max depth "
                                                    f"{r.max_depth}"),),
            "runtime_passes": ("spreadlets", "splat", "filter"),
            "skipped": (),
        }
        return with_layered_pass(rule, scene)

    def _tilt_note(self) -> str:
        return " and its tilted sensor (lab.reference.tilted_lens)" if self.runtime_camera().tilted else ""

    def _dof(self) -> str:
        lens = self.runtime_camera()
        tilt = f", sensor tilt {lens.sensor_tilt_deg[0]:.3g}/{lens.sensor_tilt_deg[1]:.3g} deg" if lens.tilted else ""
        if lens.focal_surface is not None:
            surface = lens.surface()
            tilt = (f", expressive focal surface from {len(surface['points'])} constraints, DOF extent "
                    f"{surface['dof_extent']:g}")
        return (f"thin ({lens.focal_length_mm:g} mm f/{lens.f_number:.3g}, "
                f"focus {lens.focus_distance_m:g} m{tilt}, sensor {lens.sensor_width_mm:g} mm)")

    def _plan_iris(self, scene) -> dict:
        iris, r = self.iris(), scene.render
        passes = ("polygon", "polygon_layers") + (("polygon_layered_input",) if scene.input_layers() else ())
        skipped = [Step("PSF precompute and sparsify", "MHU21's flat polygon kernel is exact: no PSF database"),
                   Step("spreadlets, splat, filter", "their database traces the round aperture; the iris "
                                                     "runs through the polygon passes")]
        if not iris.point_symmetric:
            skipped.append(Step("180-degree turn of the bokeh in front of the focus plane",
                                f"the polygon runtime draws the upright iris everywhere ({iris.blades} blades "
                                "are not point-symmetric)"))
        if not scene.input_layers():
            skipped.append(Step("polygon_layered_input", "no [[shapes]] has a layer key, so there is no "
                                                         "layered input"))
        return {
            "dof": self._dof(),
            "aperture": self.aperture_text(),
            "psf_models": (),
            "references": (Step("mitsuba_polygon_lens", f"Mitsuba path trace through the thin lens with the "
                                                        f"{iris.blades}-blade iris (lab.reference.aperture_lens), "
                                                        f"{r.reference_spp} spp, max depth {r.max_depth}"),),
            "runtime_passes": passes,
            "pass_runs": {"polygon_layers": ("polygon", {"layers": DEPTH_LAYERS}),
                          "polygon_layered_input": ("polygon", {"layers": DEPTH_LAYERS, "layered_input": True})},
            "skipped": tuple(skipped),
        }

    def _plan_shaped(self, scene) -> dict:
        shape, r = self.shaped(), scene.render
        return {
            "dof": self._dof(),
            "aperture": self.aperture_text(),
            "psf_models": ("stylized",),
            "references": (Step("mitsuba_aperture_lens", f"Mitsuba path trace through the thin lens with "
                                                         f"the {shape.shape} aperture (lab.reference."
                                                         f"aperture_lens), {r.reference_spp} spp, max depth "
                                                         f"{r.max_depth}"),),
            "runtime_passes": ("spreadlets", "splat", "filter"),
            "skipped": (Step("polygon passes", f"MHU21's kernels are polygons; a {shape.shape} aperture "
                                               "runs through the stylized database"),),
        }

    def mitsuba_sensor(self, sensor: dict) -> dict:
        """Mitsuba's ``thinlens`` (aperture radius f / 2N, planar focus distance), or with an iris
        or a stylized shape the Python sensor of :mod:`lab.reference.aperture_lens`."""
        lens, aperture = self.runtime_camera(), self.aperture_params()
        out = dict(sensor, type="thinlens", aperture_radius=lens.aperture_radius_m,
                   focus_distance=lens.focus_distance_m)
        if lens.tilted:   # Scheimpflug: the Python sensor of lab.reference.tilted_lens
            from ..reference.tilted_lens import register

            del out["fov_axis"]   # the plugin's fov is horizontal
            return dict(out, type=register(), focal_length=lens.focal_length_mm / 1000.0,
                        tilt_x_deg=lens.sensor_tilt_deg[0], tilt_y_deg=lens.sensor_tilt_deg[1])
        if aperture is not None:
            from ..reference.aperture_lens import register

            del out["fov_axis"]   # the plugin's fov is horizontal
            out["type"] = register()
            out.update(aperture)
        return out

"""The thick lens: ``[camera] model = "thick"``, a lens of spherical surfaces and Sellmeier glass.

- Scene keys: ``lens = "singlet"`` (a built-in lens, :mod:`lab.optics.lenses`) or ``surfaces =
  [[radius_mm, thickness_mm, glass, semi_aperture_mm], ...]`` (object side first, radius 0 =
  the aperture stop, ``inf`` = a flat face; :class:`lab.optics.thick_lens.Surface`), and
  ``focus_distance_m`` (metres from the entrance pupil); the sensor moves to the plane where a
  point at that distance has the smallest spot (:class:`lab.optics.lens_camera.ThickLensCamera`).
  Tilt-shift: ``focus_points = [[x, y], ...]`` (>= 3) tilt the sensor to focus their least-squares
  plane (the tilt traced through the lens, :mod:`lab.optics.tilt`), or ``sensor_tilt_deg`` by hand;
  a tilted sensor runs the layered pass only, against the tilted Mitsuba sensor. ``aperture =
  { blades = 6 }`` or ``{ shape = "star" }`` shapes the stop (:mod:`lab.optics.stop_shape`): the
  spreadlet passes and the reference trace it; the layered pass, a stochastic input and a tilted
  sensor know the round stop only, and refuse it.
  ``position`` is the entrance pupil's centre: depths are measured from it, and the labelled
  pixels are a pinhole's there with the paraxial chief-ray scale.
- Runtime twin: :class:`runtime_cl.camera.thick_lens.ThickLens`.
- Header: the surfaces, focus, sensor and the paraxial figures the runtime cannot derive
  without the glass catalog (checked against the surfaces on read, :meth:`check_header`).
- Plan: the ``physical_lens`` PSF model traced for this lens, focus and sensor, RGB at the
  camera's wavelengths (650 / 510 / 475 nm, LES10), through the spreadlet passes, against a
  Mitsuba path trace through the same lens (:mod:`lab.reference.thick_lens_sensor`), one pass
  set per channel wavelength.

Importing this module loads no Dr.Jit; building the lens (:meth:`ThickCamera.optics`) does.
"""
from __future__ import annotations

import functools
import json
import math
import typing
from dataclasses import dataclass

import numpy as np

from runtime_cl.camera.focal_surface import check_tilt, scheimpflug_tilt
from runtime_cl.camera.thick_lens import ROW, ThickLens
from runtime_cl.camera.thick_lens import surface_rows as runtime_surface_rows

from ..errors import UserError
from ..motion import scene_moves
from ..optics.glass import LINE_D_NM, get_glass
from ..optics.lenses import LENSES, lens_names
from ..plan import Step
from .base import Camera, check_focus_keys, check_focus_pixels, register_camera, with_layered_pass
from .shaped_aperture import ApertureTable

WAVELENGTHS_NM = (650.0, 510.0, 475.0)   # R, G, B (LES10)
FOCUS_WAVELENGTH_NM = LINE_D_NM          # focusing and the pinhole scale
FOCUS = "best"                           # the sensor at the smallest spot (lab.optics.lens_camera)
# Keys of the other lens models, named in the error a thick lens gives for them.
THIN_KEYS = ("focal_length_mm", "f_number", "aperture_radius_mm", "fov_deg")


@functools.lru_cache(maxsize=32)
def _focused(surfaces: tuple, focus_distance_m: float, sensor_width_mm: float, width_px: int,
             aperture: str = "null"):
    """The lens focused at ``focus_distance_m`` (a :class:`ThickLensCamera`; cached, it is immutable),
    its stop shaped by ``aperture`` (the JSON of a camera's ``aperture_params``)."""
    from ..optics.lens_camera import ThickLensCamera
    from ..optics.stop_shape import StopShape
    from ..optics.thick_lens import LensSystem

    lens = LensSystem(surfaces)
    shape = StopShape.from_params(json.loads(aperture), lens.surfaces[lens.stop].aperture_radius_mm)
    return ThickLensCamera.focused(lens, focus_distance_m, WAVELENGTHS_NM, FOCUS_WAVELENGTH_NM,
                                   width_px, sensor_width_mm, FOCUS, shape)


def surface_rows(rows, key: str = "surfaces") -> tuple:
    """``rows`` as a tuple of (float, float, str, float) (:func:`runtime_cl.camera.thick_lens.
    surface_rows`) whose glasses are in the catalog; UserError naming ``key`` and the row."""
    out = runtime_surface_rows(rows, key)
    for i, row in enumerate(out):
        try:
            get_glass(row[2])
        except UserError as exc:
            raise UserError(f"{key}[{i}]: {exc}") from None
    return out


@register_camera("thick")
@dataclass(frozen=True)
class ThickCamera(ApertureTable, Camera):
    """A thick-lens camera (the look-at keys of :class:`lab.cameras.base.Camera` too).

    Parameters
    ----------
    lens : str, optional
        A built-in lens (:data:`lab.optics.lenses.LENSES`: ``"singlet"``, ``"achromat"``).
    surfaces : list of [radius_mm, thickness_mm, glass, semi_aperture_mm], optional
        Instead of ``lens``: the prescription, object side first; the last row's thickness is 0.
    focus_distance_m : float
        Distance in focus, metres from the entrance pupil (beyond the lens's front focal point).
    focus_point : (int, int), optional
        Instead of ``focus_distance_m``: the pixel (column, row from the top) whose depth is in focus
        (:mod:`lab.focus`; the sensor moves to focus it).
    focus_points : list of (int, int), optional
        Instead of ``focus_distance_m``: >= 3 pixels; the sensor tilts to focus their least-squares
        plane, the tilt found by tracing their images through the lens (:mod:`lab.optics.tilt`).
    sensor_tilt_deg : (float, float), default (0, 0)
        The sensor's tilt: its z grows by tan(tx) per mm of sensor x and tan(ty) per mm of sensor y
        (:class:`runtime_cl.camera.thick_lens.ThickLens`); by hand or from ``focus_points``.
    aperture : dict, optional
        The stop's shape instead of its round opening: a polygonal iris ``{ blades = 6,
        rotation_deg = 0, rounding = 0 }`` or a stylized shape ``{ shape = "star" }``, its
        circumradius the stop's semi-aperture (:class:`lab.optics.stop_shape.StopShape`).
    """

    runtime = ThickLens
    lens: str | None = None
    surfaces: typing.Any = None
    focus_distance_m: float | None = None
    focus_point: tuple[int, int] | None = None
    focus_points: tuple[tuple[int, int], ...] | None = None
    sensor_tilt_deg: tuple[float, float] = (0.0, 0.0)
    aperture: typing.Any = None

    @classmethod
    def parse(cls, table: dict, where: str) -> "ThickCamera":
        check_focus_keys(table, where)
        other = [k for k in THIN_KEYS if k in table]
        if other:
            raise UserError(f"{where}: {other}: a thick lens's focal length, f-number, field of view and aperture "
                            "radius follow from its surfaces (the stop's semi-aperture); remove them, or set "
                            "model = 'thin'")
        return super().parse(table, where)

    def check(self) -> None:
        self.check_positive("focus_distance_m", "sensor_width_mm")
        if (self.lens is None) == (self.surfaces is None):
            raise UserError(f"give exactly one of lens (a built-in lens: {lens_names()}) and surfaces "
                            f"(a list of {ROW} rows); lens = {self.lens!r}, surfaces = {self.surfaces!r}")
        if self.lens is not None and self.lens not in LENSES:
            raise UserError(f"lens = {self.lens!r} is not a built-in lens; use one of {lens_names()} or give "
                            f"surfaces = [{ROW}, ...]")
        if self.surfaces is not None:
            object.__setattr__(self, "surfaces", surface_rows(self.surfaces))
        check_focus_pixels(self.focus_point, self.focus_points)
        try:
            object.__setattr__(self, "sensor_tilt_deg", check_tilt(self.sensor_tilt_deg, ""))
        except UserError as exc:
            raise UserError(str(exc).strip()) from None
        self.iris(), self.shaped()   # validates the aperture table
        if self.aperture is not None and (self.sensor_tilt_deg != (0.0, 0.0) or self.focus_points is not None):
            raise UserError(f"aperture = {self.aperture!r} with a tilted sensor: the tilted thick lens runs the "
                            "layered pass alone, which traces the round stop; remove the aperture, or the tilt")
        if self.focus_distance_m is None:
            if self.focus_point is not None or self.focus_points is not None:   # resolved by lab.focus
                return
            raise UserError("a thick lens needs focus_distance_m (metres from its entrance pupil) or focus_point = [x, y]")
        self.optics()

    def rows(self) -> tuple:
        """The lens's surface rows: the built-in lens's or ``surfaces``."""
        return LENSES[self.lens] if self.lens is not None else self.surfaces

    def _key(self) -> str:
        """The key that gave the lens, for messages."""
        return f"lens = {self.lens!r}" if self.lens is not None else "surfaces"

    def optics(self, width_px: int = 1024):
        """The lens focused on ``focus_distance_m`` with this sensor, ``width_px`` pixels across
        (:class:`lab.optics.lens_camera.ThickLensCamera`); UserError naming the key at fault."""
        from ..optics.thick_lens import LensSystem

        key = self._key()
        try:
            efl = LensSystem(self.rows()).effective_focal_length_mm(FOCUS_WAVELENGTH_NM)
        except UserError as exc:
            raise UserError(f"{key}: {exc}") from None
        if not 0 < efl < math.inf:
            raise UserError(f"{key}: the lens's focal length is {efl:.4g} mm: it forms no real image, so no ray "
                            "reaches a sensor; make it converging (e.g. a bi-convex element, radii [50, -50])")
        if self.focus_distance_m is None:
            raise UserError("focus_point(s): the focus is not resolved yet; load the scene with "
                            "lab.pipeline.load_scene_and_plan (lab.focus.resolve_focus)")
        try:
            return _focused(self.rows(), self.focus_distance_m, self.sensor_width_mm, width_px,
                            json.dumps(self.aperture_params(), sort_keys=True))
        except UserError as exc:
            raise UserError(f"{key}, focus_distance_m = {self.focus_distance_m}: {exc}") from None

    def check_sensor(self, width_px: int, height_px: int, where: str) -> None:
        """UserError (naming ``where``) unless rays from every point of the sensor, up to the
        corners of a ``width_px`` x ``height_px`` image, get through the lens."""
        from ..optics.exit_pupil import ExitPupil

        half = 0.5 * math.hypot(self.sensor_width_mm, self.sensor_width_mm * height_px / width_px)
        gx, gy = (math.tan(math.radians(t)) for t in self.sensor_tilt_deg)
        shift = 0.5 * (abs(gx) * self.sensor_width_mm + abs(gy) * self.sensor_width_mm * height_px / width_px)
        try:
            ExitPupil.build(self.optics(), FOCUS_WAVELENGTH_NM, half, n_radii=16, grid=96, slopes=(gx, gy),
                            shift_mm=shift)
        except UserError as exc:
            raise UserError(f"{where} {self._key()}: {exc}") from None

    def plane_focus(self, points, normal, offset: float, width_px: int) -> tuple:
        """(focus distance m, sensor tilt deg) that focus the plane ``normal . X = offset`` through
        ``points`` ((n, 3) camera space, m, from the entrance pupil): the sensor plane through the
        points' images traced through the lens (:func:`lab.optics.tilt.sensor_plane`), its axial
        point the focus distance's image; the thin-lens checks refuse a plane along the view
        direction or through the lens first, and a tilt beyond the limit is refused."""
        from dataclasses import replace

        from ..optics.tilt import distance_for_sensor_z, sensor_plane

        lens = self.optics().lens
        focus, _ = scheimpflug_tilt(normal, offset, lens.effective_focal_length_mm(FOCUS_WAVELENGTH_NM) / 1000.0)
        cam = replace(self, focus_distance_m=focus, focus_point=None, focus_points=None,
                      sensor_tilt_deg=(0.0, 0.0)).optics(width_px)
        z0, gx, gy = sensor_plane(cam.lens, points, cam.pupil_z_mm, FOCUS_WAVELENGTH_NM)
        tilt = (math.degrees(math.atan(gx)), math.degrees(math.atan(gy)))
        return distance_for_sensor_z(lens, z0, FOCUS_WAVELENGTH_NM, FOCUS), check_tilt(tilt, "focal plane: it needs")

    def stop_radius_mm(self) -> float:
        """The aperture stop's semi-aperture."""
        return next(row[3] for row in self.rows() if row[0] == 0.0)

    def runtime_camera(self) -> ThickLens:
        if self.focus_distance_m is None:
            raise UserError("focus_point(s): the focus is not resolved yet; load the scene with "
                            "lab.pipeline.load_scene_and_plan (lab.focus.resolve_focus)")
        cam = self.optics()
        pixels = [self.focus_point] if self.focus_point is not None else list(self.focus_points or ())
        return ThickLens(surfaces=self.rows(), focus_distance_m=self.focus_distance_m, focus=FOCUS,
                         sensor_width_mm=self.sensor_width_mm,
                         focal_length_mm=cam.lens.effective_focal_length_mm(FOCUS_WAVELENGTH_NM),
                         chief_scale_mm=cam.chief_scale_mm, pupil_radius_mm=cam.pupil_radius_mm,
                         sensor_z_mm=cam.sensor_z_mm, pupil_z_mm=cam.pupil_z_mm, wavelengths_nm=WAVELENGTHS_NM,
                         indices=tuple(cam.lens.indices(w) for w in WAVELENGTHS_NM),
                         focus_points=tuple(tuple(p) for p in pixels), sensor_tilt_deg=self.sensor_tilt_deg)

    def camera_json(self) -> dict:
        return {**self.runtime_camera().to_json(), **self.header_aperture(), "shutter": self.header_shutter()}

    @classmethod
    def check_header(cls, data: dict, source: str) -> None:
        """The paraxial figures against the surfaces they were derived from (a header edited by
        hand, or written for another glass catalog, would place the pixels wrongly)."""
        cls.check_header_aperture(data, source)
        rows = surface_rows(data["surfaces"], f"{source} surfaces")
        if data["focus"] != FOCUS:
            raise UserError(f"{source} focus = {data['focus']!r}: the lab's thick lens focuses {FOCUS!r}")
        try:
            camera = cls(model="thick", position=(0.0, 0.0, 0.0), look_at=(0.0, 0.0, 1.0), surfaces=rows,
                         focus_distance_m=data["focus_distance_m"], sensor_width_mm=data["sensor_width_mm"],
                         sensor_tilt_deg=tuple(data.get("sensor_tilt_deg", (0.0, 0.0))))
        except UserError as exc:
            raise UserError(f"{source}: {exc}") from None
        derived = camera.runtime_camera().to_json()
        for key in ("focal_length_mm", "chief_scale_mm", "pupil_radius_mm", "sensor_z_mm", "pupil_z_mm", "wavelengths_nm",
                    "indices"):
            if not np.allclose(data[key], derived[key], rtol=1e-6, atol=0.0):
                raise UserError(f"{source} {key} = {data[key]!r}, but the header's surfaces give {derived[key]!r}; "
                                "write the header from the scene's [camera] (splatlab reference) or fix the surfaces")

    def plan(self, scene) -> dict:
        if scene.medium is not None:
            raise UserError(f"{scene.source} [medium]: a medium with a thick lens; no PSF model combines the lens "
                            "and scattering (LSR18's Volume PSFs are a pinhole's): set [camera] model = \"pinhole\" "
                            "for fog, or remove [medium]")
        if scene_moves(scene):
            raise UserError(f"{scene.source} [camera] model = \"thick\": the scene moves, and no PSF model combines "
                            "the thick lens and motion (physical_lens is a still lens): remove the velocities, or set "
                            "model = \"thin\" for motion blur")
        self.check_sensor(scene.width, scene.height, f"{scene.source} [camera]")
        r = scene.render
        if self.runtime_camera().tilted:
            return self._plan_tilted(scene)
        if self.aperture is not None and r.peel_layers is not None:
            raise UserError(f"{scene.source} [camera] aperture = {self.aperture!r} with [render] peel_layers: the "
                            "layered pass traces the thick lens's round stop; remove peel_layers (the spreadlet "
                            "passes trace the shaped stop), or the aperture")
        nm = "/".join(f"{w:g}" for w in WAVELENGTHS_NM)
        stop = "round stop" if self.aperture is None else f"{self.aperture_text()} stop"
        rule = {
            "dof": self._dof(),
            "aperture": f"{stop} (semi-aperture {self.stop_radius_mm():g} mm), vignetted by the lens's "
                        "openings (cat-eye off axis)",
            "effects": {"chromatic": f"sellmeier ({nm} nm)"},
            "psf_models": ("physical_lens",),
            "references": (Step("mitsuba_thick_lens", f"Mitsuba path trace through the thick lens "
                                                      f"(lab.reference.thick_lens_sensor), one pass set per "
                                                      f"channel at {nm} nm, {r.reference_spp} spp each, max depth "
                                                      f"{r.max_depth}"),),
            "runtime_passes": ("spreadlets", "splat", "filter"),
            "skipped": (Step("polygon passes", "MHU21's kernels are flat polygons; a thick lens's bokeh (cat-eye, "
                                               "aberrations, colour) runs through its physical_lens database"),),
        }
        return with_layered_pass(rule, scene)   # LES10: the lens's own rays through peeled layers

    def _plan_tilted(self, scene) -> dict:
        """A tilted sensor: only the lens rays through the peeled layers trace it (the physical_lens
        PSFs are a flat sensor's), against the Mitsuba thick-lens sensor tilted the same way."""
        r = scene.render
        if r.peel_layers is None:
            raise UserError(f"{scene.source} [camera] sensor tilt {list(self.runtime_camera().sensor_tilt_deg)} with a "
                            "thick lens: only the layered pass traces a tilted thick-lens sensor; add [render] "
                            "peel_layers = 4, or remove the tilt")
        nm = "/".join(f"{w:g}" for w in WAVELENGTHS_NM)
        rule = {
            "dof": self._dof(),
            "aperture": f"round stop (semi-aperture {self.stop_radius_mm():g} mm), vignetted by the lens's openings",
            "effects": {"chromatic": f"sellmeier ({nm} nm)"},
            "psf_models": (),
            "references": (Step("mitsuba_thick_lens", f"Mitsuba path trace through the thick lens and its tilted "
                                                      f"sensor (lab.reference.thick_lens_sensor), one pass set per "
                                                      f"channel at {nm} nm, {r.reference_spp} spp each, max depth "
                                                      f"{r.max_depth}"),),
            "runtime_passes": (),
            "skipped": (Step("spreadlets, splat, filter", "the physical_lens PSFs are traced for a flat sensor; the "
                                                          "tilted sensor runs through the layered pass's lens rays"),),
        }
        return with_layered_pass(rule, scene)

    def _dof(self) -> str:
        lens = self.runtime_camera()
        name = f"{self.lens}, " if self.lens is not None else ""
        n = lens.chief_scale_mm / (2.0 * lens.pupil_radius_mm)
        tilt = (f", sensor tilt {lens.sensor_tilt_deg[0]:.3g}/{lens.sensor_tilt_deg[1]:.3g} deg" if lens.tilted
                else "")
        return (f"thick ({name}{len(lens.surfaces)} surfaces, EFL {lens.focal_length_mm:.1f} mm, f/{n:.2g}, "
                f"focus {lens.focus_distance_m:g} m{tilt}, sensor {lens.sensor_width_mm:g} mm)")

    def mitsuba_sensor(self, sensor: dict) -> dict:
        """The Python sensor of :mod:`lab.reference.thick_lens_sensor` tracing this lens at the
        focus wavelength (a chromatic reference sets ``wavelength_nm`` per pass), with the view,
        film and sampler of ``sensor``."""
        from ..reference.thick_lens_sensor import register

        out = {k: v for k, v in sensor.items() if k not in ("fov", "fov_axis")}
        params = self.aperture_params()
        if params is not None:   # the shaped stop (the header keeps an image's digest, not its path)
            out["aperture"] = json.dumps(params)
        return dict(out, type=register(), camera=json.dumps(self.camera_json()), wavelength_nm=FOCUS_WAVELENGTH_NM)

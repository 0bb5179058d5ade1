"""The pinhole camera: ``[camera] model = "pinhole"``, everything sharp.

- Scene keys: exactly one of ``fov_deg`` (horizontal) and ``focal_length_mm`` (with the sensor
  width); the lens keys of a thin lens are an error that says so.
- Runtime twin: :class:`runtime_cl.camera.pinhole.Pinhole` (CoC 0 everywhere).
- Header: ``{"lens": "pinhole", "fov_x_deg": ..., "shutter": [open, close]}``.
- Plan: no defocus, so no PSF database; the pinhole render is its own reference and the runtime
  pass is ``identity``. With a ``[medium]`` (:class:`lab.medium.Medium`): the ``volume`` PSF model
  through the spreadlet passes against a path-traced reference through the medium
  (:mod:`lab.reference.equiangular`), with
  the ``volume_far`` model's halo beyond the volume PSFs' window when the frame is wider (a medium
  in a box: the ``volume_box`` model, :data:`MEDIUM_PLANS`); a
  moving scene the ``combined`` model (CoC 0) against sub-frames (:func:`~lab.cameras.base.motion_plan`).
- Mitsuba: the ``perspective`` sensor itself.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from runtime_cl.camera.pinhole import Pinhole

from ..errors import UserError
from ..motion import scene_moves
from ..plan import Step
from .base import Camera, motion_plan, register_camera

# Keys of a lens aperture (model = "thin"), named in the error a pinhole gives for them.
LENS_KEYS = ("f_number", "aperture_radius_mm", "focus_distance_m", "aperture")


@register_camera("pinhole")
@dataclass(frozen=True)
class PinholeCamera(Camera):
    """A pinhole camera (the look-at keys of :class:`lab.cameras.base.Camera` too).

    Parameters
    ----------
    fov_deg : float, optional
        Horizontal field of view in degrees (0 < fov < 180).
    focal_length_mm : float, optional
        The alternative to ``fov_deg``: the fov of this focal length on ``sensor_width_mm``.
    """

    runtime = Pinhole
    focal_length_mm: float | None = None
    fov_deg: float | None = None

    @classmethod
    def parse(cls, table: dict, where: str) -> "PinholeCamera":
        lens_keys = [k for k in LENS_KEYS if k in table]
        if lens_keys:
            raise UserError(f"{where}: {lens_keys} describe a lens aperture; a pinhole has none: remove "
                            "them or set model = 'thin'")
        return super().parse(table, where)

    def check(self) -> None:
        self.check_positive("focal_length_mm", "sensor_width_mm")
        if (self.fov_deg is None) == (self.focal_length_mm is None):
            raise UserError("a pinhole needs exactly one of fov_deg and focal_length_mm "
                            "(with sensor_width_mm)")
        if self.fov_deg is not None and not 0.0 < self.fov_deg < 180.0:
            raise UserError(f"fov_deg = {self.fov_deg} must be between 0 and 180 degrees")

    def runtime_camera(self) -> Pinhole:
        fov = self.fov_deg
        if fov is None:
            fov = math.degrees(2.0 * math.atan(self.sensor_width_mm / (2.0 * self.focal_length_mm)))
        return Pinhole(fov_deg=fov)

    def camera_json(self) -> dict:
        return {**self.runtime_camera().to_json(), "shutter": self.header_shutter()}

    def plan(self, scene) -> dict:
        r = scene.render
        if scene_moves(scene):
            if scene.medium is not None:
                raise UserError(f"{scene.source} [medium]: the scene moves and has a medium; no PSF model "
                                "combines motion and scattering: remove [medium] or the velocities")
            return motion_plan(scene, "none")
        if scene.medium is not None:
            return MEDIUM_PLANS[scene.medium.psf_model](scene)
        return {
            "dof": "none",
            "aperture": "none (pinhole)",
            "psf_models": (),
            "references": (Step("pinhole", f"the pinhole render is the reference "
                                           f"({r.reference_spp} spp, max depth {r.max_depth})"),),
            "runtime_passes": ("identity",),
            "skipped": (Step("PSF precompute and sparsify", "a pinhole camera has no defocus: every PSF "
                                                            "is a delta"),),
        }

    def mitsuba_sensor(self, sensor: dict) -> dict:
        return sensor


def _medium_reference_step(scene) -> Step:
    from ..reference.equiangular import applies

    r = scene.render
    how = "equi-angular volumetric path tracing" if applies(scene) else "Mitsuba volpath"
    return Step("volume_path_trace", f"{how} through the medium, {r.reference_spp} spp, max depth {r.max_depth}")


def _filling_plan(scene) -> dict:
    """A medium filling the scene: ``volume`` (+ ``volume_far`` when the window misses the frame)."""
    from ..psf_settings import far_field_needed, near_window_px

    far = far_field_needed(scene)
    window = f"the volume PSFs' window (+-{near_window_px(scene)} px)"
    skipped = () if far else (Step("volume_far", f"{window} covers the frame: no halo reaches beyond it"),)
    return {
        "dof": "none",
        "aperture": "none (pinhole)",
        "psf_models": ("volume", "volume_far") if far else ("volume",),
        "references": (_medium_reference_step(scene),),
        "runtime_passes": ("spreadlets", "splat", "filter"),
        "skipped": (Step("defocus", "a pinhole camera: the volume PSFs are the medium's alone"),) + skipped,
    }


def _box_plan(scene) -> dict:
    """A medium in a box: ``volume_box`` (scattered light by segment; the unscattered part exact)."""
    from ..medium_box import shapes_inside

    shapes_inside(scene.medium.box, scene.shapes, scene.source)   # the reference's check, before any render
    return {
        "dof": "none",
        "aperture": "none (pinhole)",
        "psf_models": ("volume_box",),
        "references": (_medium_reference_step(scene),),
        "runtime_passes": ("spreadlets", "splat", "filter"),
        "skipped": (Step("defocus", "a pinhole camera: the volume PSFs are the medium's alone"),
                    Step("volume_far", "a box medium has no far field: its halo is cut at the volume_box "
                                       "PSFs' window (psf_resolution)")),
    }


# The medium's PSF model (lab.medium.Medium.psf_model) -> its plan.
MEDIUM_PLANS = {"volume": _filling_plan, "volume_box": _box_plan}

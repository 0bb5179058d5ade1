"""What a scene decides of a PSF model's settings: its ``[psf.<model>]`` table, filled in.

A scene's ``[psf.<model>]`` table only overrides; the rest of what the model needs from the scene
(the largest CoC from the depth range, the camera's aperture, the largest motion, the medium) is derived here, one function per model in :data:`SCENE_SETTINGS`. A table
that contradicts the scene (a star database for a round camera) is an error naming both. A
model without an entry takes its table as it is.
"""
from __future__ import annotations

import math

from runtime_cl.json_values import is_number

from .errors import UserError

__all__ = ["SCENE_SETTINGS", "model_table"]


def _same(given, value) -> bool:
    def as_list(v):
        return [as_list(x) for x in v] if isinstance(v, (list, tuple)) else v
    return as_list(given) == as_list(value)


def _from_camera(table: dict, scene, model: str, keys: dict) -> None:
    """Set ``keys`` (what the scene's camera decides) in ``table``; a different value given in
    the table is an error: its database could not match the camera's reference."""
    for key, value in keys.items():
        given = table.get(key, value)
        if not _same(given, value):
            raise UserError(f"{scene.source} [psf.{model}] {key} = {given!r}: the scene's [camera] asks "
                            f"for {key} = {value!r} (its reference is traced so), so this database would "
                            "not match it; remove the key, or change the [camera]")
        table[key] = value


def _coc_range(table: dict, scene, image) -> dict:
    """``max_coc_px``: the largest |CoC| of the input, rounded up to a multiple of 8 px (so small
    scene edits reuse the database); ``psf_resolution``: the smallest that holds it."""
    from .psf_tracing.models.simple_lens import min_psf_resolution
    from .reference.coc import coc_range

    if "max_coc_px" not in table:
        needed = coc_range(image, scene.camera.thin_lens()).max_abs_px
        table["max_coc_px"] = float(max(8, 8 * math.ceil(needed / 8.0)))
    if is_number(table["max_coc_px"]) and table["max_coc_px"] > 0:   # else the model's check names it
        table.setdefault("psf_resolution", min_psf_resolution(table["max_coc_px"]))
    return table


def _simple_lens(table: dict, scene, image) -> dict:
    """The camera's round aperture, then the CoC range of :func:`_coc_range`."""
    _from_camera(table, scene, "simple_lens", {"aperture": "circle"})
    return _coc_range(table, scene, image)


def _stylized(table: dict, scene, image) -> dict:
    """The camera's shape (``[camera] aperture = { shape = ... }``) and no colour fringes (a thin
    lens has no glass), then the CoC range of :func:`_coc_range`."""
    keys = dict(scene.camera.shaped().model_keys(), channel_scale=(1.0, 1.0, 1.0))
    _from_camera(table, scene, "stylized", keys)
    return _coc_range(table, scene, image)


def _combined(table: dict, scene, image) -> dict:
    """The camera's aperture (round for a pinhole); ``max_coc_px`` as :func:`_coc_range` finds it
    (1 px for a pinhole, whose CoC is 0 everywhere); ``max_motion_px``: the longest motion vector
    of the input, rounded up to a multiple of 8 px; ``psf_resolution``: the smallest that holds
    both (in every direction for a shaped aperture, which traces them all)."""
    import numpy as np
    from .psf_tracing.models.combined import min_combined_resolution
    from .motion import read_motion

    lens = scene.camera.thin_lens()
    _from_camera(table, scene, "combined", {"aperture": "circle"} if lens is None else scene.camera.aperture_keys())
    if "max_coc_px" not in table:
        if lens is None:
            table["max_coc_px"] = 1.0
        else:
            _coc_range(table, scene, image)
            table.pop("psf_resolution", None)
    if "max_motion_px" not in table:
        longest = float(np.hypot(*np.moveaxis(read_motion(image, scene.source, "combined"), -1, 0)).max())
        table["max_motion_px"] = float(max(8, 8 * math.ceil(longest / 8.0)))
    coc, motion, angle = table["max_coc_px"], table["max_motion_px"], table.get("motion_direction_deg", 0.0)
    if table["aperture"] != "circle":
        angle = None
    if is_number(coc) and coc > 0 and is_number(motion) and motion >= 0 and (angle is None or is_number(angle)):
        table.setdefault("psf_resolution", min_combined_resolution(coc, motion, angle))
    return table


def _volume(table: dict, scene, image) -> dict:
    """The scene's medium, the input's pixel scale (the PSFs are the camera's pinhole images) and
    the range of distances from the camera to what the pixels see, rounded out to 0.5 m (so
    small scene edits reuse the database)."""
    import numpy as np
    from runtime_cl.coords.common import pixel_offsets

    camera = scene.camera.runtime_camera()
    w, h = image.width, image.height
    fov = math.radians(camera.fov_x_deg())
    keys = dict(scene.medium.model_keys(), width_px=w, sensor_width_mm=36.0,
                focal_length_mm=18.0 / math.tan(fov / 2.0))
    _from_camera(table, scene, "volume", keys)
    depth = np.asarray(image.depth, np.float64)
    sky = int(np.count_nonzero(~np.isfinite(depth)))
    if sky:
        raise UserError(f"{scene.source} [medium]: the medium fills the scene, but {sky} pixel(s) see no "
                        "surface (infinite distance, where no light gets through the fog): close the "
                        "view with a wall or a floor")
    x, y = pixel_offsets(h, w)
    distance = depth * np.sqrt(1.0 + (x * x + y * y) / camera.focal_px(w) ** 2)   # as the runtime maps it
    table.setdefault("min_distance_m", math.floor(2.0 * float(distance.min())) / 2.0)
    table.setdefault("max_distance_m", math.ceil(2.0 * float(distance.max())) / 2.0)
    return table


def _volume_box(table: dict, scene, image) -> dict:
    """The box medium (:func:`_volume`'s medium and pixel scale, the box in the camera's frame) and,
    from each pixel's segment in the box (as the runtime maps it), the largest camera gap, length in
    the box and gap behind it, rounded up to 0.5 m (at least 0.5 m)."""
    import numpy as np
    from runtime_cl.coords.medium_box import box_segments, pixel_rays

    from .medium_box import camera_frame

    camera = scene.camera.runtime_camera()
    fov = math.radians(camera.fov_x_deg())
    box = camera_frame(scene.medium.box, scene.camera)
    keys = dict(scene.medium.model_keys(), width_px=image.width, sensor_width_mm=36.0,
                focal_length_mm=18.0 / math.tan(fov / 2.0), box_center=tuple(box["center"]),
                box_axes=tuple(tuple(a) for a in box["axes"]), box_half_size=tuple(box["half_size"]))
    _from_camera(table, scene, "volume_box", keys)
    depth = np.asarray(image.depth, np.float64)
    sky = int(np.count_nonzero(~np.isfinite(depth)))
    if sky:
        raise UserError(f"{scene.source} [medium]: {sky} pixel(s) see no surface (infinite distance); the "
                        "box's PSFs are traced by the distance behind the box: close the view with a wall or a floor")
    directions, distance = pixel_rays(camera, depth)
    t0, t1 = box_segments(directions, distance, box)
    crossed = t1 > t0

    def top(values):
        return max(0.5, math.ceil(2.0 * float(values[crossed].max(initial=0.0))) / 2.0)

    table.setdefault("max_camera_gap_m", top(t0))
    table.setdefault("max_medium_length_m", top(t1 - t0))
    table.setdefault("max_light_gap_m", top(distance - t1))
    return table


def near_window_px(scene) -> int:
    """The half-width in pixels of the image the scene's volume PSFs keep (their window less the
    tracer's margin): the far field (``volume_far``) holds the halo beyond it."""
    from .psf_tracing.models.common import check_number
    from .psf_tracing.models.simple_lens import PSF_MARGIN_PX
    from .psf_tracing.models.volume_config import VolumeConfig

    resolution = scene.psf.get("volume", {}).get("psf_resolution", VolumeConfig.psf_resolution)
    try:
        check_number("psf_resolution", resolution, integer=True)
    except UserError as exc:
        raise UserError(f"{scene.source} [psf.volume]: {exc}") from None
    return resolution // 2 - PSF_MARGIN_PX


def far_field_needed(scene) -> bool:
    """Whether a light's halo can reach beyond the volume PSF's window inside the frame: a light in
    one corner lights the opposite one, up to max(W, H) - 1 px away."""
    return near_window_px(scene) < max(scene.info.resolution) - 1


def _volume_far(table: dict, scene, image) -> dict:
    """The volume's medium, camera and distances (:func:`_volume`), its window as the hole, and a
    window of ``pixel_scale`` px (default 8) per PSF pixel reaching across the whole frame."""
    from .psf_tracing.models.simple_lens import PSF_MARGIN_PX
    from .psf_tracing.models.volume_far import VolumeFarConfig

    near = _volume(dict(scene.psf.get("volume", {})), scene, image)
    keys = {k: near[k] for k in ("medium_density", "g", "albedo", "width_px", "sensor_width_mm", "focal_length_mm",
                                 "min_distance_m", "max_distance_m")}
    _from_camera(table, scene, "volume_far", dict(keys, hole_half_px=near_window_px(scene)))
    scale = int(table.setdefault("pixel_scale", VolumeFarConfig.pixel_scale))
    reach = -(-(max(image.width, image.height) - 1) // scale)   # PSF pixels to the farthest pixel
    table.setdefault("psf_resolution", 2 * (reach + PSF_MARGIN_PX) + 1)
    return table


def _physical_lens(table: dict, scene, image) -> dict:
    """The camera's lens, focus, wavelengths and stop shape, the input's sensor (its header's: wider than the
    scene's with a guard band) with the input's width and aspect, then the range of the input's
    depths rounded out (near down to 5 cm, far up to 0.5 m, so small scene edits reuse the
    database) and the PSF size that holds the widest PSF."""
    import numpy as np

    from .cameras.thick import FOCUS, FOCUS_WAVELENGTH_NM, WAVELENGTHS_NM

    cam = scene.camera
    # the input's own sensor: a guard-banded input's is wider than the scene's, at the same pitch
    sensor = float((image.camera or {}).get("sensor_width_mm", cam.sensor_width_mm))
    keys = dict(surfaces=cam.rows(), focus_distance_m=cam.focus_distance_m, focus=FOCUS,
                wavelengths_nm=WAVELENGTHS_NM, focus_wavelength_nm=FOCUS_WAVELENGTH_NM, width_px=image.width,
                sensor_width_mm=sensor, sensor_height_mm=sensor * image.height / image.width, **cam.aperture_keys())
    _from_camera(table, scene, "physical_lens", keys)
    depth = np.asarray(image.depth, np.float64)
    sky = int(np.count_nonzero(~np.isfinite(depth)))
    if sky:
        raise UserError(f"{scene.source} [camera]: {sky} pixel(s) see no surface (infinite depth), but a thick "
                        "lens's PSFs are traced for finite depths: close the view with a wall or a floor")
    z_min, z_max = float(depth.min()), float(depth.max())
    near = math.floor(20.0 * z_min) / 20.0
    table.setdefault("near_m", near if near > cam.optics().min_depth_m() else z_min)
    table.setdefault("far_m", max(math.ceil(2.0 * z_max) / 2.0, table["near_m"] + 0.5))
    if "psf_resolution" not in table:
        from .psf_tracing.models import load_model

        table["psf_resolution"] = load_model("physical_lens", table, f"{scene.source} [psf.physical_lens]"
                                             ).required_resolution()
    return table


class _NeedsInput(Exception):
    """A setting depends on the labelled input, which :func:`check_tables` does not have."""


class _NoInput:
    """Stands in for the labelled input in :func:`check_tables`: any use of it says so."""

    def __getattr__(self, name):
        raise _NeedsInput(name)


def check_tables(scene, models) -> None:
    """Validate the scene's ``[psf.<model>]`` tables before anything is rendered, each one whose
    settings do not depend on the labelled input (the scene gives what the input would decide):
    a bad setting then fails in a second, not after the input and reference renders. The other
    tables are checked by :func:`model_table` once the input exists.

    Raises
    ------
    UserError
        A model's own checks, naming the scene file and ``[psf.<model>]``.
    """
    from .psf_tracing.models import load_model

    for name in models:
        try:
            table = model_table(scene, name, _NoInput())
        except _NeedsInput:
            continue
        load_model(name, table, f"{scene.source} [psf.{name}]")


# Model name -> fill(table, scene, labelled input) -> table.
SCENE_SETTINGS = {"simple_lens": _simple_lens, "combined": _combined, "stylized": _stylized, "volume": _volume,
                  "volume_far": _volume_far, "volume_box": _volume_box, "physical_lens": _physical_lens}


def model_table(scene, model_name: str, image) -> dict:
    """The scene's ``[psf.<model_name>]`` table with what the scene decides filled in.

    Parameters
    ----------
    scene : lab.scene.Scene
    model_name : str
        A registered PSF model.
    image : lab.exr_io.LabelledImage
        The scene's labelled-pixel input (its depths fix the CoC range).
    """
    table = dict(scene.psf.get(model_name, {}))
    fill = SCENE_SETTINGS.get(model_name)
    return fill(table, scene, image) if fill else table

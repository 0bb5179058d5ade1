"""Focus control from pixels (LES10 5.1): a focus point, and tilt-shift from several.

``[camera] focus_point = [x, y]`` (pixel column, row from the top) focuses the lens at the depth
the labelled input sees there (its Z); ``focus_points = [[x, y], ...]`` (>= 3) fits a plane through
the 3-D points they see by least squares and tilts the sensor so the plane is in focus
(Scheimpflug: the camera's ``plane_focus``, the thin lens's equation or the thick lens's traced
images, :mod:`lab.optics.tilt`).

The input's field of view depends on the focus (a thin lens breathes: the image distance moves),
so the depth a pixel sees does too: :func:`resolve_focus` iterates focus -> pinhole depths ->
focus until the distance changes by < 1e-7 relative (a couple of rounds; the input rendered with
the result then sees the same depth there). The depths are Mitsuba's pixel-centre rays, the Z of
:func:`lab.reference.labelled.planar_depth`, traced for the focus pixels alone.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from .errors import UserError

__all__ = ["check_pixels", "depth_at", "surface_from_depth", "fit_plane", "pixel_depths", "refocus_header", "refocus_option", "resolve_focus"]

ROUNDS = 12           # fixed-point rounds; focus breathing converges in 2-4
TOLERANCE = 1e-7      # relative change of the focus distance that ends them
START_M = 1000.0      # the focus of the first round (any: the next round corrects it)


def check_pixels(pixels, width: int, height: int, key: str) -> None:
    """UserError naming ``key`` unless every [x, y] lies inside a ``width`` x ``height`` image."""
    for x, y in pixels:
        if not (0 <= x < width and 0 <= y < height):
            raise UserError(f"{key} [{x}, {y}] is outside the {width} x {height} image; give a pixel with "
                            f"0 <= x < {width} and 0 <= y < {height} (column, row from the top)")


def depth_at(depth: np.ndarray, x: int, y: int, key: str) -> float:
    """The depth at pixel (x, y) of a depth map; UserError naming the pixel and the nearest pixel
    that sees a surface when it sees none (sky: Z = inf or A = 0 there)."""
    z = float(depth[y, x])
    if np.isfinite(z) and z > 0:
        return z
    valid = np.argwhere(np.isfinite(depth) & (depth > 0))
    near = None
    if len(valid):
        ny, nx = valid[np.argmin((valid[:, 0] - y) ** 2 + (valid[:, 1] - x) ** 2)]
        near = (int(nx), int(ny))
    raise no_surface(key, x, y, z, near)


def no_surface(key: str, x: int, y: int, z: float, near) -> UserError:
    hint = (f"pick a pixel on a surface, e.g. the nearest one, [{near[0]}, {near[1]}]" if near is not None else
            "pick a pixel on a surface")
    return UserError(f"{key} [{x}, {y}] sees no surface (sky: Z = {z}), so it has no depth to focus on; {hint}")


def fit_plane(points: np.ndarray, key: str) -> tuple:
    """The least-squares plane n . X = c (|n| = 1) through (n, 3) points (total least squares: the
    normal is the singular vector of the centred points' least singular value); UserError when they
    are (nearly) collinear, so no plane is determined."""
    centre = points.mean(axis=0)
    _, s, vt = np.linalg.svd(points - centre)
    if len(points) < 3 or s[1] <= 1e-6 * max(s[0], 1e-12):
        raise UserError(f"{key}: the points they see are collinear (singular values {np.round(s, 6).tolist()}), "
                        "so they fit no plane; add a focus point off their line")
    n = vt[2]
    return n, float(n @ centre)


NEAR_WINDOW_PX = 48   # how far around a focus point on the sky its error looks for a surface pixel


def pixel_depths(scene, pixels) -> np.ndarray:
    """(n,) planar depth Z (metres; inf: no surface) at the centres of ``pixels`` [(x, y), ...]: one
    pinhole ray each, traced as :func:`lab.reference.labelled.planar_depth` traces every pixel (a
    few rays: the cost does not grow with the image)."""
    import drjit as dr

    from .reference.backend import mitsuba
    from .reference.render import load

    mi = mitsuba()
    px = np.asarray(pixels, np.float64).reshape(-1, 2)
    pos = mi.Point2f(mi.Float((px[:, 0] + 0.5) / scene.width), mi.Float((px[:, 1] + 0.5) / scene.height))
    mi_scene = load(scene, "pinhole")
    ray, _ = mi_scene.sensors()[0].sample_ray(mi.Float(0.0), mi.Float(0.5), pos, mi.Point2f(0.5, 0.5))
    si = mi_scene.ray_intersect(ray)
    dr.eval(si.p)
    points = np.stack([np.asarray(si.p[i], np.float64) for i in range(3)], axis=-1)
    cam = scene.camera
    z = (points - cam.position_at(0.0)) @ cam.forward()
    return np.where(np.asarray(si.is_valid(), bool), z, np.inf)


def _depths(scene, pixels, key: str) -> np.ndarray:
    """:func:`pixel_depths`; UserError naming a pixel on the sky and the nearest surface pixel."""
    z = pixel_depths(scene, pixels)
    for (x, y), d in zip(pixels, z):
        if not (np.isfinite(d) and d > 0):
            r = NEAR_WINDOW_PX
            x0, y0 = max(0, x - r), max(0, y - r)
            ys, xs = np.mgrid[y0:min(scene.height, y + r + 1), x0:min(scene.width, x + r + 1)]
            around = pixel_depths(scene, np.stack([xs.ravel(), ys.ravel()], -1)).reshape(xs.shape)
            ok = np.argwhere(np.isfinite(around))
            near = None
            if len(ok):
                i = np.argmin((ok[:, 0] + y0 - y) ** 2 + (ok[:, 1] + x0 - x) ** 2)
                near = (int(ok[i, 1] + x0), int(ok[i, 0] + y0))
            raise no_surface(key, x, y, float(d), near)
    return z


def _focus_from(scene) -> dict:
    """The camera fields the depths the focus pixels see give: focus distance (and sensor tilt
    for focus_points)."""
    camera = scene.camera
    if camera.focus_point is not None:
        return {"focus_distance_m": float(_depths(scene, [camera.focus_point], "focus_point")[0])}
    pixels = camera.focus_points
    z = _depths(scene, pixels, "focus_points")
    w, h = scene.width, scene.height
    f_px = camera.runtime_camera().focal_px(w)
    points = np.asarray([((x + 0.5 - w / 2) / f_px * d, (h / 2 - y - 0.5) / f_px * d, d)
                         for (x, y), d in zip(pixels, z)])
    n, c = fit_plane(points, "focus_points")
    try:
        focus, tilt = camera.plane_focus(points, n, c, w)
    except UserError as exc:
        raise UserError(f"focus_points {[list(p) for p in camera.focus_points]}: {exc}") from None
    return {"focus_distance_m": focus, "sensor_tilt_deg": tilt}


def resolve_focus(scene):
    """``scene`` with its camera focused as its ``focus_point`` / ``focus_points`` ask (unchanged
    without them); UserError naming the scene file and the key for a pixel outside the image, on
    the sky, or points that fit no usable focal plane."""
    cam = scene.camera
    surface = getattr(cam, "focal_surface", None)
    if surface is not None:
        return _resolve_surface(scene)
    if getattr(cam, "focus_point", None) is None and getattr(cam, "focus_points", None) is None:
        return scene
    where = f"{scene.source} [camera]"
    pixels = [cam.focus_point] if cam.focus_point is not None else cam.focus_points
    try:
        check_pixels(pixels, scene.width, scene.height, "focus_point" if cam.focus_point is not None else "focus_points")
        current = cam.focus_distance_m or START_M
        for _ in range(ROUNDS):
            fields = _focus_from(replace(scene, camera=replace(cam, focus_distance_m=current)))
            done = abs(fields["focus_distance_m"] - current) <= TOLERANCE * current
            current = fields["focus_distance_m"]
            if done:
                break
    except UserError as exc:
        raise UserError(f"{where} {exc}") from None
    return replace(scene, camera=replace(cam, **fields))


def _resolve_surface(scene):
    """``scene`` with its focal surface's pixels checked against the image and its ``blur``
    constraints turned into focal depths (:mod:`lab.focal_constraints`), from the depths the
    constraint pixels' pinhole rays see (the input's Z there: the focus distance is given, so the
    field of view does not breathe)."""
    from .focal_constraints import check_pixels_in, resolve_blur

    cam, where = scene.camera, f"{scene.source} [camera]"
    check_pixels_in(cam.focal_surface, scene.width, scene.height, where)
    lens = replace(cam, focal_surface=None).runtime_camera()
    scale = lens.coc_scale_px(scene.width) / cam.focal_surface["dof_extent"]

    def depths(pixels):
        try:
            return _depths(replace(scene, camera=replace(cam, focal_surface=None)), pixels, "focal_surface blur")
        except UserError as exc:
            raise UserError(f"{where} {exc}") from None

    return replace(scene, camera=replace(cam, focal_surface=resolve_blur(cam.focal_surface, scale, depths, where)))


def surface_from_depth(camera, depth: np.ndarray, source: str):
    """A ``--camera`` file's thin camera with its ``blur`` constraints resolved from ``depth`` (the
    input's Z, inf where it sees no surface); unchanged without them."""
    from .focal_constraints import check_pixels_in, resolve_blur, unresolved

    surface = getattr(camera, "focal_surface", None)
    if not unresolved(surface):
        return camera
    h, w = depth.shape
    check_pixels_in(surface, w, h, source)
    scale = replace(camera, focal_surface=None).runtime_camera().coc_scale_px(w) / surface["dof_extent"]
    lookup = lambda pixels: [depth_at(depth, x, y, f"{source} focal_surface blur") for x, y in pixels]   # noqa: E731
    return replace(camera, focal_surface=resolve_blur(surface, scale, lookup, source))


def refocus_header(camera: dict, depth: np.ndarray, x: int, y: int, source: str) -> dict:
    """The ``splatlab.camera`` header ``camera`` focused at pixel (x, y) of ``depth`` (the input's
    Z): ``splatlab render --focus-point X,Y``. The thin lens takes the depth as its focus
    distance (untilted: the point overrides the header's whole focus); the thick lens moves its
    sensor there (its paraxial figures re-derived by the lab)."""
    h, w = depth.shape
    check_pixels([(x, y)], w, h, "--focus-point")
    z = depth_at(depth, x, y, "--focus-point")
    lens = camera.get("lens")
    if lens == "thin":   # the point replaces the header's whole focus: a tilt or a focal surface goes
        kept = {k: v for k, v in camera.items() if k not in ("sensor_tilt_deg", "focal_surface")}
        return dict(kept, focus_distance_m=z, focus_points=[[x, y]])
    if lens == "thick":
        from .cameras.thick import ThickCamera

        thick = ThickCamera(model="thick", position=(0.0, 0.0, 0.0), look_at=(0.0, 0.0, 1.0),
                            surfaces=camera["surfaces"], focus_distance_m=z, focus_point=(x, y),
                            sensor_width_mm=camera["sensor_width_mm"])
        return {**thick.runtime_camera().to_json(), "shutter": camera.get("shutter", [0.0, 1.0])}
    raise UserError(f"--focus-point {x},{y}: {source} lens = {lens!r} has no focus; use a thin or thick lens header")


def refocus_option(image, text: str, source: str):
    """``image`` (a :class:`lab.exr_io.LabelledImage`) with its header focused at ``--focus-point
    X,Y`` (``text``); a pixel with coverage A = 0 sees no surface."""
    from dataclasses import replace as replace_image

    try:
        x, y = (int(v) for v in text.split(","))
    except ValueError:
        raise UserError(f"--focus-point {text!r}: give the pixel as X,Y (column, row from the top), e.g. "
                        "--focus-point 120,80") from None
    depth = np.where(np.asarray(image.alpha) > 0, np.asarray(image.depth, np.float64), np.inf)
    return replace_image(image, camera=refocus_header(image.camera, depth, x, y, source))

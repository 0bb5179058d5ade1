"""The stochastic-framebuffer input (LSR18 6.2, Fig. 9's 1-spp input): one path per pixel through
the scene's own camera, with the pixel's lens sample and shutter time as channels.

Each pixel gets its own sub-pixel position (the box filter the references use), lens sample
(u, v) and shutter time t, and one path traced with the scene's integrator (``path``; ``volpath``
in a medium) through the camera's own Mitsuba sensor (``thinlens``; with an iris or a shaped
aperture the reference's own sensor, :mod:`lab.reference.aperture_lens`; or the pinhole). Mitsuba
3.9.1 cannot move shapes during a launch, so, as for the motion reference
(:mod:`lab.reference.motion`), the shutter is cut into sub-frames at most a pixel of motion
apart: a pixel's time picks its sub-frame, and each sub-frame traces only its own pixels (one
path per pixel in all). ``time`` is the sub-frame's time, the time the path was traced at.

Channels written (the contract of :mod:`runtime_cl.stochastic.samples`): R, G, B (the path's
radiance), A (1 where the primary ray hits a surface), Z (the planar depth of that hit from the
camera at time t), ``lens.U, lens.V`` (the lens point in the film's axes, :func:`lens_channels`)
and ``time``; with motion also ``motion.X, motion.Y`` (the
hit point's chord from shutter open to close, as the labelled input's).

``shading_spp`` > 1 traces that many paths from each pixel's one camera ray (same sub-pixel
position, lens sample and time) and averages them: one *visibility* sample per pixel with
converged shading, as a stochastic rasterizer (Akenine-Moeller et al. 2007; LSR18 Fig. 2 b)
delivers. The lens and time noise is then all there is, which is what the reconstruction removes;
1 is a plain 1-spp path trace (LSR18 Fig. 9).
"""
from __future__ import annotations

import numpy as np

from runtime_cl.stochastic.samples import inverse_concentric

from ..errors import UserError
from ..exr_io import LabelledImage
from ..motion import scene_moves
from ..scene import Scene
from .backend import mitsuba
from .motion import Animator, project, subframes_for
from .render import load

__all__ = ["check_camera", "lens_channels", "render_stochastic", "stochastic_seed", "trace_samples"]

_STREAM = 0x5707    # the stochastic input's seed stream (apart from the reference and input streams)


def stochastic_seed(scene: Scene, index: int) -> np.random.SeedSequence:
    """The seeds of the ``index``-th independent 1-spp image of ``scene``."""
    return np.random.SeedSequence([scene.render.seed, _STREAM, index])


def check_camera(scene: Scene) -> None:
    """A :class:`~lab.errors.UserError` unless the scene's camera can write a stochastic input."""
    cam = scene.camera
    if cam.model in ("pinhole", "thin"):
        return
    raise UserError(f"{scene.source} [camera]: a stochastic input is written for a thin lens (a round, iris or "
                    f"shaped aperture) or a pinhole, whose lens samples are points of the unit disc; this camera "
                    f"is {cam.model!r}")


def lens_channels(scene: Scene, lens: np.ndarray) -> tuple:
    """``lens.U, lens.V`` (float32 (N,) each, in [0, 1)) of Mitsuba aperture samples ``lens``
    ((N, 2) float32): the concentric-map coordinates of each ray's lens point in the film's axes
    (x right, y down; :func:`runtime_cl.stochastic.concentric_disc`), unit circumradius.

    Mitsuba's camera has x left and y up. Its ``thinlens`` puts a sample at the concentric point
    of (u, v), which is odd in each coordinate, so ``(1 - u, 1 - v)`` is the film's point (exact).
    An iris or a shaped aperture (:mod:`lab.reference.aperture_lens`) puts it at the camera's
    (-x, y) of its shape's point (x, y) (lens plane, x right, y up): the film's (x, -y), mapped
    back to the square by the inverse concentric map.
    """
    params = scene.camera.aperture_params() if scene.camera.model == "thin" else None
    top = np.float32(np.nextafter(np.float32(1.0), np.float32(0.0)))
    if params is None:
        return np.minimum(1.0 - lens[:, 0], top), np.minimum(1.0 - lens[:, 1], top)
    from drjit.llvm import Array2f, Float

    from ..optics.aperture import make_aperture

    params = dict(params)
    shape = make_aperture(params.pop("aperture"), **params)   # the sensor's own sampler
    p = shape.sample(Array2f(Float(lens[:, 0]), Float(lens[:, 1])))
    u, v = inverse_concentric(np.asarray(p.x, np.float64), -np.asarray(p.y, np.float64))
    # a point on the rim (a polygon's corner) may lie a rounding error outside the unit disc
    return tuple(np.clip(x.astype(np.float32), np.float32(0.0), top) for x in (u, v))


def _flow(scene: Scene, points, t_frac, shape_idx) -> np.ndarray:
    """(N, 2) motion over the shutter in pixels (X right, Y up) of world ``points`` seen at shutter
    fraction ``t_frac`` on scene shape ``shape_idx`` (-1: none or static)."""
    open_, close = scene.camera.shutter
    start, end = points.copy(), points.copy()
    t_abs = open_ + t_frac * (close - open_)
    for i, shape in enumerate(scene.shapes):
        if shape.velocity is None and shape.angular_velocity_deg is None:
            continue
        for t in np.unique(t_abs[shape_idx == i]):
            on = (shape_idx == i) & (t_abs == t)
            back = np.linalg.inv(shape.to_world_at(float(t)))
            local = points[on] @ back[:3, :3].T + back[:3, 3]
            for out, tt in ((start, open_), (end, close)):
                m = shape.to_world_at(tt)
                out[on] = local @ m[:3, :3].T + m[:3, 3]
    flow = project(scene, end, close) - project(scene, start, open_)
    flow[:, 1] *= -1.0
    return flow


def trace_samples(scene: Scene, index: int = 0, max_motion_px: float = 0.0, shading_spp: int = 1) -> dict:
    """Trace one path per pixel (see the module docstring); the per-pixel arrays, row-major:
    ``rgb`` (N, 3), ``depth`` (N,), ``points`` (N, 3) world hit points, ``shape_idx`` (N,) scene
    shape hit (-1: none), ``lens`` (N, 2) Mitsuba's aperture samples, ``t_frac`` (N,) shutter
    fractions, ``jitter`` (N, 2) sub-pixel positions.

    Parameters
    ----------
    scene : Scene
        A thin-lens (round, iris or shaped aperture) or pinhole scene.
    index : int
        Which independent image (seeds: :func:`stochastic_seed`); 4 spp is images 0-3.
    max_motion_px : float
        The longest motion vector on screen (the labelled input's); sets the sub-frames.
    shading_spp : int
        Paths traced from each pixel's camera ray (see the module docstring).
    """
    check_camera(scene)
    if isinstance(shading_spp, bool) or not isinstance(shading_spp, int) or not 1 <= shading_spp <= 4096:
        raise UserError(f"shading_spp = {shading_spp!r}: give an integer in [1, 4096] (paths per camera ray)")
    mi = mitsuba()
    import drjit as dr

    w, h = scene.width, scene.height
    rng = np.random.default_rng(stochastic_seed(scene, index))
    jitter = rng.random((h * w, 2))
    lens = rng.random((h * w, 2)).astype(np.float32)
    moves = scene_moves(scene)
    k = subframes_for(max_motion_px) if moves else 1
    slot = rng.integers(0, k, h * w)
    mi_seeds = rng.integers(0, 2**31, k)
    mi_scene = load(scene, "scene", medium=True)
    animator = Animator(scene, mi_scene) if moves else None
    sensor, integrator = mi_scene.sensors()[0], mi_scene.integrator()
    ids = {sh.id(): int(np.asarray(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(sh)))[0]) for sh in mi_scene.shapes()}
    shape_of = {v: int(key.split("_")[1]) for key, v in ids.items() if key.startswith("shape_")}
    rgb = np.zeros((h * w, 3), np.float32)
    depth = np.full(h * w, np.inf, np.float32)
    points = np.zeros((h * w, 3))
    shape_idx = np.full(h * w, -1)
    t_frac = (slot + 0.5) / k
    open_, close = scene.camera.shutter
    for s in range(k):
        pix = np.flatnonzero(slot == s)
        if pix.size == 0:
            continue
        t_abs = open_ + (s + 0.5) / k * (close - open_)
        if animator is not None:
            animator.set_time(t_abs)
        lanes = np.repeat(pix, shading_spp)      # one camera ray per pixel, shading_spp paths from it
        pos = mi.Point2f(mi.Float(((lanes % w) + jitter[lanes, 0]) / w),
                         mi.Float(((lanes // w) + jitter[lanes, 1]) / h))
        aperture = mi.Point2f(mi.Float(lens[lanes, 0]), mi.Float(lens[lanes, 1]))
        sampler = mi.load_dict({"type": "independent"})
        sampler.seed(int(mi_seeds[s]), int(lanes.size))
        ray, weight = sensor.sample_ray_differential(mi.Float(t_abs), sampler.next_1d(), pos, aperture)
        spec, _, _ = integrator.sample(mi_scene, sampler, ray, sensor.get_medium(), True)
        value = spec * weight
        rgb[pix] = np.stack([np.asarray(value[i]) for i in range(3)], axis=-1).reshape(
            pix.size, shading_spp, 3).mean(axis=1)
        ray = mi.Ray3f(mi.Point3f(*(mi.Float(np.asarray(ray.o[i])[::shading_spp]) for i in range(3))),
                       mi.Vector3f(*(mi.Float(np.asarray(ray.d[i])[::shading_spp]) for i in range(3))))
        si = mi_scene.ray_intersect(ray)
        valid = np.asarray(si.is_valid(), bool)
        p = np.stack([np.asarray(si.p[i], np.float64) for i in range(3)], axis=-1)
        z = (p - scene.camera.position_at(t_abs)) @ scene.camera.forward()
        depth[pix] = np.where(valid, z, np.inf)
        points[pix] = p
        raw = np.asarray(dr.reinterpret_array(mi.UInt32, si.shape))
        shape_idx[pix] = np.where(valid, [shape_of.get(int(r), -1) for r in raw], -1)
    return {"rgb": rgb, "depth": depth, "points": points, "shape_idx": shape_idx, "lens": lens,
            "t_frac": t_frac, "jitter": jitter}


def render_stochastic(scene: Scene, index: int = 0, max_motion_px: float = 0.0,
                      shading_spp: int = 1) -> LabelledImage:
    """One 1-spp stochastic image of ``scene`` with its lens samples and times.

    Parameters
    ----------
    scene : Scene
        A thin-lens (round, iris or shaped aperture) or pinhole scene.
    index : int
        Which independent image (seeds: :func:`stochastic_seed`); 4 spp is images 0-3.
    max_motion_px : float
        The longest motion vector on screen (the labelled input's); sets the sub-frames.
    shading_spp : int
        Paths traced from each pixel's camera ray (see the module docstring).
    """
    w, h = scene.width, scene.height
    tr = trace_samples(scene, index, max_motion_px, shading_spp)
    lens, depth, t_frac = tr["lens"], tr["depth"], tr["t_frac"]
    u, v = lens_channels(scene, lens)
    extra = {"lens.U": u.reshape(h, w), "lens.V": v.reshape(h, w), "time": t_frac.astype(np.float32).reshape(h, w)}
    if scene_moves(scene):
        flow = np.zeros((h * w, 2), np.float32)
        hit = np.isfinite(depth)
        flow[hit] = _flow(scene, tr["points"][hit], t_frac[hit], tr["shape_idx"][hit])
        extra.update({"motion.X": flow[:, 0].reshape(h, w), "motion.Y": flow[:, 1].reshape(h, w)})
    header = scene.camera.camera_json()
    if scene.medium is not None:
        header["medium"] = scene.medium.header_json(scene.camera)
    alpha = np.isfinite(depth).astype(np.float32).reshape(h, w)
    return LabelledImage(rgb=tr["rgb"].reshape(h, w, 3), alpha=alpha, depth=depth.reshape(h, w), camera=header,
                         extra=extra)

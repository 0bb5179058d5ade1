"""The stochastic-framebuffer input (LSR18 6.2, Fig. 9's 1-spp input): one path per pixel through
the scene's own camera, with the pixel's lens sample and shutter time as channels.

Each pixel gets its own sub-pixel position (the box filter the references use), lens sample (u, v)
and shutter time t, from an Owen-scrambled Sobol sequence laid over the image in shuffled Morton
order (:mod:`lab.reference.sampling`: neighbouring pixels share out the lens and the shutter, as a
stochastic rasterizer's sample pattern does), and one path traced with the scene's integrator
(``path``) through the camera's own Mitsuba sensor (``thinlens``; with an iris or a shaped aperture
the reference's own sensor, :mod:`lab.reference.aperture_lens`; or the pinhole). A ``[medium]`` is
left out, as from the labelled input: the runtime's volume PSFs add it (tracing it here would add
it twice). A thick lens's pixel sends one ray per channel, through the same exit-pupil box sample
at the channel's wavelength (drawn again until the lens passes the middle ray:
:func:`passing_lens`), traced backward through the lens as the runtime re-traces it to re-centre
the sample (:mod:`runtime_cl.stochastic.thick`); R, G and B are the three rays' radiances, and Z, A
and the motion are the middle (510 nm) ray's; ``Z.R`` and ``Z.B`` are the depths the other two rays
hit (dispersed by the lens, a ray can pass a small drop that the 510 nm one hits: its sample goes
back to the pinhole position of its own hit). A ray the lens blocks adds nothing (its channel is
0). Mitsuba 3.9.1 cannot move shapes during a launch, so, as for the motion reference
(:mod:`lab.reference.motion`), the shutter is cut into sub-frames at most a pixel of motion apart:
a pixel's time picks its sub-frame, and each sub-frame traces only its own pixels (one path per
pixel in all). ``time`` is the sub-frame's time, the time the path was traced at.

Channels written (the contract of :mod:`runtime_cl.stochastic.samples`): R, G, B (the path's
radiance), A (1 where the primary ray hits a surface), Z (the planar depth of that hit from the
camera at time t), ``lens.U, lens.V`` (the lens point in the film's axes, :func:`lens_channels`),
``time`` and ``subpixel.X, subpixel.Y`` (the sample's place in its pixel); with motion also
``motion.X, motion.Y`` (the hit point's chord from shutter open to close, as the labelled input's);
through a thick lens also ``Z.R, Z.B`` (:data:`runtime_cl.stochastic.samples.CHANNEL_DEPTHS`).

``shading_spp`` > 1 traces that many paths from each pixel's one camera ray (same sub-pixel
position, lens sample and time) and averages them: one *visibility* sample per pixel with
converged shading, as a stochastic rasterizer (Akenine-Moeller et al. 2007; LSR18 Fig. 2 b)
delivers. The lens and time noise is then all there is, which is what the reconstruction removes;
1 is a plain 1-spp path trace (LSR18 Fig. 9).
"""
from __future__ import annotations

import functools

import numpy as np

from runtime_cl.stochastic.samples import inverse_concentric
from runtime_cl.camera.exit_pupil import PupilBoxes
from runtime_cl.stochastic.thick import backward_rays

from ..errors import UserError
from ..exr_io import LabelledImage
from ..motion import scene_moves
from ..scene import Scene
from .backend import mitsuba
from .motion import Animator, project, subframes_for
from .render import load
from .sampling import sample_points

__all__ = ["lens_channels", "render_stochastic", "stochastic_seed", "thick_rays", "trace_samples"]

_STREAM = 0x5707    # the stochastic input's seed stream (apart from the reference and input streams)
PASS_TRIES = 64     # box samples drawn per pixel until its thick-lens ray passes (passing_lens)


def stochastic_seed(scene: Scene, index: int) -> np.random.SeedSequence:
    """The seeds of the ``index``-th independent 1-spp image of ``scene``."""
    return np.random.SeedSequence([scene.render.seed, _STREAM, index])


def lens_channels(scene: Scene, lens: np.ndarray) -> tuple:
    """``lens.U, lens.V`` (float32 (N,) each, in [0, 1)) of Mitsuba aperture samples ``lens``
    ((N, 2) float32): the concentric-map coordinates of each ray's lens point in the film's axes
    (x right, y down; :func:`runtime_cl.stochastic.concentric_disc`), unit circumradius.

    Mitsuba's camera has x left and y up. Its ``thinlens`` puts a sample at the concentric point
    of (u, v), which is odd in each coordinate, so ``(1 - u, 1 - v)`` is the film's point (exact).
    An iris or a shaped aperture (:mod:`lab.reference.aperture_lens`) puts it at the camera's
    (-x, y) of its shape's point (x, y) (lens plane, x right, y up): the film's (x, -y), mapped
    back to the square by the inverse concentric map. A thick lens's are its exit-pupil box
    samples, as drawn (:func:`thick_rays`).
    """
    top = np.float32(np.nextafter(np.float32(1.0), np.float32(0.0)))
    if scene.camera.model == "thick":   # the exit-pupil box samples (runtime_cl.stochastic.thick)
        return np.minimum(lens[:, 0], top), np.minimum(lens[:, 1], top)
    params = scene.camera.aperture_params() if scene.camera.model == "thin" else None
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


def thick_rays(camera, sensor, shape, film, lens, channel: int, t_abs: float) -> tuple:
    """World rays of a thick lens's samples: from film positions ``film`` ((m, 2) px) through
    exit-pupil box samples ``lens`` ((m, 2)) in ``channel``, traced backward through the lens as
    the runtime re-traces them (:func:`runtime_cl.stochastic.thick.backward_rays`), placed by the
    scene sensor's transform at ``t_abs`` as :mod:`lab.reference.thick_lens_sensor` places its
    own rays. Returns ``(mi.Ray3f, ok)``: ``ok`` (m,) bool, False where the lens blocks the ray
    (its lane traces a dummy ray whose radiance is dropped)."""
    mi = mitsuba()
    o, d, ok = backward_rays(camera, _boxes(camera, shape), shape, film, lens, channel)
    o, d = np.where(ok[:, None], o, 0.0), np.where(ok[:, None], d, [[0.0, 0.0, -1.0]])
    # lens coordinates (x right, y up seen from the camera, z into it; mm) -> Mitsuba camera space
    origin = mi.Point3f(mi.Float(-o[:, 0] / 1000.0), mi.Float(o[:, 1] / 1000.0),
                        mi.Float((camera.pupil_z_mm - o[:, 2]) / 1000.0))
    direction = mi.Vector3f(mi.Float(-d[:, 0]), mi.Float(d[:, 1]), mi.Float(-d[:, 2]))
    to_world = sensor.world_transform()
    ray = mi.Ray3f(mi.Point3f(to_world @ origin), mi.Vector3f(to_world @ direction), mi.Float(t_abs), mi.Color0f())
    return mi.RayDifferential3f(ray), ok


def passing_lens(camera, shape: tuple, film: np.ndarray, lens: np.ndarray, rng: np.random.Generator,
                 tries: int = PASS_TRIES) -> np.ndarray:
    """``lens`` ((N, 2) float32 exit-pupil box samples) with each sample whose middle-wavelength
    ray from ``film`` ((N, 2) px) the thick lens blocks drawn again, uniformly in the box, until
    one passes (at most ``tries`` draws; a pixel none of them passes keeps its first).

    The box is the pupil's bounding box, so about a quarter of its points miss the round stop (far
    more at a vignetted corner): each such pixel would hold no sample. Drawing until a ray passes
    is uniform over the rays that pass, which is what the reference's pixel averages (its weight
    ``box area / A(r)``, :mod:`lab.reference.thick_lens_sensor`), so each pixel's value estimates
    the reference's without the factor ``A(r) / box area`` that the blocked pixels put in."""
    lens = np.array(lens, np.float32)
    boxes = _boxes(camera, tuple(shape))
    todo = np.flatnonzero(~backward_rays(camera, boxes, shape, film, lens, 1)[2])
    for _ in range(tries - 1):
        if todo.size == 0:
            break
        trial = rng.random((todo.size, 2)).astype(np.float32)
        ok = backward_rays(camera, boxes, shape, film[todo], trial, 1)[2]
        lens[todo[ok]] = trial[ok]
        todo = todo[~ok]
    return lens


@functools.lru_cache(maxsize=4)
def _boxes(camera, shape):
    return PupilBoxes.for_camera(camera, shape)


def trace_samples(scene: Scene, index: int = 0, max_motion_px: float = 0.0, shading_spp: int = 1,
                  medium: bool = False) -> dict:
    """Trace one path per pixel (see the module docstring); the per-pixel arrays, row-major:
    ``rgb`` (N, 3), ``depth`` (N,), ``points`` (N, 3) world hit points, ``shape_idx`` (N,) scene
    shape hit (-1: none), ``lens`` (N, 2) Mitsuba's aperture samples (a thick lens's box samples),
    ``t_frac`` (N,) shutter fractions, ``jitter`` (N, 2) sub-pixel positions, ``blocked`` (N,) the
    thick lens blocked the pixel's middle-wavelength ray (no sample: colour 0, depth inf);
    ``channel_depth`` (N, 3): through a thick lens, the depth each channel's ray hit (inf: none;
    the middle ray's depth where the lens blocks a channel's ray), else None.

    Parameters
    ----------
    scene : Scene
        A pinhole, thin-lens (round, iris or shaped aperture) or thick-lens scene.
    index : int
        Which independent image (seeds: :func:`stochastic_seed`); 4 spp is images 0-3.
    max_motion_px : float
        The longest motion vector on screen (the labelled input's); sets the sub-frames.
    shading_spp : int
        Paths traced from each pixel's camera ray (see the module docstring).
    medium : bool
        Trace through the scene's ``[medium]`` (Mitsuba's ``volpath``): the image a
        path tracer shows with these same samples, which a denoiser baseline starts from. Only
        its ``rgb`` is meant (a box's walls are shapes too); never the runtime's input (its volume
        PSFs add the medium).
    """
    if scene.camera.model == "thick" and scene.camera.aperture is not None:
        raise UserError(f"{scene.source} [camera] aperture = {scene.camera.aperture!r}: a stochastic input re-traces "
                        "the thick lens's round stop (runtime_cl.stochastic.thick); remove the aperture for it")
    if isinstance(shading_spp, bool) or not isinstance(shading_spp, int) or not 1 <= shading_spp <= 4096:
        raise UserError(f"shading_spp = {shading_spp!r}: give an integer in [1, 4096] (paths per camera ray)")
    mi = mitsuba()
    import drjit as dr

    w, h = scene.width, scene.height
    rng = np.random.default_rng(stochastic_seed(scene, index))
    jitter, lens, shutter = sample_points(rng, h, w)
    moves = scene_moves(scene)
    k = subframes_for(max_motion_px) if moves else 1
    slot = np.minimum((shutter * k).astype(np.int64), k - 1)
    mi_seeds = rng.integers(0, 2**31, k)
    mi_scene = load(scene, "scene", medium=medium)   # by default none: the runtime adds it
    thick = scene.camera.runtime_camera() if scene.camera.model == "thick" else None
    if thick is not None:
        film = np.stack([np.arange(h * w) % w + jitter[:, 0], np.arange(h * w) // w + jitter[:, 1]], axis=1)
        lens = passing_lens(thick, (h, w), film, lens, rng)
    animator = Animator(scene, mi_scene) if moves else None
    sensor, integrator = mi_scene.sensors()[0], mi_scene.integrator()
    ids = {sh.id(): int(np.asarray(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(sh)))[0]) for sh in mi_scene.shapes()}
    shape_of = {v: int(key.split("_")[1]) for key, v in ids.items() if key.startswith("shape_")}
    rgb = np.zeros((h * w, 3), np.float32)
    depth = np.full(h * w, np.inf, np.float32)
    points = np.zeros((h * w, 3))
    shape_idx = np.full(h * w, -1)
    blocked = np.zeros(h * w, bool)
    channel_depth = np.full((h * w, 3), np.inf, np.float32) if thick is not None else None
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
        sampler = mi.load_dict({"type": "independent"})
        sampler.seed(int(mi_seeds[s]), int(lanes.size))
        if thick is not None:   # each channel's ray through the lens at its wavelength
            for c in (1, 0, 2):
                ray_c, ok = thick_rays(thick, sensor, (h, w), film[lanes], lens[lanes], c, t_abs)
                if c == 1:   # the depth, hit and coverage of the middle wavelength's ray; where the
                    ray, seen = ray_c, ok[::shading_spp]   # lens blocks it the pixel is no sample
                spec, _, _ = integrator.sample(mi_scene, sampler, ray_c, sensor.get_medium(), True)
                rgb[pix, c] = (np.asarray(spec[c]) * ok * np.repeat(seen, shading_spp)).reshape(
                    pix.size, shading_spp).mean(axis=1)
                if c != 1:   # the other rays' own hits (the middle one's is the depth below)
                    z_c = _hit_depth(scene, mi_scene, ray_c, shading_spp, t_abs)[0]
                    channel_depth[pix, c] = np.where(ok[::shading_spp], z_c, np.nan)
        else:
            pos = mi.Point2f(mi.Float(((lanes % w) + jitter[lanes, 0]) / w),
                             mi.Float(((lanes // w) + jitter[lanes, 1]) / h))
            aperture = mi.Point2f(mi.Float(lens[lanes, 0]), mi.Float(lens[lanes, 1]))
            ray, weight = sensor.sample_ray_differential(mi.Float(t_abs), sampler.next_1d(), pos, aperture)
            spec, _, _ = integrator.sample(mi_scene, sampler, ray, sensor.get_medium(), True)
            value = spec * weight
            rgb[pix] = np.stack([np.asarray(value[i]) for i in range(3)], axis=-1).reshape(
                pix.size, shading_spp, 3).mean(axis=1)
            seen = np.ones(pix.size, bool)
        z, valid, p, si = _hit_depth(scene, mi_scene, ray, shading_spp, t_abs)
        valid &= seen
        depth[pix] = np.where(valid, z, np.inf)
        blocked[pix] = ~seen
        points[pix] = p
        raw = np.asarray(dr.reinterpret_array(mi.UInt32, si.shape))
        shape_idx[pix] = np.where(valid, [shape_of.get(int(r), -1) for r in raw], -1)
    if channel_depth is not None:   # a channel's ray the lens blocks is no sample: the middle ray's depth
        channel_depth[:, 1] = depth
        channel_depth = np.where(np.isnan(channel_depth), depth[:, None], channel_depth)
    return {"rgb": rgb, "depth": depth, "points": points, "shape_idx": shape_idx, "lens": lens,
            "t_frac": t_frac, "jitter": jitter, "blocked": blocked, "channel_depth": channel_depth}


def _hit_depth(scene: Scene, mi_scene, ray, lanes_per_pixel: int, t_abs: float) -> tuple:
    """What the first of every ``lanes_per_pixel`` rays of ``ray`` hits: its planar depth from
    the camera at ``t_abs`` (inf: nothing), whether it hit, the points and Mitsuba's interaction."""
    mi = mitsuba()
    first = mi.Ray3f(mi.Point3f(*(mi.Float(np.asarray(ray.o[i])[::lanes_per_pixel]) for i in range(3))),
                     mi.Vector3f(*(mi.Float(np.asarray(ray.d[i])[::lanes_per_pixel]) for i in range(3))))
    si = mi_scene.ray_intersect(first)
    valid = np.asarray(si.is_valid(), bool)
    p = np.stack([np.asarray(si.p[i], np.float64) for i in range(3)], axis=-1)
    z = (p - scene.camera.position_at(t_abs)) @ scene.camera.forward()
    return np.where(valid, z, np.inf), valid, p, si


def render_stochastic(scene: Scene, index: int = 0, max_motion_px: float = 0.0,
                      shading_spp: int = 1, medium: bool = False) -> LabelledImage:
    """One 1-spp stochastic image of ``scene`` with its lens samples and times.

    Parameters
    ----------
    scene : Scene
        A pinhole, thin-lens (round, iris or shaped aperture) or thick-lens scene.
    index : int
        Which independent image (seeds: :func:`stochastic_seed`); 4 spp is images 0-3.
    max_motion_px : float
        The longest motion vector on screen (the labelled input's); sets the sub-frames.
    shading_spp : int
        Paths traced from each pixel's camera ray (see the module docstring).
    medium : bool
        See :func:`trace_samples`.
    """
    w, h = scene.width, scene.height
    tr = trace_samples(scene, index, max_motion_px, shading_spp, medium)
    lens, depth, t_frac = tr["lens"], tr["depth"], tr["t_frac"]
    u, v = lens_channels(scene, lens)
    top = np.nextafter(np.float32(1.0), np.float32(0.0))
    sub = np.minimum(tr["jitter"].astype(np.float32), top)
    extra = {"lens.U": u.reshape(h, w), "lens.V": v.reshape(h, w), "time": t_frac.astype(np.float32).reshape(h, w),
             "subpixel.X": sub[:, 0].reshape(h, w), "subpixel.Y": sub[:, 1].reshape(h, w)}
    if scene_moves(scene):
        flow = np.zeros((h * w, 2), np.float32)
        hit = np.isfinite(depth)
        flow[hit] = _flow(scene, tr["points"][hit], t_frac[hit], tr["shape_idx"][hit])
        extra.update({"motion.X": flow[:, 0].reshape(h, w), "motion.Y": flow[:, 1].reshape(h, w)})
    header = scene.camera.camera_json()
    if scene.medium is not None:
        header["medium"] = scene.medium.header_json(scene.camera)
    if tr["channel_depth"] is not None:
        depths = np.where(tr["blocked"][:, None], tr["depth"][:, None], tr["channel_depth"])
        extra.update({f"Z.{name}": _fill_blocked(depths[:, c], tr["blocked"], (h, w))
                      for c, name in ((0, "R"), (2, "B"))})
    alpha = np.isfinite(depth).astype(np.float32).reshape(h, w)
    return LabelledImage(rgb=tr["rgb"].reshape(h, w, 3), alpha=alpha, depth=_fill_blocked(depth, tr["blocked"], (h, w)),
                         camera=header, extra=extra)


def _fill_blocked(depth: np.ndarray, blocked: np.ndarray, shape: tuple) -> np.ndarray:
    """(H, W) depths where a blocked pixel takes its nearest unblocked pixel's (it splats nothing,
    but its PSF coordinates must lie in the database's range)."""
    from scipy.ndimage import distance_transform_edt

    depth, blocked = depth.reshape(shape), blocked.reshape(shape)
    if not blocked.any() or blocked.all():
        return depth
    rows, cols = distance_transform_edt(blocked, return_distances=False, return_indices=True)
    return depth[rows, cols]

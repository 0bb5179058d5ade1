"""Re-centring a stochastic image (LSR18 6.2, Fig. 7 d-e): every pixel back to the film position
y' its surface has at the lens centre and mid-shutter, as a stack of ordinary frames.

A pixel at y with lens point d (:func:`~runtime_cl.stochastic.samples.concentric_disc`) and
shutter time t saw a surface whose pinhole position at mid-shutter is

    y' = y - c(Z) d - m (t - 1/2)

(c: the camera's signed CoC radius in pixels at the pixel's depth Z; m: its motion over the
shutter in film axes). Splatting each pixel's PSF around y' instead of y draws the blur once:
the samples of one surface point, spread over its CoC in the input, all return to one place.

With the default footprint a sample stands for its pixel's box moved by its shift y' - y (y its
film point: the ``subpixel`` channels, or the pixel centre), rounded to the nearest pixel (the box
filter of a pinhole image), so an in-focus sample stays whole on its own pixel; ``bilinear`` lays
it on the four pixels around its own y'. Samples are summed, not averaged: a pixel of the input is
one sample of its pinhole point's light, so k samples landing on one pixel carry k pixels' worth of
that light, and a pixel no sample lands on is dark. A target pixel can receive samples of different
surfaces (an edge seen past a blurred occluder): samples whose CoCs and motions agree within
``coc_bin_px`` and ``motion_bin_px`` share one entry (their depth and motion averaged); the others
go to further frames (*slots*), so each surface keeps its own PSF. The frames are splatted
separately and summed (splatting is linear).

Samples whose y' leaves the image saw a surface outside the frame through the lens (a lamp just
above it, whose bokeh reaches in): with ``margin`` the frames are that much wider on every side,
so those samples keep their light and their PSFs spread it back into the frame (the caller
splats the wider frames with :func:`widened` camera and crops the margin). Without a margin, or
beyond it, they are dropped, as a pinhole input holds nothing outside the frame.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from runtime_cl.errors import InputError
from runtime_cl.frame import Frame
from runtime_cl.stochastic.samples import concentric_disc, film_points
from runtime_cl.camera.exit_pupil import PupilBoxes
from runtime_cl.stochastic.thick import is_thick, thick_positions

__all__ = ["FOOTPRINTS", "Recentred", "recentre", "pinhole_positions", "widened"]

FOOTPRINTS = ("nearest", "bilinear")


@dataclass(frozen=True)
class Recentred:
    """The re-centred samples as frames to splat and sum.

    Attributes
    ----------
    frames : tuple of Frame
        Slot 0 holds, at every pixel, the first group of samples landing there; slot k the
        (k+1)-th. Empty entries are black with alpha 0 and the input's depth at that pixel (so
        their PSF coordinates stay in the range of a database sized for the input).
    counts : tuple of (H, W, 1) float32
        Per slot, how many samples each entry holds (splatted like the colour, the sample
        density of the normalised reconstruction).
    dropped : float
        Samples (bilinear: parts of samples) whose y' lies outside the image.
    max_shift_px : float
        The largest |y' - y|.
    margin : int
        Pixels the frames reach beyond the image on every side (0: the image's size).
    """

    frames: tuple
    counts: tuple
    dropped: float
    max_shift_px: float
    margin: int = 0


def _widens(camera) -> bool:
    """Whether :func:`widened` knows a camera for wider frames (not for a tilted or expressive
    focus: its focus map is laid out on the image's own pixels)."""
    lens = getattr(camera, "lens", None)
    return lens == "pinhole" or (lens == "thin" and not camera.has_focal_map)


def widened(camera, width: int, margin: int):
    """``camera`` for an image ``margin`` px wider on every side at the same pixel pitch, so CoCs
    in pixels, and every pixel's direction (a medium's light distance), stay those of the
    ``width``-px image."""
    if margin == 0:
        return camera
    scale = (width + 2 * margin) / width
    if getattr(camera, "lens", None) == "pinhole":   # the field of view widens
        return replace(camera, fov_deg=math.degrees(2 * math.atan(math.tan(math.radians(camera.fov_deg) / 2) * scale)))
    if not _widens(camera):
        raise InputError(f"a {getattr(camera, 'lens', None)!r} camera with a per-pixel focus cannot be widened "
                         "beyond its image; re-centre without a margin (keep_outside = False)")
    return replace(camera, sensor_width_mm=camera.sensor_width_mm * scale)


def pinhole_positions(depth, samples, camera, motion=None) -> np.ndarray:
    """(H, W, 2) float64 film positions y' (x right, y down; pixel centres at i + 0.5) of every
    pixel's surface at the lens centre and mid-shutter.

    Parameters
    ----------
    depth : (H, W)
        Planar depth Z in metres of what each sample saw.
    samples : (H, W, 3) or (H, W, 5)
        ``lens.U, lens.V, time`` and optionally ``subpixel.X, subpixel.Y``
        (:func:`~runtime_cl.stochastic.samples.lens_time_samples`).
    camera : runtime camera
        Its ``coc_radius_px(z, width)`` gives the signed CoC (0 for a pinhole).
    motion : (H, W, 2), optional
        ``motion.X, motion.Y`` in pixels over the shutter, Y up.
    """
    w = np.shape(depth)[1]
    dx, dy = concentric_disc(samples[..., 0], samples[..., 1])
    c = np.asarray(camera.coc_radius_px(np.asarray(depth, np.float64), w), np.float64)
    return film_points(samples) - np.stack([c * dx, c * dy], axis=-1) - _motion_shift(samples, motion)


def _deposits(pos, w: int, h: int, footprint: str) -> tuple:
    """Where each sample's light goes: (source index, target pixel, weight) per deposit, inside
    the image. ``"nearest"``: the pixel holding ``pos`` (the caller gives its pixel centre moved by
    the sample's shift); ``"bilinear"``: the four pixels around ``pos`` (the sample's own y'),
    weighted by the tent of one pixel (no sample is moved by rounding)."""
    if footprint == "nearest":
        corners = [(np.floor(pos), np.ones(len(pos)))]
    else:
        base = np.floor(pos - 0.5)
        frac = pos - 0.5 - base
        corners = [(base + (i, j), np.where(i, frac[:, 0], 1.0 - frac[:, 0]) * np.where(j, frac[:, 1], 1.0 - frac[:, 1]))
                   for i in (0, 1) for j in (0, 1)]
    src, target, weight = [], [], []
    for at, wt in corners:
        tx, ty = at[:, 0], at[:, 1]
        keep = np.flatnonzero((tx >= 0) & (tx < w) & (ty >= 0) & (ty < h) & (wt > 0.0))
        src.append(keep)
        target.append((ty[keep] * w + tx[keep]).astype(np.int64))
        weight.append(wt[keep])
    return np.concatenate(src), np.concatenate(target), np.concatenate(weight)


def recentre(frame: Frame, samples, camera, coc_bin_px: float = 1.0, motion_bin_px: float = 1.0,
             footprint: str = "nearest", keep_outside: bool = False) -> Recentred:
    """Re-centre a stochastic ``frame`` (its per-pixel ``samples``: lens.U, lens.V, time).

    Parameters
    ----------
    frame : Frame
        The 1-spp image: colour, depth Z of what each pixel's sample saw, optional motion and alpha.
    samples : (H, W, 3) or (H, W, 5) float32
        Checked ``lens.U, lens.V, time`` in [0, 1), and optionally ``subpixel.X, subpixel.Y``.
    camera : runtime camera
    coc_bin_px, motion_bin_px : float
        Samples landing on one pixel share an entry when their CoCs, and each component of their
        motion vectors, fall in the same bin of this many pixels (a light and the wall behind it
        have nearly the same CoC but not the same motion).
    footprint : {"nearest", "bilinear"}
        How a sample lands on the pixel grid (:func:`_deposits`).
    keep_outside : bool, default False
        Make the frames wider on every side by the largest |y' - y| (rounded up, at most half the
        image's larger side), so they hold the samples re-centred outside the image (splat them
        with :func:`widened` camera); their empty entries take the nearest image pixel's depth.
        Cameras :func:`widened` cannot widen get no margin.

    Returns
    -------
    Recentred

    A thick lens (:mod:`runtime_cl.stochastic.thick`) re-centres each colour channel through the
    lens at its own wavelength, at the depth its own ray hit (``frame.channel_depth``; default the
    frame's depth): its frames hold one channel each and their counts (H, W, C) that channel's
    samples. A channel's sample whose ray the lens blocks is dropped, and so is every channel of a
    pixel whose middle-channel ray it blocks (the stochastic input leaves it empty).
    """
    if footprint not in FOOTPRINTS:
        raise InputError(f"footprint = {footprint!r}: give one of {list(FOOTPRINTS)}")
    options = dict(coc_bin_px=coc_bin_px, motion_bin_px=motion_bin_px, footprint=footprint, keep_outside=keep_outside,
                   film=film_points(samples))
    motion = None if frame.motion is None else np.asarray(frame.motion, np.float64)
    if not is_thick(camera):
        return _recentre(frame, pinhole_positions(frame.depth, samples, camera, motion), camera, **options)
    rgb = np.asarray(frame.rgb, np.float32)
    boxes = PupilBoxes.for_camera(camera, rgb.shape[:2])
    depths = [frame.depth if frame.channel_depth is None else np.asarray(frame.channel_depth)[..., c]
              for c in range(rgb.shape[2])]
    positions = [thick_positions(z, samples, camera, c, boxes) - _motion_shift(samples, motion)
                 for c, z in enumerate(depths)]
    # a pixel whose middle-wavelength ray the lens blocks is no sample (lab.reference.stochastic)
    blocked = np.isnan(positions[rgb.shape[2] // 2][..., :1])
    parts = []
    for c, pos in enumerate(positions):
        pos = np.where(blocked, np.nan, pos)
        mono = np.zeros_like(rgb)
        mono[..., c] = rgb[..., c]
        rec = _recentre(replace(frame, rgb=mono, depth=depths[c], channel_depth=None), pos, camera, **options)
        counts = []
        for n in rec.counts:
            k = np.zeros(n.shape[:2] + (rgb.shape[2],), np.float32)
            k[..., c] = n[..., 0]
            counts.append(k)
        parts.append(replace(rec, counts=tuple(counts)))
    return Recentred(sum((r.frames for r in parts), ()), sum((r.counts for r in parts), ()),
                     sum(r.dropped for r in parts) / len(parts), max(r.max_shift_px for r in parts), 0)


def _motion_shift(samples, motion) -> np.ndarray | float:
    """(H, W, 2) film shift of each sample's surface from mid-shutter to its time (0 without
    motion): ``m (t - 1/2)``, motion Y up, film y down."""
    if motion is None:
        return 0.0
    lag = np.asarray(samples, np.float64)[..., 2] - 0.5
    return np.stack([motion[..., 0] * lag, -motion[..., 1] * lag], axis=-1)


def _recentre(frame: Frame, pos: np.ndarray, camera, coc_bin_px: float, motion_bin_px: float, footprint: str,
              keep_outside: bool, film: np.ndarray) -> Recentred:
    """:func:`recentre` of the samples at pinhole positions ``pos`` ((H, W, 2); NaN: no sample) seen
    at film positions ``film`` ((H, W, 2))."""
    rgb = np.asarray(frame.rgb, np.float32)
    h0, w0, nc = rgb.shape
    depth = np.asarray(frame.depth, np.float64)
    alpha = frame.coverage()
    motion = None if frame.motion is None else np.asarray(frame.motion, np.float64)
    shift = pos - film
    largest = float(np.nanmax(np.abs(shift), initial=0.0))
    # (+1: a bilinear footprint's neighbour; nothing moved, nothing leaves: a still pinhole)
    margin = min(math.ceil(largest) + 1, max(h0, w0) // 2) if keep_outside and _widens(camera) and largest > 0 else 0
    h, w = h0 + 2 * margin, w0 + 2 * margin
    if footprint == "nearest":   # the sample stands for its pixel's box, moved: in focus it stays home
        pos = shift + (np.stack(np.mgrid[0:h0, 0:w0][::-1], axis=-1) + 0.5)
    src, target, weight = _deposits(pos.reshape(-1, 2) + margin, w, h, footprint)
    coc = np.asarray(camera.coc_radius_px(depth, w0), np.float64).ravel()[src]
    # one entry per (target pixel, CoC group, motion group): sums of colour and alpha, means of
    # 1/Z and motion; rows sort by target pixel first
    groups = [target, np.round(coc / coc_bin_px).astype(np.int64)]
    if motion is not None:
        groups += [np.round(motion[..., k].ravel()[src] / motion_bin_px).astype(np.int64) for k in range(2)]
    keys, entry = np.unique(np.stack(groups, axis=1), axis=0, return_inverse=True)
    entry = entry.ravel()
    n = keys.shape[0]
    count = np.bincount(entry, weight, n)
    col = np.stack([np.bincount(entry, weight * rgb.reshape(-1, nc)[src, k], n) for k in range(nc)], axis=-1)
    cov = np.bincount(entry, weight * alpha.ravel()[src], n)
    inv_z = np.bincount(entry, weight / depth.ravel()[src], n) / count
    flow = None
    if motion is not None:
        flow = np.stack([np.bincount(entry, weight * motion[..., k].ravel()[src], n) / count for k in range(2)],
                        axis=-1)
    # entries sorted by key are grouped by target pixel; the rank within the pixel is the slot
    entry_target = target[np.unique(entry, return_index=True)[1]]
    first = np.r_[0, np.flatnonzero(np.diff(entry_target)) + 1]
    slot = np.arange(n) - np.repeat(first, np.diff(np.r_[first, n]))
    frames, counts = [], []
    # at least one frame: with no sample at all (a lens that blocked every ray) an empty one
    for k in range(max(int(slot.max(initial=-1)) + 1, 1)):
        sel = slot == k
        t = entry_target[sel]
        f_rgb = np.zeros((h * w, nc), np.float32)
        f_rgb[t] = col[sel]
        f_a = np.zeros(h * w, np.float32)
        f_a[t] = np.minimum(cov[sel], 1.0)
        # empty entries keep the (nearest) input depth: inside any range the database fits
        f_z = np.pad(depth, margin, mode="edge").ravel()
        with np.errstate(divide="ignore"):
            f_z[t] = 1.0 / inv_z[sel]
        f_n = np.zeros(h * w, np.float32)
        f_n[t] = count[sel]
        counts.append(f_n.reshape(h, w, 1))
        f_m = None
        if flow is not None:
            f_m = np.zeros((h * w, 2), np.float32)
            f_m[t] = flow[sel]
        frames.append(Frame(f_rgb.reshape(h, w, nc), f_z.reshape(h, w).astype(np.float32),
                            alpha=f_a.reshape(h, w),
                            motion=None if f_m is None else f_m.reshape(h, w, 2)))
    dropped = float(h0 * w0 - weight.sum())   # samples (or, bilinear, parts of samples) outside the frames
    return Recentred(tuple(frames), tuple(counts), dropped, largest, int(margin))

"""The stochastic channels of a labelled-pixel image: ``lens.U``, ``lens.V`` and ``time``.

Contract (DESIGN.md, labelled-pixel image): each pixel holds ONE path sample (a 1-spp image).
``lens.U, lens.V`` in [0, 1) are its lens sample; its point on the unit aperture disc is the
concentric map (Shirley-Chiu, Mitsuba's ``square_to_uniform_disk_concentric``) in the film's
pixel axes, x right and y down: :func:`concentric_disc`. ``time`` in [0, 1) is its shutter time
as a fraction of the shutter. A surface that the pinhole at the lens centre sees at film position
y' (in pixels) at time t is seen through lens point d at y = y' + c(Z) d, c the signed CoC
radius in pixels (positive behind the focus plane), and moves on the film by the motion vector
times t over the shutter. Through a thick lens (camera ``"lens": "thick"``) ``lens.U, lens.V``
are instead the sample's exit-pupil box coordinates, from which the runtime re-traces its ray
through the lens per channel (:mod:`runtime_cl.stochastic.thick`), and the lens disperses them:
``Z.R, Z.G, Z.B`` (:data:`CHANNEL_DEPTHS`, optional; a missing one is ``Z``) are the depths each
channel's ray hit, so each channel's sample goes back to its own surface. ``subpixel.X,
subpixel.Y`` (:data:`SUBPIXEL`, optional, both or neither) in [0, 1) are where in its pixel the
sample's film point lies (x right, y down; missing: the pixel's centre, 0.5), so it goes back
from there and not from the centre.
"""
from __future__ import annotations

import numpy as np

from runtime_cl.errors import InputError

__all__ = ["CHANNELS", "CHANNEL_DEPTHS", "SUBPIXEL", "channel_depths", "concentric_disc", "film_points",
           "inverse_concentric", "lens_time_samples"]

CHANNELS = ("lens.U", "lens.V", "time")
CHANNEL_DEPTHS = ("Z.R", "Z.G", "Z.B")
SUBPIXEL = ("subpixel.X", "subpixel.Y")
_FIX = ("write the pixel's lens sample (lens.U, lens.V) and its shutter time as a fraction of the shutter "
        "(time), each in [0, 1), e.g. with `splatlab stochastic SCENE`")
_FIX_SUBPIXEL = f"write both {list(SUBPIXEL)}: where in its pixel each sample lies, x right and y down, in [0, 1)"


def concentric_disc(u, v) -> tuple:
    """Shirley-Chiu concentric map of [0, 1)^2 onto the unit disc (area preserving): (dx, dy)."""
    a, b = 2.0 * np.asarray(u, np.float64) - 1.0, 2.0 * np.asarray(v, np.float64) - 1.0
    steep = np.abs(a) < np.abs(b)
    r = np.where(steep, b, a)
    with np.errstate(divide="ignore", invalid="ignore"):
        phi = 0.25 * np.pi * np.where(steep, a, b) / r
    phi = np.where(steep, 0.5 * np.pi - phi, phi)
    phi = np.where(r == 0.0, 0.0, phi)
    return r * np.cos(phi), r * np.sin(phi)


def inverse_concentric(dx, dy) -> tuple:
    """The (u, v) in [0, 1)^2 that :func:`concentric_disc` maps to the disc point (dx, dy)."""
    x, y = np.asarray(dx, np.float64), np.asarray(dy, np.float64)
    r = np.hypot(x, y)
    phi = np.arctan2(y, x)
    # wedge |phi| <= pi/4 (r = a > 0), its mirror around pi (r = a < 0), and the two steep wedges
    a, b = np.empty_like(r), np.empty_like(r)
    right, left = np.abs(phi) <= 0.25 * np.pi, np.abs(phi) >= 0.75 * np.pi
    up = ~right & ~left & (phi > 0)
    down = ~right & ~left & (phi <= 0)
    a[right], b[right] = r[right], r[right] * phi[right] / (0.25 * np.pi)
    pl = np.where(phi[left] > 0, phi[left] - np.pi, phi[left] + np.pi)
    a[left], b[left] = -r[left], -r[left] * pl / (0.25 * np.pi)
    b[up], a[up] = r[up], r[up] * (0.5 * np.pi - phi[up]) / (0.25 * np.pi)
    pd = phi[down] + np.pi
    b[down], a[down] = -r[down], -r[down] * (0.5 * np.pi - pd) / (0.25 * np.pi)
    u, v = 0.5 * (a + 1.0), 0.5 * (b + 1.0)
    top = np.nextafter(1.0, 0.0)
    return np.minimum(u, top), np.minimum(v, top)


def lens_time_samples(channels: dict, source: str, shape: tuple) -> np.ndarray:
    """The checked ``(H, W, 3)`` float32 stack of :data:`CHANNELS` from ``channels`` (name -> (H, W)),
    ``(H, W, 5)`` with :data:`SUBPIXEL` after them when the image has those.

    Raises
    ------
    InputError
        A channel is missing (or one of :data:`SUBPIXEL` without the other), of another size, not
        finite or outside [0, 1): one line naming ``source``, the channel, the bad value and the fix.
    """
    missing = [c for c in CHANNELS if c not in channels]
    if missing:
        raise InputError(f"{source}: channel(s) {missing} missing; a stochastic input needs {list(CHANNELS)}: {_FIX}")
    names = CHANNELS
    if any(c in channels for c in SUBPIXEL):
        lone = [c for c in SUBPIXEL if c not in channels]
        if lone:
            raise InputError(f"{source}: channel {lone[0]} missing beside {[c for c in SUBPIXEL if c in channels][0]}; "
                             f"{_FIX_SUBPIXEL} or neither (the pixel centres)")
        names = CHANNELS + SUBPIXEL
    out = np.empty(tuple(shape) + (len(names),), np.float32)
    for k, name in enumerate(names):
        fix = _FIX_SUBPIXEL if name in SUBPIXEL else _FIX
        ch = np.asarray(channels[name], np.float32)
        if ch.shape != tuple(shape):
            raise InputError(f"{source}: channel {name} is {ch.shape}, the image is {tuple(shape)}; {fix}")
        bad = ~(np.isfinite(ch) & (ch >= 0.0) & (ch < 1.0))
        if bad.any():
            y, x = np.argwhere(bad)[0]
            raise InputError(f"{source}: channel {name} = {float(ch[y, x])!r} at pixel (x={x}, y={y}) "
                             f"({int(bad.sum())} pixel(s)) lies outside [0, 1); {fix}")
        out[..., k] = ch
    return out


def film_points(samples) -> np.ndarray:
    """(H, W, 2) float64 film positions (x right, y down, pixel centres at i + 0.5) of the samples
    of ``samples`` (:func:`lens_time_samples`): each pixel's ``subpixel.X, subpixel.Y`` or its
    centre."""
    h, w = np.shape(samples)[:2]
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    inside = np.asarray(samples, np.float64)[..., 3:5] if np.shape(samples)[-1] == 5 else 0.5
    return np.stack([xs, ys], axis=-1) + inside


def channel_depths(channels: dict, source: str, depth) -> np.ndarray | None:
    """``(H, W, 3)`` float32: per colour channel, the planar depth (m) its sample's ray hit, from
    :data:`CHANNEL_DEPTHS` (a missing one: ``depth``, the image's Z); None when ``channels``
    (name -> (H, W)) holds none of them.

    Raises
    ------
    InputError
        A depth channel of another size, NaN, or not above 0 (inf: the ray hit nothing): one line
        naming ``source``, the channel, the bad value and the fix.
    """
    if not any(name in channels for name in CHANNEL_DEPTHS):
        return None
    depth = np.asarray(depth, np.float32)
    out = np.empty(depth.shape + (3,), np.float32)
    for k, name in enumerate(CHANNEL_DEPTHS):
        ch = np.asarray(channels.get(name, depth), np.float32)
        if ch.shape != depth.shape:
            raise InputError(f"{source}: channel {name} is {ch.shape}, the image is {depth.shape}; write one "
                             "depth per pixel")
        bad = ~(ch > 0.0)   # NaN too
        if bad.any():
            y, x = np.argwhere(bad)[0]
            raise InputError(f"{source}: channel {name} = {float(ch[y, x])!r} at pixel (x={x}, y={y}) "
                             f"({int(bad.sum())} pixel(s)) is no depth; write the planar depth in metres (> 0, "
                             "inf: nothing) that the channel's ray hit, e.g. with `splatlab stochastic SCENE`")
        out[..., k] = ch
    return out

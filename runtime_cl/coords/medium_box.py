"""Coordinate map of ``volume_box``: each pixel's segment of its camera ray inside a box of medium.

The pixel's ray leaves the centre of projection along (x / f_px, y / f_px, 1) (camera frame: x
right, y up, z the optical axis) and ends at the point it sees, at distance D = Z sqrt(1 + (x^2 +
y^2) / f_px^2). The box (centre, edge directions, half sizes in that frame: the input header's
``medium.box``, which the database's fingerprint must match) cuts it by the slab method into
[t0, t1] (clipped to [0, D]; empty: t0 = t1). The PSF coordinates are the three lengths the
light crosses (:mod:`lab.psf_tracing.models.volume_box`): camera gap t0, length in the medium
t1 - t0, and gap behind the box D - t1. Beside them the map returns, per pixel:

- ``direct`` = exp(-sigma_t (t1 - t0)): the light that reaches the pixel unscattered, added
  exactly (Beer-Lambert), since the database holds the scattered light only;
- ``gain``: how much light the pixel scatters, 1 - exp(-sigma_t L), over what its cell's PSF holds,
  the mean of the same over the cell's lengths [lo, hi] (the PSFs are pre-filtered over their cell:
  a pixel 5 cm deep in the box would otherwise scatter as if 0.3 m deep); 0 where the ray misses;
- ``receive`` = the same mask on the output: light reaches the camera scattered only from points
  of the medium, i.e. only along the rays of pixels that cross the box. The PSFs, traced in an
  unbounded shell, spread a light's halo across the frame; in a box it stops at the box's outline.
"""
from __future__ import annotations

import numpy as np

from runtime_cl.psf.grid import triangular, triangular_root
from runtime_cl.coords.common import (PsfCoords, as_depth, check_symmetries, expect_space, in_range, pixel_offsets,
                                      register)
from runtime_cl.errors import InputError
from runtime_cl.psf.database import SpreadletDatabase

NAMES = ("camera_gap_m", "medium_length_m", "light_gap_m")


def box_segments(directions: np.ndarray, distance: np.ndarray, box: dict) -> tuple[np.ndarray, np.ndarray]:
    """(t0, t1), each shaped like ``distance``: the part [t0, t1] of each ray from the origin along
    unit ``directions`` (..., 3) up to ``distance`` that lies inside ``box`` (``center``, ``axes``
    rows, ``half_size``; camera frame). A ray missing the box has t0 = t1 (= its clipped entry)."""
    axes = np.asarray(box["axes"], np.float64)
    origin = axes @ -np.asarray(box["center"], np.float64)          # the camera in box coordinates
    u = directions @ axes.T
    half = np.asarray(box["half_size"], np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = (-half - origin) / u
        b = (half - origin) / u
    # a ray parallel to a slab: inside it for all t (enters at -inf, leaves at +inf), or never
    # (enters at +inf, after it has left any other slab)
    parallel = u == 0
    inside = np.abs(origin) < half
    a = np.where(parallel, np.where(inside, -np.inf, np.inf), a)
    b = np.where(parallel, np.inf, b)
    enter = np.minimum(a, b).max(axis=-1)
    leave = np.maximum(a, b).min(axis=-1)
    t0 = np.clip(enter, 0.0, distance)
    t1 = np.clip(leave, 0.0, distance)
    return t0, np.maximum(t1, t0)


def pixel_rays(camera, depth) -> tuple[np.ndarray, np.ndarray]:
    """(unit directions (H, W, 3), distances (H, W)) of each pixel's ray to the point it sees."""
    z = as_depth(depth)
    h, w = z.shape
    f_px = camera.focal_px(w)
    x, y = pixel_offsets(h, w)
    d = np.stack([x / f_px, y / f_px, np.ones_like(x)], axis=-1)
    norm = np.linalg.norm(d, axis=-1)
    return d / norm[..., None], z * norm


def cell_range(grid, coords: np.ndarray, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi): the physical range along ``dim`` of the nested-grid cell holding each point of
    ``coords`` (..., ns) -- the box its PSF was pre-filtered over (``lab.psf_tracing.space.boxes``)."""
    g = grid.to_grid(grid.normalise(coords))
    level = np.minimum(triangular_root(g.min(axis=-1)), grid.levels - 1)
    t0, w = triangular(level), level + 1
    k = np.clip(np.floor((g[..., dim] - t0) / w), 0, -(-(grid.n - t0) // w) - 1)
    glo = t0 + k * w
    ghi = np.minimum(glo + w, grid.n)
    lo, hi = grid.ranges[dim]
    beta = grid.beta[dim]
    return (lo + (glo / grid.n) ** beta * (hi - lo), lo + (ghi / grid.n) ** beta * (hi - lo))


def scattered_fraction_gain(sigma_t: float, length: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(1 - exp(-sigma_t L)) over its mean on [lo, hi] (hi > lo): a pixel's scattered light relative
    to its cell's PSF, which averages it over the cell's lengths."""
    mean_kept = (np.exp(-sigma_t * lo) - np.exp(-sigma_t * hi)) / (sigma_t * (hi - lo))
    return (1.0 - np.exp(-sigma_t * length)) / (1.0 - mean_kept)


def header_box(db: SpreadletDatabase) -> dict:
    """The box the database was traced for (its fingerprint's ``medium.box``)."""
    box = ((db.params.get("fingerprint") or {}).get("medium") or {}).get("box")
    if not isinstance(box, dict) or set(box) != {"center", "axes", "half_size"}:
        raise InputError("volume_box database: its fingerprint holds no medium box; rebuild it with "
                         "`splatlab precompute SCENE` on a scene whose [medium] has a box")
    return box


@register("volume_box", attenuates=True)
def volume_box_coords(camera, depth, db: SpreadletDatabase, motion=None) -> PsfCoords:
    """``volume_box``: (camera gap, length in the box, gap behind it) per pixel, with the exact
    unscattered light ``direct`` and the ``gain`` of the scattered light (module docstring)."""
    expect_space(db, "volume_box", NAMES)
    check_symmetries(db, ("rotation",))
    directions, distance = pixel_rays(camera, depth)
    if not np.all(np.isfinite(distance)):
        raise InputError(f"depth: {int(np.count_nonzero(~np.isfinite(distance)))} pixel(s) see nothing "
                         "(infinite depth); a volume_box render needs every pixel's distance: close the view")
    t0, t1 = box_segments(directions, distance, header_box(db))
    length = t1 - t0
    crossed = length > 0
    sigma_t = float(db.params["fingerprint"]["medium"]["sigma_t"])
    # pixels missing the box take the range's low corner: their gain is 0, their cell is never drawn
    lows = [r[0] for r in db.grid.ranges]
    parts = [np.where(crossed, v, lows[i]) for i, v in enumerate((t0, length, distance - t1))]
    coords = [in_range(name, v, db, i, "m", lambda lo, hi, name=name: f"rebuild the database with a "
                       f"{name} range holding [{lo:.4g}, {hi:.4g}]") for i, (name, v) in enumerate(zip(NAMES, parts))]
    stacked = np.stack(coords, axis=-1)
    lo, hi = cell_range(db.grid, stacked.astype(np.float64), 1)
    gain = np.where(crossed, scattered_fraction_gain(sigma_t, length, lo, hi), 0.0)
    return PsfCoords(stacked, None, direct=np.exp(-sigma_t * length).astype(np.float32),
                     gain=gain.astype(np.float32), receive=crossed.astype(np.float32))

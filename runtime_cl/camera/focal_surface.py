"""Per-pixel focus of a thin lens (LES10 section 5): a tilted sensor (Scheimpflug) or an expressive
focal surface, as one map of inverse in-focus distance per pixel that every thin-lens pass reads.

In the pinhole image of the lens centre (the labelled pixels), pixel p's chief ray has direction
d = (dx, dy, 1) (dx right, dy up, in units of the pinhole's focal distance f_px). All lens rays of
a sensor point converge on the chief ray at the sensor point's conjugate depth z_f(p), so in pinhole
coordinates, parametrised by w = 1/z, the ray through lens point xi a is

    q(w) = p - xi S (w_f(p) - w),      w_f(p) = 1 / z_f(p),

the untilted thin lens's line with its own 1/F replaced by w_f(p) (S = a f_px: CoC px per
dioptre). The CoC of depth z at p is S (w_f(p) - 1/z): only w_f changes, so the camera twin owns a
map of it (:meth:`runtime_cl.camera.thin_lens.ThinLens.inverse_focus_map`) and the passes take it
from there.

Tilted sensor (``"sensor_tilt_deg": [tx, ty]`` in the header): the sensor plane passes through the
on-axis image point at distance v behind the lens, and its distance behind the lens grows by
tan(tx) per unit of sensor x and tan(ty) per unit of sensor y (camera space: x image-right, y up),
v_s = v + gx X + gy Y. The sensor point of chief direction d is X = -v_s d, so v_s = v / (1 + gx dx
+ gy dy), and the thin lens's conjugate 1/z_f = 1/f - 1/v_s gives

    w_f(p) = 1/F - (gx dx + gy dy) / v,

affine in the pixel: the in-focus points form a plane (Scheimpflug). A plane n.X = c in camera space
is the set 1/z = (n.d) / c, so the plane is in focus exactly when 1/F = nz / c, gx = -v nx / c,
gy = -v ny / c (:func:`scheimpflug_tilt`).

Expressive surface (``"focal_surface"``): constraints (pixel, focal depth) interpolated in inverse
depth over the image by moving least squares, weights alpha / d^beta in screen-space distance d
(LES10 5.2), a plane fitted per pixel (so a tilted plane's constraints are reproduced exactly, and
each constraint pixel exactly: its weight is infinite); ``dof_extent`` scales the depth of field
of the lens (2: twice as deep, half the blur), a single scalar as in LES10.
"""
from __future__ import annotations

import math

import numpy as np

from runtime_cl.errors import InputError
from runtime_cl.json_values import is_number

__all__ = ["MAX_CONSTRAINTS", "MAX_TILT_DEG", "SURFACE_KEYS", "chief_directions", "check_tilt", "expressive_inverse_focus", "read_surface",
           "scheimpflug_tilt", "tilt_inverse_focus"]

# A sensor tilted this far is no camera (a real tilt-shift lens tilts by about 10 degrees): the
# focal plane then nearly contains the view direction.
MAX_TILT_DEG = 60.0
MAX_CONSTRAINTS = 256   # expressive constraints: a hand-made list, and the MLS is O(pixels x constraints)
MAX_PIXEL = 1 << 16     # a constraint's pixel coordinates: the largest image side the lab renders, and more


def chief_directions(height: int, width: int, f_px: float) -> tuple:
    """(dx, dy): per pixel centre, the chief ray's direction per unit depth (x right, y up)."""
    y = (height / 2.0 - 0.5 - np.arange(height, dtype=np.float64))[:, None] / f_px
    x = (np.arange(width, dtype=np.float64) + 0.5 - width / 2.0)[None, :] / f_px
    return np.broadcast_to(x, (height, width)), np.broadcast_to(y, (height, width))


def check_tilt(tilt, source: str = "camera") -> tuple:
    """``tilt`` ([tx, ty] degrees) as a tuple of floats; InputError naming ``source``."""
    if not (isinstance(tilt, (list, tuple)) and len(tilt) == 2 and all(is_number(t) for t in tilt)):
        raise InputError(f"{source} sensor_tilt_deg = {tilt!r}: give [tilt_x, tilt_y] in degrees, e.g. [0, 4.5]")
    if max(abs(t) for t in tilt) > MAX_TILT_DEG:
        raise InputError(f"{source} sensor_tilt_deg = {list(tilt)}: a tilt beyond {MAX_TILT_DEG:g} degrees puts "
                         "the focal plane along the view direction; tilt less, or focus on points across the view")
    return float(tilt[0]), float(tilt[1])


def tilt_inverse_focus(height: int, width: int, f_px: float, inv_focus: float, image_distance_m: float,
                       tilt_deg) -> np.ndarray:
    """(H, W) float64 w_f(p) = 1/F - (gx dx + gy dy) / v of a sensor tilted by ``tilt_deg`` (module
    docstring); ``f_px`` the pinhole focal distance in pixels, v = ``image_distance_m``."""
    gx, gy = (math.tan(math.radians(t)) for t in tilt_deg)
    dx, dy = chief_directions(height, width, f_px)
    return inv_focus - (gx * dx + gy * dy) / image_distance_m


def scheimpflug_tilt(normal, offset: float, focal_length_m: float) -> tuple:
    """The thin lens that has the plane ``normal . X = offset`` (camera space, metres; x right, y up,
    z forward) in focus: (focus distance F on the axis in metres, sensor tilt [tx, ty] in degrees).

    Raises
    ------
    InputError
        The plane contains the lens centre or runs along the optical axis (no finite F: the view
        direction lies in it), crosses the axis closer than the focal length, or needs a tilt beyond
        :data:`MAX_TILT_DEG`.
    """
    n = np.asarray(normal, np.float64) / np.linalg.norm(normal)
    c = float(offset) / float(np.linalg.norm(normal))
    if abs(c) < focal_length_m:
        raise InputError(f"focal plane normal {np.round(n, 3).tolist()}, {c:.4g} m from the lens centre: it passes "
                         "through the lens, so it contains the view direction; choose focus points whose plane "
                         "faces the camera")
    inv_f = n[2] / c
    if not inv_f > 0:
        raise InputError(f"focal plane normal {np.round(n, 3).tolist()}: it runs along the optical axis (the view "
                         "direction) or crosses it behind the camera, so no sensor tilt focuses it; choose focus "
                         "points whose plane crosses the view in front of the camera")
    if inv_f * focal_length_m >= 1.0:
        raise InputError(f"focal plane crossing the optical axis at {1 / inv_f:.4g} m, closer than the focal length "
                         f"({focal_length_m * 1000:g} mm); choose focus points farther away")
    v = 1.0 / (1.0 / focal_length_m - inv_f)
    tilt = [math.degrees(math.atan(-v * n[0] / c)), math.degrees(math.atan(-v * n[1] / c))]
    if max(abs(t) for t in tilt) > MAX_TILT_DEG:
        raise InputError(f"focal plane normal {np.round(n, 3).tolist()}: it needs a sensor tilt of "
                         f"{np.round(tilt, 1).tolist()} degrees, beyond {MAX_TILT_DEG:g}: the plane lies nearly along "
                         "the view direction; choose focus points whose plane faces the camera more")
    return 1.0 / inv_f, tuple(tilt)


SURFACE_KEYS = ("points", "alpha", "beta", "dof_extent")
MAX_DEPTH_M = 1e6       # a focal depth beyond is infinity to every lens here (1/z < 1e-6 dioptre)
MAX_ALPHA = 1e6         # weight ratios beyond leave the other constraints no say (and strain the MLS solve)
DOF_EXTENT = (0.01, 100.0)   # 0.01: 100 x the lens's blur (past any image); 100: all but sharp


def read_surface(data, source: str = "camera") -> dict:
    """The header's ``"focal_surface"``: ``{"points": [[x, y, depth_m], ...], "alpha": [...] (optional),
    "beta": 2, "dof_extent": 1}`` checked (every value finite and bounded); pixels are (column, row
    from the top)."""
    if not isinstance(data, dict) or "points" not in data:
        raise InputError(f"{source} focal_surface = {data!r}: give {{\"points\": [[x, y, depth_m], ...], \"beta\": 2, "
                         "\"dof_extent\": 1}} (alpha: optional weight per point)")
    unknown = sorted(set(data) - set(SURFACE_KEYS))
    if unknown:
        raise InputError(f"{source} focal_surface: unknown key(s) {unknown}; known keys are {list(SURFACE_KEYS)}")
    pts = data["points"]
    if not (isinstance(pts, (list, tuple)) and 1 <= len(pts) <= MAX_CONSTRAINTS and all(
            isinstance(p, (list, tuple)) and len(p) == 3 and all(is_number(v) for v in p)
            and abs(p[0]) <= MAX_PIXEL and abs(p[1]) <= MAX_PIXEL and 0 < p[2] <= MAX_DEPTH_M for p in pts)):
        raise InputError(f"{source} focal_surface points = {pts!r}: give 1 to {MAX_CONSTRAINTS} constraints "
                         f"[x_px, y_px, focal_depth_m] with 0 < depth <= {MAX_DEPTH_M:g} m")
    alpha = data.get("alpha", [1.0] * len(pts))
    if not (isinstance(alpha, (list, tuple)) and len(alpha) == len(pts)
            and all(is_number(a) and 0 < a <= MAX_ALPHA for a in alpha)):
        raise InputError(f"{source} focal_surface alpha = {alpha!r}: give one weight in (0, {MAX_ALPHA:g}] per "
                         f"point ({len(pts)})")
    beta, extent = data.get("beta", 2.0), data.get("dof_extent", 1.0)
    if not (is_number(beta) and 0.5 <= beta <= 8):
        raise InputError(f"{source} focal_surface beta = {beta!r}: use 0.5 to 8 (LES10: 2 to 4; larger is more local)")
    if not (is_number(extent) and DOF_EXTENT[0] <= extent <= DOF_EXTENT[1]):
        raise InputError(f"{source} focal_surface dof_extent = {extent!r}: the depth of field relative to the "
                         f"lens's own must be {DOF_EXTENT[0]:g} to {DOF_EXTENT[1]:g} (1: the lens's own)")
    return {"points": [[float(v) for v in p] for p in pts], "alpha": [float(a) for a in alpha],
            "beta": float(beta), "dof_extent": float(extent)}


def expressive_inverse_focus(height: int, width: int, surface: dict) -> np.ndarray:
    """(H, W) float64 inverse focal depth of an expressive ``surface`` (:func:`read_surface`):
    per pixel, the plane in (x, y) -> 1/z that fits the constraints by least squares weighted
    alpha / d^beta (d: distance to the constraint's pixel centre), or their weighted mean when fewer
    than three constraints do not span a plane. A constraint's own pixel gets its value."""
    pts = np.asarray(surface["points"], np.float64)
    rows = max(1, (1 << 22) // max(1, width * len(pts)))   # bounded (rows, W, n) temporaries
    return np.concatenate([_mls_rows(r, min(r + rows, height), width, pts, surface)
                           for r in range(0, height, rows)], axis=0)


def _mls_rows(r0: int, r1: int, width: int, pts: np.ndarray, surface: dict) -> np.ndarray:
    """:func:`expressive_inverse_focus` on rows r0..r1."""
    alpha = np.asarray(surface["alpha"], np.float64)
    px, py, target = pts[:, 0] + 0.5, pts[:, 1] + 0.5, 1.0 / pts[:, 2]
    y = np.arange(r0, r1, dtype=np.float64)[:, None, None] + 0.5
    x = np.arange(width, dtype=np.float64)[None, :, None] + 0.5
    dx, dy = px - x, py - y                                                 # (H, W, n) offsets, pixels
    d2 = dx * dx + dy * dy
    exact = d2 < 1e-12
    k = alpha / np.where(exact, 1.0, d2) ** (surface["beta"] / 2.0)
    s0, sx, sy = k.sum(-1), (k * dx).sum(-1), (k * dy).sum(-1)
    mean = (k * target).sum(-1) / s0
    if len(pts) >= 3 and np.linalg.matrix_rank(np.c_[np.ones(len(pts)), pts[:, :2]]) == 3:
        # Weighted least squares of target = c0 + c1 dx + c2 dy about the pixel: c0 is the value here.
        a = np.stack([np.stack([s0, sx, sy], -1), np.stack([sx, (k * dx * dx).sum(-1), (k * dx * dy).sum(-1)], -1),
                      np.stack([sy, (k * dx * dy).sum(-1), (k * dy * dy).sum(-1)], -1)], -2)
        b = np.stack([(k * target).sum(-1), (k * target * dx).sum(-1), (k * target * dy).sum(-1)], -1)
        value = np.linalg.solve(a, b[..., None])[..., 0, 0]
    else:
        value = mean
    hit = exact.any(-1)
    if hit.any():   # the singular weight: the constraint itself (the first one given there)
        value = np.where(hit, target[np.argmax(exact, axis=-1)], value)
    return value

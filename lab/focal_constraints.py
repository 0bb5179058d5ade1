"""Expressive focus constraints as a user writes them (LES10 5.2): in-focus depths and out-of-focus pixels.

``[camera] focal_surface`` of a thin lens (a scene or a ``--camera`` file)::

    focal_surface = { points = [[x, y, depth_m], ...],   # these pixels focus at that depth
                      blur = [[x, y, r_px], ...],        # what these pixels see blurs by r px
                      alpha = [...], beta = 2, dof_extent = 1 }

LES10: "our system also supports focus points that indicate out-of-focus regions. A user simply
specifies the offset with respect to a potential focal plane to achieve controlled defocus." A
``blur`` constraint is that offset in the unit a user sees: the signed CoC radius r (pixels) the
surface at pixel p seen by the pixel should get, positive when the point lies behind the focal
surface (the project's CoC sign), r = 0 to focus on whatever the pixel sees. With the depth z the
pixel sees (the labelled input's Z, or the pinhole ray the input traces) and the lens's CoC scale
S (pixels per dioptre, already divided by ``dof_extent``), CoC = S (w_f - 1/z) = r gives the
focal depth constraint 1 / w_f = 1 / (1/z + r/S). So a resolved surface is the runtime's plain
list of (pixel, focal depth) constraints (:func:`runtime_cl.camera.focal_surface.read_surface`),
interpolated per pixel by moving least squares, and the DOF extent scales every blur about it. A
constraint's own pixel gets its value exactly (its weight is singular), so the asked blur is met
there; away from it the MLS blends the constraints.

``alpha`` weights the constraints in order: ``points`` first, then ``blur``.
"""
from __future__ import annotations

import math

import numpy as np

from runtime_cl.camera.focal_surface import MAX_CONSTRAINTS, MAX_DEPTH_M, SURFACE_KEYS, read_surface
from runtime_cl.errors import InputError
from runtime_cl.json_values import is_number

from .errors import UserError

__all__ = ["SCENE_KEYS", "check_table", "resolve_blur", "unresolved"]

SCENE_KEYS = SURFACE_KEYS + ("blur",)
MAX_BLUR_PX = 4096    # a blur radius past the largest image side the lab renders blurs nothing more


def _at(where: str) -> str:
    return f"{where} focal_surface" if where else "focal_surface"


def check_table(table, where: str) -> dict:
    """``table`` (``[camera] focal_surface``) checked; UserError naming ``where``, the key and the fix.

    Returns the table with numbers as floats; ``blur`` stays until :func:`resolve_blur`."""
    if not isinstance(table, dict):
        raise UserError(f"{_at(where)} = {table!r}: write it as a table, e.g. focal_surface = "
                        "{ points = [[40, 30, 2.5]], blur = [[10, 50, 6.0]], dof_extent = 1 }")
    unknown = sorted(set(table) - set(SCENE_KEYS))
    if unknown:
        raise UserError(f"{_at(where)}: unknown key(s) {unknown}; known keys are {list(SCENE_KEYS)}")
    blur = table.get("blur", [])
    if not (isinstance(blur, (list, tuple)) and all(
            isinstance(b, (list, tuple)) and len(b) == 3 and all(is_number(v) for v in b)
            and min(b[0], b[1]) >= 0 and abs(b[2]) <= MAX_BLUR_PX for b in blur)):
        raise UserError(f"{_at(where)} blur = {blur!r}: give [[x_px, y_px, coc_radius_px], ...] with the "
                        f"pixel in the image and |radius| <= {MAX_BLUR_PX} (signed: > 0 blurs the point as if behind "
                        "the focal surface, < 0 in front, 0 focuses on it)")
    points = table.get("points", [])
    if not isinstance(points, (list, tuple)) or not 1 <= len(points) + len(blur) <= MAX_CONSTRAINTS:
        raise UserError(f"{_at(where)}: {len(points) if isinstance(points, (list, tuple)) else points!r} "
                        f"points and {len(blur)} blur constraints; give 1 to {MAX_CONSTRAINTS} in all")
    # The rest as the runtime checks it, with a placeholder point per blur constraint (depth 1 m).
    plain = {k: v for k, v in table.items() if k != "blur"}
    plain["points"] = list(points) + [[b[0], b[1], 1.0] for b in blur]
    try:
        if points:
            read_surface({"points": points}, where)   # its errors show the user's points alone
        checked = read_surface(plain, where)
    except InputError as exc:
        raise UserError(str(exc).strip()) from None
    out = dict(checked, points=checked["points"][:len(points)])
    if blur:
        out["blur"] = [[float(v) for v in b] for b in blur]
    return out


def unresolved(surface) -> bool:
    """True when ``surface`` still holds ``blur`` constraints (they need the depths their pixels see)."""
    return isinstance(surface, dict) and bool(surface.get("blur"))


def check_pixels_in(surface: dict, width: int, height: int, where: str) -> None:
    """UserError unless every constraint's pixel lies inside a ``width`` x ``height`` image."""
    for key in ("points", "blur"):
        for c in surface.get(key, []):
            if not (0 <= c[0] < width and 0 <= c[1] < height):
                raise UserError(f"{_at(where)} {key} [{c[0]:g}, {c[1]:g}, ...] is outside the {width} x "
                                f"{height} image; give a pixel with 0 <= x < {width} and 0 <= y < {height}")


def resolve_blur(surface: dict, coc_scale_px: float, depths, where: str) -> dict:
    """``surface`` with its ``blur`` constraints turned into focal-depth points (module docstring).

    Parameters
    ----------
    surface : dict
        As :func:`check_table` returns it.
    coc_scale_px : float
        The lens's CoC radius in pixels per dioptre with the surface's ``dof_extent`` (S).
    depths : callable
        ``depths(pixels) -> (n,) z`` in metres: what each (x, y) pixel sees (it raises a UserError
        for a pixel on the sky).
    where : str
        The file and table, for errors.
    """
    if not unresolved(surface):
        return {k: v for k, v in surface.items() if k != "blur"}
    blur = surface["blur"]
    pixels = [(int(math.floor(b[0])), int(math.floor(b[1]))) for b in blur]
    z = np.asarray(depths(pixels), np.float64)
    added = []
    for (x, y, r), d in zip(blur, z):
        w = 1.0 / d + r / coc_scale_px
        if not 1.0 / MAX_DEPTH_M <= w:
            most = coc_scale_px * (1.0 / d - 1.0 / MAX_DEPTH_M)
            raise UserError(f"{_at(where)} blur [{x:g}, {y:g}, {r:g}]: the pixel sees depth {d:.4g} m, and a "
                            f"blur of {r:g} px in front of the focal surface needs focus beyond infinity; ask for "
                            f"at most {most:.3g} px in front (r >= {-most:.3g}), or a blur behind it (r > 0)")
        added.append([float(x), float(y), 1.0 / w])
    return {"points": list(surface["points"]) + added, "alpha": surface["alpha"], "beta": surface["beta"],
            "dof_extent": surface["dof_extent"]}

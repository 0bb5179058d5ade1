"""Rectified apertures for the runtime's polygon pass (``splatlab render --method polygon``,
reports, ``splatlab bench polygon``).

A built-in aperture shape (:mod:`runtime_cl.polygon.shapes`) or a camera's iris
(:class:`lab.optics.iris.Iris`, ``[camera] aperture``) is rectified (MHU21 section 4,
:func:`lab.polygon.rectify.rectify`; a built-in shape at the default settings was rectified in
advance and ships with the runtime) and handed to the runtime's exact splatter
(:class:`runtime_cl.polygon.splat.PolygonSplatter`), which :class:`runtime_cl.passes.polygon.
PolygonPass` draws at every pixel's thin-lens ``|CoC|``.

The kernel is the iris as it images behind the focus plane; in front of it the PSF is rotated
by 180 degrees, which the runtime does not do: exact for point-symmetric irises (even blade
counts, the built-in regular shapes).
"""
from __future__ import annotations

import time
from dataclasses import dataclass


from .errors import UserError

__all__ = ["PolygonAperture", "polygon_aperture", "iris_aperture", "default_edges"]


def default_edges(name: str) -> int:
    """Edge budget N when none is given: the shape's own corners, at most 16 (heart, clover)."""
    from runtime_cl.polygon.shapes import shape

    return min(len(shape(name)), 16)


@dataclass
class PolygonAperture:
    """A rectified aperture and its splatter.

    Attributes
    ----------
    name : str
        Built-in shape name.
    directions_m : int
        D = :func:`lab.polygon.rectify.direction_set` (m).
    edges : int
        N, the rectification's edge budget.
    splatter : runtime_cl.polygon.splat.PolygonSplatter
    rectify_s : float
        Wall time of the rectification (graph construction + traversal), or of loading the
        shipped polygon (:func:`polygon_aperture`), seconds.
    """

    name: str
    directions_m: int
    edges: int
    splatter: object
    rectify_s: float


MAX_DIRECTIONS_M = 8   # D(8) has 88 edge directions, each a directional prefix sum per splat
MAX_EDGES = 256        # rectification time grows with N; 256 edges is beyond a visible polygon


def check_options(directions_m, edges) -> None:
    """``--directions M`` in [1, 8] and ``--edges N`` in [3, 256] (None: the default), as the
    command line names them."""
    if isinstance(directions_m, bool) or not isinstance(directions_m, int) or not 1 <= directions_m <= MAX_DIRECTIONS_M:
        raise UserError(f"--directions {directions_m}: edge directions take run and rise up to M, an integer "
                        f"in [1, {MAX_DIRECTIONS_M}] (|D(M)| grows as M^2 and each direction is a prefix sum); "
                        "MHU21 uses 2")
    if edges is not None and (isinstance(edges, bool) or not isinstance(edges, int) or not 3 <= edges <= MAX_EDGES):
        raise UserError(f"--edges {edges}: the rectified aperture's most edges, an integer in [3, {MAX_EDGES}] "
                        "(a polygon needs 3; rectification time grows with N), e.g. --edges 8")


def polygon_aperture(name: str = "hexagon", directions_m: int = 2, edges: int | None = None,
                     device=None) -> PolygonAperture:
    """The built-in shape ``name``'s rectified polygon and its splatter.

    With m = 2 and the default N the polygon is the one the runtime ships
    (:func:`runtime_cl.polygon.shapes.unit_polygon`, rectified by the lab in advance); other m or N
    rectify the outline here.

    Parameters
    ----------
    name : str, default "hexagon"
        One of :data:`runtime_cl.polygon.shapes.SHAPES`.
    directions_m : int, default 2
        Edge directions are all reduced (run, rise) with components up to m (MHU21: m = 2).
    edges : int, optional
        Most edges of the rectified polygon (default :func:`default_edges`).
    device : runtime_cl.device.opencl.Device, optional

    Raises
    ------
    UserError
        Unknown shape name, bad m or N (the messages list the choices or the smallest N).
    """
    from runtime_cl.polygon.shapes import SHAPES, SHIPPED_DIRECTIONS_M, shape, unit_polygon

    check_options(directions_m, edges)
    if name not in SHAPES:
        raise UserError(f"--aperture {name!r}: unknown shape; choose one of {', '.join(SHAPES)}")
    n = default_edges(name) if edges is None else edges
    if directions_m == SHIPPED_DIRECTIONS_M and n == default_edges(name):
        return _aperture(name, directions_m, n, lambda: unit_polygon(name), device)
    return _rectified(name, shape(name), directions_m, n, device)


def iris_aperture(iris, directions_m: int = 2, edges: int | None = None, device=None) -> PolygonAperture:
    """Rectify a camera's polygonal iris (as it images behind the focus plane) and build its splatter.

    Parameters
    ----------
    iris : lab.optics.iris.Iris
    directions_m, edges, device
        As for :func:`polygon_aperture`; ``edges`` defaults to the outline's vertices, at most 16.
    """
    check_options(directions_m, edges)
    outline = iris.outline() * [1.0, -1.0]        # lens plane (y up) -> image (y down), upright
    n = min(len(outline), 16) if edges is None else edges
    return _rectified(f"iris{iris.blades}", outline, directions_m, n, device)


def _rectified(name, outline, directions_m, edges, device) -> PolygonAperture:
    from .polygon.rectify import direction_set, rectify

    return _aperture(name, directions_m, edges,
                     lambda: rectify(outline, direction_set(directions_m), edges).unit(), device)


def _aperture(name, directions_m, edges, polygon, device) -> PolygonAperture:
    """The aperture of the unit polygon ``polygon()`` returns, timed as ``rectify_s``."""
    from runtime_cl.polygon.splat import PolygonSplatter

    start = time.perf_counter()
    unit, dirs = polygon()
    took = time.perf_counter() - start
    return PolygonAperture(name, directions_m, edges, PolygonSplatter(unit, dirs, device=device), took)

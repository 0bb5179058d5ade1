"""Polygonal bokeh for ``splatlab render --method polygon`` and ``splatlab bench polygon``.

A built-in aperture shape (:mod:`lab.sparsify.polygon_shapes`) is rectified once per run
(MHU21 section 4, :func:`lab.sparsify.polygon.rectify`) and handed to the runtime's exact
splatter (:class:`runtime_cl.polygon_splat.PolygonSplatter`). The radius of every pixel is its
thin-lens circle of confusion, ``|CoC|`` in pixels, from the EXR's depth and camera header.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .errors import UserError

__all__ = ["PolygonAperture", "polygon_aperture", "default_edges", "coc_radius", "render_polygon"]


def default_edges(name: str) -> int:
    """Edge budget N when none is given: the shape's own corners, at most 16 (heart, clover)."""
    from .sparsify.polygon_shapes import shape

    return min(len(shape(name)), 16)


@dataclass
class PolygonAperture:
    """A rectified aperture and its splatter.

    Attributes
    ----------
    name : str
        Built-in shape name.
    directions_m : int
        D = :func:`lab.sparsify.polygon.direction_set` (m).
    edges : int
        N, the rectification's edge budget.
    splatter : runtime_cl.polygon_splat.PolygonSplatter
    rectify_s : float
        Wall time of the rectification (graph construction + traversal), seconds.
    """

    name: str
    directions_m: int
    edges: int
    splatter: object
    rectify_s: float


def polygon_aperture(name: str = "hexagon", directions_m: int = 2, edges: int | None = None,
                     device=None) -> PolygonAperture:
    """Rectify the built-in shape ``name`` and build its splatter.

    Parameters
    ----------
    name : str, default "hexagon"
        One of :data:`lab.sparsify.polygon_shapes.SHAPES`.
    directions_m : int, default 2
        Edge directions are all reduced (run, rise) with components up to m (MHU21: m = 2).
    edges : int, optional
        Most edges of the rectified polygon (default :func:`default_edges`).
    device : runtime_cl.device.Device, optional

    Raises
    ------
    UserError
        Unknown shape name, bad m or N (the messages list the choices or the smallest N).
    """
    from runtime_cl.polygon_splat import PolygonSplatter

    from .sparsify.polygon import direction_set, rectify
    from .sparsify.polygon_shapes import SHAPES, shape

    if name not in SHAPES:
        raise UserError(f"--aperture {name!r}: unknown shape; choose one of {', '.join(SHAPES)}")
    n = default_edges(name) if edges is None else edges
    start = time.perf_counter()
    unit, dirs = rectify(shape(name), direction_set(directions_m), n).unit()
    took = time.perf_counter() - start
    return PolygonAperture(name, directions_m, n, PolygonSplatter(unit, dirs, device=device), took)


def coc_radius(image) -> np.ndarray:
    """``|CoC|`` in pixels per pixel of a labelled image, from its thin-lens camera header."""
    from runtime_cl.thin_lens import ThinLens

    camera = ThinLens.from_json(image.camera, "input camera")
    return np.abs(camera.coc_radius_px(image.depth, image.width)).astype(np.float32)


def render_polygon(image, aperture: PolygonAperture):
    """Depth of field of a labelled image with the aperture's polygon: ``(rgb, info)``."""
    radius = coc_radius(image)
    rgb, info = aperture.splatter.render(image.rgb, radius)
    info = dict(info, rectify_s=aperture.rectify_s, table_s=aperture.splatter.table.build_seconds,
                max_radius_px=float(radius.max()), entries=len(aperture.splatter.table))
    return rgb, info

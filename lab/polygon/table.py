"""MHU21 Table 1: non-zero elements of differenced polygon kernels, three ways.

* ``laplacian`` (LSR18): the 5-point Laplacian of the rasterised kernel ``K``.
* ``dxdy`` (KTB09): ``K(x, y) - K(x-1, y) - K(x, y-1) + K(x-1, y-1)``.
* ``directional`` (MHU21): all terms of :func:`runtime_cl.polygon.kernel.differenced_kernel`.

The shapes are rectified with MHU21's D (:func:`lab.polygon.rectify.direction_set` (2)) and,
as in the paper, "radius" is the half-width: the distance from the centre to the two vertical
edges. MHU21's hexagon has 8 directional terms, which only a hexagon with 45-degree edges gives:
the regular hexagon stretched vertically by sqrt(3) (the paper's remark that a regular hexagon
comes from splatting a vertically scaled image), vertices (0, +-2r), (+-r, +-r); its Laplacian
and dxdy counts then match the paper's 8r + 4 and 16r + 8 pattern.
"""
from __future__ import annotations

import numpy as np

from lab.errors import UserError
from lab.polygon.rectify import direction_set, rectify
from runtime_cl.polygon.kernel import differenced_kernel, rasterize_polygon, scale_polygon
from runtime_cl.polygon.shapes import shape

__all__ = ["PAPER_TABLE1", "METHODS", "TABLE1_SHAPES", "table1_polygon", "nonzero_counts",
           "table1", "format_table1"]

METHODS = ("laplacian", "dxdy", "directional")
TABLE1_SHAPES = ("hexagon", "octagon", "dodecagon", "hexadecagon")
#: MHU21 Table 1 as printed, counts at r = 25 and r = 100 ("Ours" is constant in r). Its
#: hexadecagon Laplacian/dxdy entries equal the octagon's; so do ours (both count staircase
#: corners, which the two shapes have equally many of), so that is no misprint.
PAPER_TABLE1 = {
    "hexagon": {"laplacian": (408, 1608), "dxdy": (204, 804), "directional": (8, 8)},
    "octagon": {"laplacian": (292, 1140), "dxdy": (116, 468), "directional": (12, 12)},
    "dodecagon": {"laplacian": (300, 1196), "dxdy": (108, 412), "directional": (28, 28)},
    "hexadecagon": {"laplacian": (292, 1140), "dxdy": (116, 468), "directional": (36, 36)},
}


def table1_polygon(name: str) -> tuple[np.ndarray, np.ndarray]:
    """Unit polygon (half-width 1) and edge directions of a Table 1 shape, rectified with D."""
    if name not in TABLE1_SHAPES:
        raise UserError(f"name: {name!r} is not a Table 1 shape; choose one of {TABLE1_SHAPES}")
    v = shape(name)
    if name == "hexagon":
        v = v * np.array([1.0, np.sqrt(3.0)])
    n = len(v)
    unit, dirs = rectify(v, direction_set(2), n).unit()
    return unit / np.abs(unit[:, 0]).max(), dirs


def nonzero_counts(vertices) -> dict[str, int]:
    """Non-zero counts of the three differencing methods for one integer polygon."""
    k = np.pad(rasterize_polygon(vertices)[0], 2)
    lap = 4 * k[1:-1, 1:-1] - k[:-2, 1:-1] - k[2:, 1:-1] - k[1:-1, :-2] - k[1:-1, 2:]
    dxdy = k[1:, 1:] - k[:-1, 1:] - k[1:, :-1] + k[:-1, :-1]
    return {"laplacian": int(np.count_nonzero(lap)), "dxdy": int(np.count_nonzero(dxdy)),
            "directional": differenced_kernel(vertices).nnz}


def table1(radii=(25, 100)) -> dict[str, dict[str, tuple[int, ...]]]:
    """Measured Table 1: ``{shape: {method: (count at each radius)}}``.

    Parameters
    ----------
    radii : sequence of float
        Half-widths in pixels (MHU21 uses 25 and 100).
    """
    out = {}
    for name in TABLE1_SHAPES:
        unit, dirs = table1_polygon(name)
        rows = [nonzero_counts(scale_polygon(unit, dirs, r)[0]) for r in radii]
        out[name] = {m: tuple(row[m] for row in rows) for m in METHODS}
    return out


def format_table1(measured: dict, radii=(25, 100)) -> str:
    """Plain-text table: measured counts with the paper's in parentheses."""
    head = "shape        " + "".join(f"{m:>14s} r={r:<4}" for m in METHODS for r in radii)
    lines = [head]
    for name, row in measured.items():
        cells = []
        for m in METHODS:
            paper = PAPER_TABLE1[name][m] if tuple(radii) == (25, 100) else (None,) * len(radii)
            cells += [f"{c:>10d} ({p if p is not None else '-':>5})" for c, p in zip(row[m], paper)]
        lines.append(f"{name:12s} " + "".join(f"{c:>19s}" for c in cells))
    return "\n".join(lines)

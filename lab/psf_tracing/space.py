"""PSF space for the precompute: the nested grid's inverse map g^-1(i) as a list of boxes.

The forward map g(x) (needed at runtime) lives in :mod:`runtime_cl.psf.grid`; this module
enumerates the cells level by level in exactly that order and gives each its box, in grid
coordinates and in physical coordinates (LSR18 section 5.2, Fig. 5 d).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from runtime_cl.psf.grid import NestedGrid, triangular

__all__ = ["NestedGrid", "Box", "boxes", "box"]


@dataclass(frozen=True)
class Box:
    """One cell: axis-aligned box [lo, hi] per dimension (physical units) and its grid box."""

    index: int
    grid_lo: tuple
    grid_hi: tuple
    lo: tuple
    hi: tuple

    @property
    def centre(self) -> tuple:
        """Centre of the physical box (used as the cell's representative PSF coordinate)."""
        return tuple((a + b) / 2.0 for a, b in zip(self.lo, self.hi))


def _level_cells(grid: NestedGrid, level: int):
    """Lattice coordinates k of the cells of ``level`` in index order (see runtime_cl.psf.grid)."""
    ns, kmax = grid.nested_ns, grid.cells_per_row(level)
    for j in range(ns):
        ranges = [range(1, kmax) if d < j else range(kmax) for d in range(ns) if d != j]
        for digits in itertools.product(*ranges):
            k = list(digits)
            k.insert(j, 0)
            yield tuple(k)


def boxes(grid: NestedGrid) -> list[Box]:
    """g^-1: every cell of ``grid`` as a :class:`Box`, in index order. With ``bins``, the nested
    cells repeat once per bin of the uniform last coordinate (its grid coordinate is the bin)."""
    nested = []
    for level in range(grid.levels):
        t0, w = triangular(level), level + 1
        for k in _level_cells(grid, level):
            glo = np.array([t0 + kd * w for kd in k], dtype=np.float64)
            ghi = np.minimum(glo + w, grid.n)
            nested.append((tuple(glo), tuple(ghi), tuple(grid.from_grid(glo)), tuple(grid.from_grid(ghi))))
    assert len(nested) == grid.nested_size, "nested grid enumeration disagrees with its level table"
    if not grid.bins:
        return [Box(i, *cell) for i, cell in enumerate(nested)]
    out = []
    for b in range(grid.bins):
        blo, bhi = grid.bin_range(b)
        for glo, ghi, lo, hi in nested:
            out.append(Box(len(out), glo + (float(b),), ghi + (float(b + 1),), lo + (blo,), hi + (bhi,)))
    return out


def box(grid: NestedGrid, index: int) -> Box:
    """g^-1(i) for one cell."""
    if not 0 <= index < grid.size:
        raise IndexError(f"cell index {index} outside 0..{grid.size - 1}")
    return boxes(grid)[index]

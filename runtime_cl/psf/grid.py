"""PSF space: power remapping and LSR18's nested grid (section 5.2), forward map in numpy.

A PSF model has ``ns`` physical coordinates x_d in [lo_d, hi_d] (e.g. the CoC radius in pixels).
They are normalised to s_d = (x_d - lo_d) / (hi_d - lo_d) in [0, 1] and power remapped: grid
coordinates are g_d = n * s_d ** (1 / beta_d), so a physical coordinate is s = (g / n) ** beta and
beta > 1 puts more cells at small coordinates (LSR18 Tbl. 1: p(s) = s^beta places the samples).

The nested grid on [0, n)^ns has levels l = 0, 1, ...: level l is the L-shaped shell where
min_d g_d lies in [T(l), T(l+1)), T(l) = l (l + 1) / 2 the triangular numbers, tiled by cells of
edge w = l + 1 on a lattice starting at T(l) (the last cell of each row truncated at n). The level
follows from the triangular root of min(g); the cell's lattice coordinates k_d = floor((g_d - T(l)) / w)
have at least one zero. Cells are numbered level by level; inside a level, grouped by the first
dimension j with k_j = 0 (dims before j count 1..K-1, dims after j count 0..K-1, row-major).
For ns = 2, n = 9 this gives LSR18 Fig. 5's 28 cells. The forward map is O(ns) and is mirrored
by ``kernels/psf/psf_space.cl``; the inverse (a list of boxes) lives in ``lab.psf_tracing.space``.

``bins > 0`` makes the last coordinate a uniform one: ``bins`` equal cells over its range, each
holding a whole nested grid of the other coordinates (cell = bin * nested size + nested cell).
It is for an angle (motion direction modulo a shaped aperture's symmetry): the nested grid is
fine only near each axis's low end, which means nothing for an angle.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from runtime_cl.errors import InputError


MAX_SAMPLES = 65536           # PSF samples a model may ask for (LSR18's tables use hundreds)
MAX_CELLS = 1 << 20           # cells of any grid (a database header cannot ask for more)
MAX_DIMS = 8                  # PSF-space dimensions (models use 1 or 2)
MAX_N = 65536 * 65537 // 2    # grid units: T(65536), 65536 levels
MAX_BINS = 4096               # cells of a uniform coordinate


def triangular(l):
    return l * (l + 1) // 2


def triangular_root(g):
    """Level l with T(l) <= g < T(l+1), for g >= 0 (float math, corrected by one integer step)."""
    g = np.asarray(g, dtype=np.float64)
    l = np.floor((np.sqrt(8.0 * g + 1.0) - 1.0) / 2.0).astype(np.int64)
    l = np.where(triangular(l + 1) <= g, l + 1, l)
    l = np.where(triangular(l) > g, l - 1, l)
    return l


@dataclass(frozen=True)
class NestedGrid:
    """The sampled PSF space of one model.

    Parameters
    ----------
    n : int
        Grid units per dimension (>= 1); the number of cells follows (see :attr:`size`).
    beta : tuple of float
        Power-remapping exponent per dimension (> 0; LSR18 Tbl. 1).
    ranges : tuple of (lo, hi)
        Physical range per dimension, hi > lo.
    names : tuple of str
        Name of each physical coordinate, for messages and reports.
    bins : int, default 0
        0: every coordinate is nested. > 0: the last coordinate is uniform, cut into ``bins``
        equal cells (its beta must be 1); the nested grid covers the others.
    """

    n: int
    beta: tuple
    ranges: tuple
    names: tuple
    bins: int = 0
    level_offsets: np.ndarray = field(init=False, repr=False, compare=False)
    level_widths: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "beta", tuple(float(b) for b in self.beta))
        object.__setattr__(self, "ranges", tuple((float(lo), float(hi)) for lo, hi in self.ranges))
        object.__setattr__(self, "names", tuple(str(s) for s in self.names))
        if not (isinstance(self.n, (int, np.integer)) and 1 <= self.n <= MAX_N):
            raise InputError(f"PSF space n = {self.n!r}: must be an integer in [1, {MAX_N}] (T(65536): "
                             "the nested grid's levels are counted one by one)")
        if not 1 <= len(self.beta) <= MAX_DIMS:
            raise InputError(f"PSF space: {len(self.beta)} dimensions; a PSF model has 1 to {MAX_DIMS}")
        if not (len(self.beta) == len(self.ranges) == len(self.names) >= 1):
            raise InputError(f"PSF space: beta {self.beta}, ranges {self.ranges} and names {self.names} "
                             "must have one entry per dimension")
        for b in self.beta:
            if not (math.isfinite(b) and b > 0):
                raise InputError(f"PSF space beta = {b}: must be a finite number > 0")
        for name, (lo, hi) in zip(self.names, self.ranges):
            if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
                raise InputError(f"PSF space range of {name} = [{lo}, {hi}]: needs finite hi > lo")
        if not (isinstance(self.bins, (int, np.integer)) and not isinstance(self.bins, bool)
                and 0 <= self.bins <= MAX_BINS):
            raise InputError(f"PSF space bins = {self.bins!r}: must be an integer in [0, {MAX_BINS}]")
        if self.bins and (self.ns < 2 or self.beta[-1] != 1.0):
            raise InputError(f"PSF space bins = {self.bins}: the uniform last coordinate needs another "
                             f"(nested) one and beta 1 (got {self.ns} coordinate(s), beta {self.beta})")
        levels = int(triangular_root(self.n - 1)) + 1 if self.n > 0 else 0
        counts = []
        for l in range(levels):
            k = self.cells_per_row(l)
            counts.append(k ** self.nested_ns - (k - 1) ** self.nested_ns)
        total = sum(counts) * max(self.bins, 1)
        if total > MAX_CELLS:
            raise InputError(f"PSF space n = {self.n} in {self.ns} dimension(s) has {total} cells, more than "
                             f"{MAX_CELLS} (each cell is a traced PSF and a database row); use fewer samples")
        object.__setattr__(self, "level_offsets", np.concatenate([[0], np.cumsum(counts)]).astype(np.int64))
        object.__setattr__(self, "level_widths", np.arange(1, levels + 1, dtype=np.int64))

    @property
    def ns(self) -> int:
        return len(self.beta)

    @property
    def nested_ns(self) -> int:
        """Coordinates on the nested grid (all but a uniform last one)."""
        return self.ns - (self.bins > 0)

    @property
    def levels(self) -> int:
        return len(self.level_widths)

    @property
    def nested_size(self) -> int:
        """Cells of the nested grid (of one bin)."""
        return int(self.level_offsets[-1])

    @property
    def size(self) -> int:
        """Number of cells (= PSF samples)."""
        return self.nested_size * max(self.bins, 1)

    def cells_per_row(self, level: int) -> int:
        """K: lattice cells along one axis in ``level`` (the last one possibly truncated at n)."""
        w = level + 1
        return -(-(self.n - triangular(level)) // w)

    @classmethod
    def for_samples(cls, samples: int, beta, ranges, names, bins: int = 0) -> "NestedGrid":
        """The smallest grid with n = T(L) (so no level is truncated) and at least ``samples`` cells
        (``samples`` counts every bin's cells)."""
        if not (isinstance(samples, (int, np.integer)) and not isinstance(samples, bool)
                and 1 <= samples <= MAX_SAMPLES):
            raise InputError(f"PSF samples = {samples!r}: must be an integer in [1, {MAX_SAMPLES}] (each sample "
                             "is a traced PSF: seconds each, and a row of the database)")
        lo, hi = 1, 1          # the size grows with the level: bracket it, then bisect
        while cls(triangular(hi), beta, ranges, names, bins).size < samples:
            lo, hi = hi + 1, 2 * hi
        while lo < hi:
            mid = (lo + hi) // 2
            if cls(triangular(mid), beta, ranges, names, bins).size >= samples:
                hi = mid
            else:
                lo = mid + 1
        return cls(triangular(lo), beta, ranges, names, bins)

    # --- coordinates -----------------------------------------------------------------------
    def normalise(self, x) -> np.ndarray:
        """Physical coordinates (..., ns) -> s in [0, 1]; out-of-range values are an error."""
        x = np.asarray(x, dtype=np.float64)
        if x.shape[-1:] != (self.ns,):
            raise InputError(f"PSF coordinates have shape {x.shape}, need (..., {self.ns})")
        lo = np.array([r[0] for r in self.ranges])
        hi = np.array([r[1] for r in self.ranges])
        s = (x - lo) / (hi - lo)
        bad = ~((s >= 0.0) & (s <= 1.0))
        if np.any(bad):
            d = int(np.argwhere(bad)[0][-1])
            value = x[bad][0]
            raise InputError(f"PSF coordinate {self.names[d]} = {value}: outside the database range "
                             f"[{self.ranges[d][0]}, {self.ranges[d][1]}]; rebuild the database with a "
                             "larger range")
        return s

    def to_grid(self, s) -> np.ndarray:
        """Normalised s in [0, 1] (..., nested_ns) -> grid coordinates g in [0, n]."""
        return self.n * np.power(np.asarray(s, dtype=np.float64), 1.0 / np.array(self.beta[:self.nested_ns]))

    def from_grid(self, g) -> np.ndarray:
        """Grid coordinates (..., nested_ns) -> physical coordinates."""
        s = np.power(np.asarray(g, dtype=np.float64) / self.n, np.array(self.beta[:self.nested_ns]))
        lo = np.array([r[0] for r in self.ranges[:self.nested_ns]])
        hi = np.array([r[1] for r in self.ranges[:self.nested_ns]])
        return lo + s * (hi - lo)

    def bin_range(self, b: int) -> tuple:
        """Physical [lo, hi] of bin ``b`` of the uniform last coordinate."""
        lo, hi = self.ranges[-1]
        return lo + (hi - lo) * b / self.bins, lo + (hi - lo) * (b + 1) / self.bins

    def index_of_grid(self, g) -> np.ndarray:
        """Forward map of the nested grid: grid coordinates (..., nested_ns) in [0, n] -> its cell (int64)."""
        g = np.asarray(g, dtype=np.float64)
        level = np.minimum(triangular_root(g.min(axis=-1)), self.levels - 1)
        t0 = triangular(level)
        w = level + 1
        kmax = -(-(self.n - t0) // w)  # K per level
        k = np.floor((g - t0[..., None]) / w[..., None]).astype(np.int64)
        k = np.clip(k, 0, kmax[..., None] - 1)
        is_zero = k == 0
        j = np.argmax(is_zero, axis=-1)  # first dimension with k_j = 0 (exists by construction)
        index = np.zeros(level.shape, dtype=np.int64)
        # groups before j: count_j' = (K-1)^j' * K^(ns-1-j')
        ns = self.nested_ns
        for jj in range(ns):
            before = jj < j
            index += np.where(before, (kmax - 1) ** jj * kmax ** (ns - 1 - jj), 0)
        # rank inside group j: row-major over dims != j, radix K-1 (value k-1) before j, K after
        rank = np.zeros_like(index)
        for d in range(ns):
            radix = np.where(d < j, kmax - 1, kmax)
            digit = np.where(d < j, k[..., d] - 1, k[..., d])
            use = d != j
            rank = np.where(use, rank * radix + digit, rank)
        return self.level_offsets[level] + index + rank

    def index(self, x) -> np.ndarray:
        """Forward map g(x): physical coordinates (..., ns) -> cell index, O(ns) per point."""
        s = self.normalise(x)
        if not self.bins:
            return self.index_of_grid(self.to_grid(s))
        return self.bin_index(s[..., -1]) * self.nested_size + self.index_of_grid(self.to_grid(s[..., :-1]))

    def bin_index(self, s) -> np.ndarray:
        """The bin of normalised values ``s`` in [0, 1] of the uniform last coordinate: floor(bins s),
        the last bin for s = 1 (as ``psf_space.cl`` finds it)."""
        return np.minimum(np.floor(np.asarray(s, np.float64) * self.bins).astype(np.int64), self.bins - 1)

    def to_json(self) -> dict:
        out = {"n": int(self.n), "beta": list(self.beta), "ranges": [list(r) for r in self.ranges],
               "names": list(self.names)}
        return dict(out, bins=int(self.bins)) if self.bins else out

    @classmethod
    def from_json(cls, data: dict) -> "NestedGrid":
        return cls(int(data["n"]), tuple(data["beta"]), tuple(tuple(r) for r in data["ranges"]),
                   tuple(data["names"]), int(data.get("bins", 0)))

"""Per-radius polygon kernels on the device: the table the splatting kernels look radii up in.

:class:`RadiusTable` owns a :class:`~runtime_cl.polygon.scale.ScaleTable` (radius -> integer
polygon, exactly ``scale_polygon``'s), the directional differences of every entry
(:func:`~runtime_cl.polygon.terms.polygon_terms`) with their pixel counts, and their device
copies. It grows on demand: a radius beyond the table rebuilds it to at least twice the old
range (the search costs ~1 s per 200 px of radius for the built-in shapes).

Device layout (``kernels/polygon/splat.cl``): ``breaks`` (float32, entry ``e`` serves
``breaks[e] <= r < breaks[e + 1]``), ``bucket`` (int32, the entry of radius ``i / BUCKETS``, so a
pixel finds its entry in a step or two), ``start`` (int32, terms of entry ``e`` are
``terms[start[e]:start[e + 1]]``) and ``terms`` (int4: direction index, dx, dy, value).
"""
from __future__ import annotations

import math
import time

import numpy as np

from runtime_cl.errors import InputError
from runtime_cl.polygon.scale import ScaleOracle, ScaleTable
from runtime_cl.polygon.terms import PolygonTerms, polygon_terms

__all__ = ["RadiusTable", "MAX_RADIUS", "BUCKETS"]

MAX_RADIUS = 2048.0   # px
BUCKETS = 16          # radius lookup buckets per pixel of radius


class RadiusTable:
    """Polygon kernels of one unit polygon for every float32 radius up to :attr:`max_radius`.

    Parameters
    ----------
    oracle : ScaleOracle
        The unit polygon's exact scaling (``scale_polygon`` on the device).
    directions : ndarray of int32, shape (m, 2)
        Buffer directions ``(a >= 1, b)``; every non-vertical edge runs along one of them.
    upload : callable
        ``upload(ndarray) -> device buffer`` (read-only copy).
    """

    def __init__(self, oracle: ScaleOracle, directions: np.ndarray, upload):
        self.oracle, self.directions, self.upload = oracle, directions, upload
        self.scale: ScaleTable | None = None
        self.terms: list[PolygonTerms] = []
        self.build_seconds = 0.0

    @property
    def max_radius(self) -> float:
        """Largest radius covered so far (0 before the first build)."""
        return 0.0 if self.scale is None else float(self.scale.max_radius)

    def ensure(self, max_radius: float) -> "RadiusTable":
        """Cover ``[0, max_radius]`` px, building or growing the table if needed.

        Raises
        ------
        InputError
            ``max_radius`` is not finite or lies outside ``[0, MAX_RADIUS]``.
        """
        if not (math.isfinite(max_radius) and 0 <= max_radius <= MAX_RADIUS):
            raise InputError(f"radius: largest value {max_radius!r} is not in [0, {MAX_RADIUS:g}] px; "
                             "pass pixel radii (|CoC|), or blur a downscaled image")
        if self.scale is not None and max_radius <= self.scale.max_radius:
            return self
        target = max(max_radius, 2 * self.max_radius, 32.0)
        target = min(MAX_RADIUS, float(16 * math.ceil(target / 16)))
        start = time.perf_counter()
        scale = ScaleTable.build(self.oracle, target)
        terms = [polygon_terms(p, self.directions) for p in scale.polygons]
        counts = np.array([t.nnz for t in terms])
        packed = np.concatenate([np.stack([t.direction, t.dx, t.dy, t.value], 1) for t in terms])
        self.area = np.array([t.area for t in terms], np.float64)
        # extent of each entry's terms (x0, x1, y0, y1), for tiling the splat without races
        self.bounds = np.array([(t.dx.min(), t.dx.max(), t.dy.min(), t.dy.max()) if t.nnz else (0,) * 4
                                for t in terms], np.int64)
        n_buckets = int(math.floor(float(scale.max_radius) * BUCKETS)) + 2
        bucket = scale.index(np.arange(n_buckets, dtype=np.float64) / BUCKETS)
        self.breaks = self.upload(scale.breaks.astype(np.float32))
        self.bucket = self.upload(np.ascontiguousarray(bucket, np.int32))
        self.start = self.upload(np.concatenate([[0], np.cumsum(counts)]).astype(np.int32))
        self.packed = self.upload(np.ascontiguousarray(packed, np.int32))
        self.scale, self.terms = scale, terms
        self.build_seconds += time.perf_counter() - start
        return self

    def __len__(self) -> int:
        return 0 if self.scale is None else len(self.scale.breaks)

    def span(self, max_radius: float) -> int:
        """Width or height (the larger) of the union of the term offsets of all entries serving
        radii ``<= max_radius``: two pixels further apart never write the same buffer pixel."""
        b = self.bounds[: int(self.entry(max_radius)) + 1]
        return int(max(b[:, 1].max() - b[:, 0].min(), b[:, 3].max() - b[:, 2].min()))

    def entry(self, radius) -> np.ndarray:
        """Entry index of (float32-rounded) radii, as the kernels compute it."""
        return self.scale.index(radius)

    def at(self, radius: float) -> PolygonTerms:
        """Terms and pixel count of the polygon at ``radius`` (builds the table if needed)."""
        self.ensure(float(radius))
        return self.terms[int(self.entry(radius))]

    def polygon(self, radius: float) -> np.ndarray:
        """Integer vertices used at ``radius`` (``scale_polygon``'s, see ``polygon_scale``)."""
        self.ensure(float(radius))
        return self.scale.polygon(radius)

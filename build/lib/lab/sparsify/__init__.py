"""Spreadlet optimisation (LSR18 section 5.5): dense PSF -> sparse Laplacian points, or fast track.

``sparsify(psf)`` runs Laplacian, dart throwing, Lloyd, Voronoi collapse, annealing and merge and
returns a :class:`SparsePSF`. Numba compiles the loops on first use (cached in NUMBA_CACHE_DIR).
"""
from .spreadlets import MASS, SparsePSF, sparsify

__all__ = ["sparsify", "SparsePSF", "MASS"]

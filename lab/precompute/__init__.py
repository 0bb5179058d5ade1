"""Precompute jobs: every cell of a PSF model light-traced, sparsified and stored as a database.

Modules, one concept each:

- :mod:`.naming` - cache folders and the content hash that names a database.
- :mod:`.cell` - the unit of work (trace + sparsify one cell) and its picklable task form.
- :mod:`.shards` - one atomic file per finished cell, so jobs resume after any interruption.
- :mod:`.executors` - this process, ``--workers N`` local processes, or a Dask cluster.
- :mod:`.consolidate` - shards, in cell order, into one database (``runtime_cl.psf.database``).
- :mod:`.job` - :func:`precompute`, the whole job with a progress bar.
- :mod:`.target` - ``splatlab precompute MODEL|SCENE`` and ``--set KEY=VALUE``.
"""
from .cell import build_cell, dense_crop
from .job import PrecomputeResult, precompute
from .naming import content_hash, source_digest

__all__ = ["content_hash", "source_digest", "precompute", "PrecomputeResult",
           "build_cell", "dense_crop"]

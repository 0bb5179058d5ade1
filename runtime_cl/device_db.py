"""A spreadlet database uploaded to an OpenCL device, once, for every kernel that reads it."""
from __future__ import annotations

import numpy as np

from .database import SpreadletDatabase
from .device import Device, event_ms, get_device
from .psf_space_cl import PsfSpaceTables


class DeviceDatabase:
    """Read-only device buffers of one :class:`SpreadletDatabase` plus its PSF-space tables.

    Parameters
    ----------
    db : SpreadletDatabase
        The database.
    device : Device, optional
        Default :func:`~runtime_cl.device.get_device`.

    Attributes
    ----------
    buffers : dict of str -> pyopencl.Buffer
        ``C, P, V, fast, dense_r, dense_off, dense_v, psf_thr, psf_bucket``.
    options : list of str
        ``-D`` options every kernel reading this database needs (PSF space, DC, PAD, HAS_FAST).
    upload_ms : float
        Time of the one-off upload (event profiling).
    """

    def __init__(self, db: SpreadletDatabase, device: Device | None = None):
        import pyopencl as cl

        self.db = db
        self.device = device or get_device()
        self.fp64 = self.device.fp64
        self.tables = PsfSpaceTables(db.grid, self.fp64)
        ctx, q = self.device.context, self.device.queue
        host = {
            "C": db.C, "P": db.P, "V": db.V, "fast": db.fast_track.astype(np.uint8),
            "dense_r": db.dense_radius, "dense_off": db.dense_offsets, "dense_v": db.dense_values,
            "psf_thr": self.tables.thr, "psf_bucket": self.tables.bucket,
        }
        self.buffers, events = {}, []
        for name, array in host.items():
            array = np.ascontiguousarray(array)
            # OpenCL refuses zero-sized buffers (a database without spreadlets is legal)
            buf = cl.Buffer(ctx, cl.mem_flags.READ_ONLY, max(array.nbytes, 16))
            if array.nbytes:
                events.append(cl.enqueue_copy(q, buf, array, is_blocking=False))
            self.buffers[name] = buf
        self.upload_ms = event_ms(*events)
        self.has_fast = bool(db.fast_track.any())
        self.options = self.tables.options + [f"-DDC={db.channels}", f"-DPAD={db.pad}"]

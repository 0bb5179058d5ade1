"""A spreadlet database uploaded to an OpenCL device, once, for every kernel that reads it."""
from __future__ import annotations

import numpy as np

from runtime_cl.psf.database import SpreadletDatabase
from runtime_cl.device.opencl import Device, event_ms, get_device
from runtime_cl.psf.grid_cl import PsfSpaceTables


# How the splat kernel draws a cell (the device's ``fast`` array): Laplacian spreadlets, the dense
# PSF (fast track), or row differences (``kernels/spreadlets/splat.cl``)
KIND_LAPLACIAN, KIND_DENSE, KIND_ROWS = 0, 1, 2


def cell_kinds(db: SpreadletDatabase, rows: np.ndarray | None = None) -> np.ndarray:
    """uint8 :data:`KIND_DENSE` for a fast-tracked cell, else the kind of its spreadlets: (n,), or
    (2n,) for a ``"dual"`` database (its cells turned by other than 0 or pi, then the same cells at
    0 and pi: their row differences where ``rows`` (default :func:`half_turn_rows`) says, else
    their Laplacian)."""
    kinds = np.where(db.fast_track, KIND_DENSE, KIND_ROWS if db.basis == "rows" else KIND_LAPLACIAN)
    if db.basis == "dual":
        rows = half_turn_rows(db) if rows is None else rows
        kinds = np.concatenate([kinds, np.where(rows, np.where(db.row_fast, KIND_DENSE, KIND_ROWS), kinds)])
    return kinds.astype(np.uint8)


def half_turn_rows(db: SpreadletDatabase, dense_n: np.ndarray | None = None) -> np.ndarray:
    """(n,) bool: the cells of a ``"dual"`` database drawn from their row differences at 0 and pi,
    those whose row differences cost fewer adds than their Laplacian (either's dense PSF when it
    is fast-tracked). A still disc's rim is 2 terms per row against its Laplacian's 3-pixel-wide
    outline; a moving capsule's rows are long ramps (fewer shutter times cover its ends), each
    pixel a difference, where its Laplacian is zero. ``dense_n``: each dense PSF's pixels inside
    its row spans (default: :func:`dense_row_spans`'s)."""
    dense = dense_row_spans(db)[2] if dense_n is None else dense_n
    rows = np.where(db.row_fast, dense, np.diff(db.row_C))
    return rows < np.where(db.fast_track, dense, np.diff(db.C))


def device_spreadlets(db: SpreadletDatabase, rows: np.ndarray | None = None) -> tuple:
    """(C, P, V) as the device holds them: each cell's spreadlets sorted by (dy, dx)
    (:func:`row_major_order`); a ``"dual"`` database's cells at 0 and pi follow as cells
    n .. 2n - 1 (C of length 2n + 1): row differences where ``rows`` (default
    :func:`half_turn_rows`) says, else Laplacian."""
    order = row_major_order(db.C, db.P)
    C, P, V = db.C, db.P[order], db.V[order]
    if db.basis != "dual":
        return C, P, V
    rows = half_turn_rows(db) if rows is None else rows
    row_order = row_major_order(db.row_C, db.row_P)
    rP, rV = db.row_P[row_order], db.row_V[row_order]
    parts = [(rP[db.row_C[i]:db.row_C[i + 1]], rV[db.row_C[i]:db.row_C[i + 1]]) if rows[i]
             else (P[C[i]:C[i + 1]], V[C[i]:C[i + 1]]) for i in range(db.n_samples)]
    counts = np.cumsum([len(p) for p, _ in parts]) + C[-1]
    return (np.concatenate([C, counts]).astype(np.int64), np.concatenate([P] + [p for p, _ in parts]),
            np.concatenate([V] + [v for _, v in parts]))


def row_major_order(C: np.ndarray, P: np.ndarray) -> np.ndarray:
    """Permutation that sorts each sample's spreadlets by (dy, dx), samples kept in place.

    Splatting a sample's spreadlets in this order writes the canvas row by row, left to right,
    so consecutive writes share cache lines. Measured on the demo database (spreadlets stored by
    (dx, dy), i.e. column by column): 357 -> 767 M spreadlets/s for the per-pixel splat kernel.
    The sort is stable, so equal offsets (allowed) keep their stored order.
    """
    sample = np.repeat(np.arange(len(C) - 1), np.diff(C))
    return np.lexsort((P[:, 0], P[:, 1], sample)) if len(P) else np.zeros(0, np.int64)


def dense_row_spans(db: SpreadletDatabase) -> tuple:
    """The non-zero part of every row of every dense PSF, so splatting skips the zero corners.

    Returns
    -------
    span_off : ndarray, int64, (n + 1,)
        Rows of sample i are span[span_off[i]:span_off[i + 1]] (2 r_i + 1 of them).
    span : ndarray, int32, (rows, 2)
        [first, end) columns of the row's non-zero pixels (any channel); (0, 0) if all zero.
    pixels : ndarray, int64, (n,)
        Pixels inside the spans of sample i: what its dense splat adds.

    The benchmark's discs keep ~77 % of their square crops; skipping zeros changes no sum.
    """
    side = 2 * db.dense_radius.astype(np.int64) + 1
    span_off = np.concatenate([[0], np.cumsum(side)])
    span = np.zeros((int(span_off[-1]), 2), np.int32)
    for i, s in enumerate(side):
        nz = np.any(db.dense_psf(i) != 0, axis=-1)  # (s, s): row, column
        has = nz.any(axis=1)
        span[span_off[i]:span_off[i + 1], 0] = np.where(has, np.argmax(nz, axis=1), 0)
        span[span_off[i]:span_off[i + 1], 1] = np.where(has, s - np.argmax(nz[:, ::-1], axis=1), 0)
    width = (span[:, 1] - span[:, 0]).astype(np.int64)
    pixels = np.add.reduceat(width, span_off[:-1]) if len(side) else np.zeros(0, np.int64)
    return span_off, span, pixels


def dense_boxes(db: SpreadletDatabase, span_off: np.ndarray, span: np.ndarray) -> np.ndarray:
    """(n, 4) int32: each dense PSF's non-zero box as offsets from its centre, (x0, x1, y0, y1)
    inclusive; (0, -2, 0, -2) for an all-zero PSF. Turned PSFs are sampled only inside it
    (``kernels/spreadlets/rotate.cl`` turned_cols)."""
    box = np.tile(np.array([0, -2, 0, -2], np.int32), (db.n_samples, 1))
    for i in range(db.n_samples):
        rows = span[span_off[i]:span_off[i + 1]]
        has = np.flatnonzero(rows[:, 1] > rows[:, 0])
        if len(has):
            r = int(db.dense_radius[i])
            box[i] = (rows[has, 0].min() - r, rows[has, 1].max() - 1 - r, has[0] - r, has[-1] - r)
    return box


class DeviceDatabase:
    """Read-only device buffers of one :class:`SpreadletDatabase` plus its PSF-space tables.

    The spreadlets of every sample are uploaded sorted by (dy, dx) (:func:`row_major_order`);
    the file keeps its own order. A sample's sum of spreadlets does not depend on the order,
    only its float rounding does.

    Parameters
    ----------
    db : SpreadletDatabase
        The database.
    device : Device, optional
        Default :func:`~runtime_cl.device.opencl.get_device`.

    Attributes
    ----------
    buffers : dict of str -> pyopencl.Buffer
        ``C, P, V, fast, dense_r, dense_off, dense_v, span_off, span, dense_n, dense_box,
        dense_sum, psf_thr, psf_bucket`` (``fast``: :attr:`kinds`; ``span*``, ``dense_n``: :func:`dense_row_spans`;
        ``dense_box``: :func:`dense_boxes`; ``dense_sum``: each dense PSF's sum per channel, the
        energy a turned PSF keeps).
    kinds : ndarray, uint8
        Each device cell's kind (:func:`cell_kinds`), the ``fast`` buffer's host copy.
    dense_n : ndarray, int64
        Each dense PSF's pixels inside its row spans (:func:`dense_row_spans`), host copy.
    options : list of str
        ``-D`` options every kernel reading this database needs (PSF space, DC, PAD).
    base_options : list of str
        ``options`` without PAD, for kernels that pad otherwise (rotated PSFs need more).
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
        span_off, span, dense_n = dense_row_spans(db)
        self.dense_n = dense_n
        rows = half_turn_rows(db, dense_n) if db.basis == "dual" else None
        C, P, V = device_spreadlets(db, rows)
        self.kinds = cell_kinds(db, rows)
        host = {
            "C": C, "P": P, "V": V, "fast": self.kinds,
            "dense_r": db.dense_radius, "dense_off": db.dense_offsets, "dense_v": db.dense_values,
            "span_off": span_off, "span": span, "dense_n": dense_n,
            "dense_box": dense_boxes(db, span_off, span),
            "dense_sum": np.add.reduceat(db.dense_values, db.dense_offsets[:-1], axis=0,
                                         dtype=np.float64).astype(np.float32),
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
        self.base_options = self.tables.options + [f"-DDC={db.channels}"]
        self.options = self.base_options + [f"-DPAD={db.pad}"]

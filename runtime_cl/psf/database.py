"""The spreadlet database: every PSF sample of one model, sparse (spreadlets) and dense.

File format (version 1): an uncompressed NumPy ``.npz`` (a zip of ``.npy`` arrays, loaded with
``allow_pickle=False``) holding

==================  ==========================  ============================================
array               dtype, shape                meaning
==================  ==========================  ============================================
``header``          uint8 (k,)                  UTF-8 JSON: magic, format_version, model,
                                                params, grid (NestedGrid.to_json), channels,
                                                psf_resolution, stats (names), counts
``checksum``        uint8 (64,)                 hex sha256 over the header and every array
``C``               int64 (n+1,)                spreadlets of sample i are C[i]:C[i+1]
``P``               int16 (m, 2)                (dx, dy) offsets from the PSF centre, pixels
``V``               float32 (m, channels)       values of the spreadlets: Laplacian, or row
                                                differences if params ``basis`` is ``"rows"``
``fast_track``      bool (n,)                   sample is splat dense (LSR18 section 6.4)
``dense_radius``    int32 (n,)                  r_i: the dense crop is (2 r_i + 1)^2 pixels
``dense_offsets``   int64 (n+1,)                rows of sample i in dense_values
``dense_values``    float32 (sum, channels)     dense PSFs, row-major [y][x], centre at (r, r)
``stat__NAME``      float32 (n,)                per-sample statistics (sparsity, ssim, l1, ...)
``row_C``, ``row_P``, ``row_V``, ``row_fast``     basis ``"dual"`` only: every sample again as row
                                                differences (as C, P, V, fast_track)
==================  ==========================  ============================================

n is the number of cells of the nested grid (one PSF sample per cell, in cell order). Files are
written atomically (temporary file in the same directory, then ``os.replace``).

``params["basis"]`` (absent: ``"laplacian"``) says what the spreadlets are: LSR18's Laplacian
values, integrated by a Poisson solve, or backward differences along image rows (``"rows"``,
``lab.sparsify.rows``), integrated by a prefix sum along each canvas row as the splat tiles are
merged; row differences can be drawn as stored or half-turned only. ``"dual"``: C, P, V hold
Laplacian values and ``row_*`` the same samples as row differences, for a model whose PSFs turn by
any angle but mostly by none or a half turn (``combined``: still pixels, horizontal motion), which
the runtime draws from the row differences, and every other turn from the Laplacian.
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from runtime_cl.atomic_file import atomic_path
from runtime_cl.errors import InputError
from runtime_cl.input_file import open_input
from runtime_cl.json_values import loads
from runtime_cl.psf.grid import NestedGrid
from runtime_cl.psf.npz_reader import read_npz

MAGIC = "splatlab-spreadlet-db"
FORMAT_VERSION = 1
REQUIRED_STATS = ("sparsity", "ssim", "l1")
BASES = ("laplacian", "rows", "dual")
REBUILD = "rebuild it with `splatlab precompute SCENE`"
# (name, dtype) of the arrays, in checksum order
ARRAYS = (("C", np.int64), ("P", np.int16), ("V", np.float32), ("fast_track", np.bool_),
          ("dense_radius", np.int32), ("dense_offsets", np.int64), ("dense_values", np.float32))
# basis "dual" only: the row differences of every sample
ROW_ARRAYS = (("row_C", np.int64), ("row_P", np.int16), ("row_V", np.float32), ("row_fast", np.bool_))


def _cast(name, value, dtype, shape):
    """``value`` as a C-contiguous ``dtype`` array of ``shape`` (None = any), refusing lossy casts."""
    a = np.asarray(value)
    out = np.ascontiguousarray(a, dtype=dtype)
    if a.dtype != out.dtype and a.size and not np.array_equal(out.astype(a.dtype), a):
        raise InputError(f"database array {name}: values do not fit {np.dtype(dtype).name}")
    if len(shape) != out.ndim or any(s is not None and s != t for s, t in zip(shape, out.shape)):
        want = tuple("any" if s is None else s for s in shape)
        raise InputError(f"database array {name}: shape {out.shape}, need {want}")
    return out


@dataclass(eq=False)
class SpreadletDatabase:
    """All PSF samples of one model; see the module docstring for the arrays.

    Parameters
    ----------
    model : str
        Registered PSF model name, e.g. ``"simple_lens"``.
    params : dict
        Camera-independent model parameters (JSON-serialisable), e.g. r_max, rays, seed.
    grid : NestedGrid
        The sampled PSF space; sample i belongs to cell i.
    channels : int
        1 (monochrome PSFs, multiplying every colour channel) or 3.
    psf_resolution : int
        Resolution (pixels per side) the PSFs were traced at.
    C, P, V, fast_track, dense_radius, dense_offsets, dense_values : ndarray
        As in the module docstring.
    row_C, row_P, row_V, row_fast : ndarray, optional
        Basis ``"dual"`` only (required there): every sample's row differences.
    stats : dict of str -> ndarray
        Per-sample float32 statistics; must include sparsity, ssim and l1.
    checksum : str, optional
        The checksum stored in the file this was loaded from (None if built in memory).
    path : Path, optional
        The file this was loaded from or last saved to.
    """

    model: str
    params: dict
    grid: NestedGrid
    channels: int
    psf_resolution: int
    C: np.ndarray
    P: np.ndarray
    V: np.ndarray
    fast_track: np.ndarray
    dense_radius: np.ndarray
    dense_offsets: np.ndarray
    dense_values: np.ndarray
    stats: dict
    row_C: np.ndarray | None = None
    row_P: np.ndarray | None = None
    row_V: np.ndarray | None = None
    row_fast: np.ndarray | None = None
    checksum: str | None = None
    path: Path | None = field(default=None, repr=False)

    def __post_init__(self):
        if not (isinstance(self.model, str) and self.model):
            raise InputError(f"database model = {self.model!r}: must be a non-empty string")
        try:
            json.dumps(self.params)
        except (TypeError, ValueError) as exc:
            raise InputError(f"database params of model {self.model}: not JSON-serialisable ({exc})")
        if self.channels not in (1, 3):
            raise InputError(f"database channels = {self.channels!r}: must be 1 or 3")
        if self.basis not in BASES:
            raise InputError(f"database params basis = {self.params.get('basis')!r}: must be one of "
                             f"{list(BASES)}; {REBUILD}")
        if not (isinstance(self.psf_resolution, (int, np.integer)) and self.psf_resolution >= 1):
            raise InputError(f"database psf_resolution = {self.psf_resolution!r}: must be an integer >= 1")
        n, ch = self.grid.size, self.channels
        self.C = _cast("C", self.C, np.int64, (n + 1,))
        m = int(self.C[-1])
        self.P = _cast("P", self.P, np.int16, (m, 2))
        self.V = _cast("V", self.V, np.float32, (m, ch))
        self.fast_track = _cast("fast_track", self.fast_track, np.bool_, (n,))
        self.dense_radius = _cast("dense_radius", self.dense_radius, np.int32, (n,))
        self.dense_offsets = _cast("dense_offsets", self.dense_offsets, np.int64, (n + 1,))
        self.dense_values = _cast("dense_values", self.dense_values, np.float32,
                                  (int(self.dense_offsets[-1]), ch))
        dual = self.basis == "dual"
        given = sum(getattr(self, name) is not None for name, _ in ROW_ARRAYS)
        if given != (len(ROW_ARRAYS) if dual else 0):
            raise InputError(f"database arrays {[name for name, _ in ROW_ARRAYS]}: needed by basis 'dual' "
                             f"and by no other; basis {self.basis!r} has {given} of them; {REBUILD}")
        if dual:
            self.row_C = _cast("row_C", self.row_C, np.int64, (n + 1,))
            self.row_P = _cast("row_P", self.row_P, np.int16, (int(self.row_C[-1]), 2))
            self.row_V = _cast("row_V", self.row_V, np.float32, (int(self.row_C[-1]), ch))
            self.row_fast = _cast("row_fast", self.row_fast, np.bool_, (n,))
        for name in ("C", "row_C") if dual else ("C",):
            c = getattr(self, name)
            if c[0] != 0 or np.any(np.diff(c) < 0):
                raise InputError(f"database array {name}: must start at 0 and never decrease")
        if np.any(self.dense_radius < 0):
            raise InputError("database array dense_radius: radii must be >= 0")
        sizes = (2 * self.dense_radius.astype(np.int64) + 1) ** 2
        if self.dense_offsets[0] != 0 or np.any(np.diff(self.dense_offsets) != sizes):
            raise InputError("database array dense_offsets: must be the cumulative sum of "
                             "(2 dense_radius + 1)^2 starting at 0")
        for name in ("V", "dense_values", "row_V") if dual else ("V", "dense_values"):
            if not np.all(np.isfinite(getattr(self, name))):
                raise InputError(f"database array {name}: contains NaN or infinity")
        missing = [s for s in REQUIRED_STATS if s not in self.stats]
        if missing:
            raise InputError(f"database stats: missing {missing}; every sample needs {list(REQUIRED_STATS)}")
        self.stats = {str(k): _cast(f"stat {k}", v, np.float32, (n,)) for k, v in self.stats.items()}

    # --- queries -------------------------------------------------------------------------
    @property
    def n_samples(self) -> int:
        """Number of PSF samples (= cells of the grid)."""
        return self.grid.size

    @property
    def basis(self) -> str:
        """``"laplacian"``, ``"rows"`` or ``"dual"``: what the spreadlet values are (module docstring)."""
        return self.params.get("basis", "laplacian") if isinstance(self.params, dict) else "laplacian"

    @property
    def n_spreadlets(self) -> int:
        """Total number of spreadlets over all samples."""
        return int(self.C[-1])

    @property
    def max_offset(self) -> int:
        """Largest |dx| or |dy| over all spreadlets, a dual database's row differences too (0 if
        there are none)."""
        parts = [p for p in (self.P, self.row_P) if p is not None and len(p)]
        return max((int(np.abs(p.astype(np.int32)).max()) for p in parts), default=0)

    @property
    def pad(self) -> int:
        """Canvas padding that holds the largest PSF, plus the zero ring (LSR18 section 6.2)."""
        return max(self.max_offset, int(self.dense_radius.max())) + 1

    @property
    def rotated_pad(self) -> int:
        """Canvas padding that holds every PSF turned by any angle (``Renderer.render(angle=...)``).

        A spreadlet at offset p, turned, lies within |p| of the centre along either axis and
        reaches one pixel further when shared bilinearly; a dense crop of radius r turned
        reaches less than (r + 1) sqrt(2) (``kernels/spreadlets/rotate.cl``); plus the zero ring.
        """
        p = self.P.astype(np.float64)
        reach = int(np.ceil(np.sqrt((p ** 2).sum(axis=1)).max())) + 1 if len(p) else 0
        dense = int(np.ceil(np.sqrt(2.0) * int(self.dense_radius.max()))) + 1
        return max(reach, dense) + 1

    def spreadlets(self, i: int):
        """(P, V) of sample ``i``: (k, 2) int16 offsets and (k, channels) float32 values."""
        a, b = self.C[i], self.C[i + 1]
        return self.P[a:b], self.V[a:b]

    def row_spreadlets(self, i: int):
        """(P, V) of sample ``i``'s row differences in a ``"dual"`` database."""
        a, b = self.row_C[i], self.row_C[i + 1]
        return self.row_P[a:b], self.row_V[a:b]

    def dense_psf(self, i: int) -> np.ndarray:
        """Dense PSF of sample ``i`` as (2r+1, 2r+1, channels) float32, centre at [r, r]."""
        side = 2 * int(self.dense_radius[i]) + 1
        rows = self.dense_values[self.dense_offsets[i]:self.dense_offsets[i + 1]]
        return rows.reshape(side, side, self.channels)

    def header(self) -> dict:
        """The JSON header written to the file (everything but the arrays)."""
        return {"magic": MAGIC, "format_version": FORMAT_VERSION, "model": self.model,
                "params": self.params, "grid": self.grid.to_json(), "channels": int(self.channels),
                "psf_resolution": int(self.psf_resolution), "stats": sorted(self.stats),
                "n_samples": self.n_samples, "n_spreadlets": self.n_spreadlets}

    def _arrays(self) -> dict:
        arrays = {name: getattr(self, name) for name, _ in ARRAYS + ROW_ARRAYS if getattr(self, name) is not None}
        arrays.update({f"stat__{k}": self.stats[k] for k in sorted(self.stats)})
        return arrays

    def compute_checksum(self) -> str:
        """sha256 (hex) over the canonical header JSON and every array (name, dtype, shape, bytes)."""
        return _checksum(_header_bytes(self.header()), self._arrays())

    def nbytes(self) -> int:
        """Bytes of all arrays (the file adds the zip directory and the header)."""
        return int(sum(a.nbytes for a in self._arrays().values()))

    def info(self) -> dict:
        """Summary for ``splatlab db info``."""
        computed = self.compute_checksum()
        return {
            "model": self.model, "params": self.params, "format_version": FORMAT_VERSION,
            "samples": self.n_samples, "spreadlets": self.n_spreadlets, "channels": self.channels,
            "psf_space": self.grid.to_json(), "psf_resolution": int(self.psf_resolution),
            "mean_spreadlets_per_sample": self.n_spreadlets / self.n_samples,
            "basis": self.basis, "mean_sparsity": float(np.mean(self.stats["sparsity"])),
            # LSR18 Fig. 10's figure: the samples stored sparse (the fast-tracked ones draw dense)
            "sparse_only_sparsity": (float(np.mean(self.stats["sparsity"][~self.fast_track]))
                                     if not self.fast_track.all() else None),
            "mean_ssim": float(np.mean(self.stats["ssim"])),
            "fast_track": int(self.fast_track.sum()), "max_dense_radius": int(self.dense_radius.max()),
            **(self._row_info() if self.basis == "dual" else {}),
            "pad": self.pad, "bytes": self.nbytes(),
            "file_bytes": os.path.getsize(self.path) if self.path and os.path.exists(self.path) else None,
            "checksum": computed, "checksum_ok": None if self.checksum is None else computed == self.checksum,
        }

    def _row_info(self) -> dict:
        """A dual database's row differences, as :meth:`info` summarises its Laplacian ones."""
        sparsity = self.stats.get("row_sparsity")
        return {"row_spreadlets": int(self.row_C[-1]), "row_fast_track": int(self.row_fast.sum()),
                "row_sparse_only_sparsity": (float(np.mean(sparsity[~self.row_fast]))
                                             if sparsity is not None and not self.row_fast.all() else None)}

    # --- files ---------------------------------------------------------------------------
    def save(self, path) -> str:
        """Write atomically to ``path`` (any suffix); returns the checksum written."""
        path = Path(path)
        checksum = self.compute_checksum()
        payload = {"header": np.frombuffer(_header_bytes(self.header()), dtype=np.uint8),
                   "checksum": np.frombuffer(checksum.encode("ascii"), dtype=np.uint8),
                   **self._arrays()}
        with atomic_path(path, fsync=True) as tmp, open(tmp, "wb") as f:
            np.savez(f, **payload)  # a file object: savez adds no ".npz" suffix
        self.checksum, self.path = checksum, path
        return checksum

    @classmethod
    def load(cls, path, expect_model: str | None = None) -> "SpreadletDatabase":
        """Read and validate a database file.

        Parameters
        ----------
        path : str or Path
            The database file.
        expect_model : str, optional
            If given, the file must hold this model.

        Raises
        ------
        InputError
            Missing, truncated, corrupt (checksum), foreign or newer-format file, or a file
            built for another model; the message names the file and the fix.
        """
        path = Path(path)
        where = f"spreadlet database {path}"
        with open_input(path, "spreadlet database", "build it with `splatlab precompute SCENE`") as fh:
            try:
                return cls._decode(read_npz(fh, where), path, where, expect_model)
            except InputError as exc:
                if str(exc).startswith(where):
                    raise
                raise InputError(f"{where}: inconsistent content ({exc}); {REBUILD}") from None
            except Exception as exc:  # noqa: BLE001 - any failure to decode a damaged file is the user's input
                reason = (str(exc).splitlines() or [""])[0][:200]
                raise InputError(f"{where}: unreadable, truncated or not a database ({type(exc).__name__}: "
                                 f"{reason}); {REBUILD}") from None

    @classmethod
    def _decode(cls, arrays: dict, path: Path, where: str, expect_model) -> "SpreadletDatabase":
        """The database from the file's arrays (header checked, checksum verified)."""
        header = stored = None
        if "header" in arrays and "checksum" in arrays:
            header = loads(arrays["header"].tobytes(), f"{where} header", REBUILD, infinite_keys=("surfaces",))
            stored = arrays["checksum"].tobytes().decode("ascii", "replace")
        if not isinstance(header, dict) or header.get("magic") != MAGIC:
            raise InputError(f"{where}: not a splatlab spreadlet database (no '{MAGIC}' header); "
                             f"pass a file written by `splatlab precompute SCENE`")
        version = header.get("format_version")
        if version != FORMAT_VERSION:
            raise InputError(f"{where}: format version {version!r}, this splatlab reads version "
                             f"{FORMAT_VERSION}; {REBUILD}")
        _check_header_types(header, where)
        dual = isinstance(header["params"], dict) and header["params"].get("basis") == "dual"
        names = [n for n, _ in ARRAYS + (ROW_ARRAYS if dual else ())] + [f"stat__{s}" for s in header["stats"]]
        missing = [n for n in names if n not in arrays]
        if missing:
            raise InputError(f"{where}: arrays {missing} are missing; {REBUILD}")
        computed = _checksum(arrays["header"].tobytes(), {n: arrays[n] for n in names})
        if computed != stored:
            raise InputError(f"{where}: corrupt (checksum mismatch: stored {stored[:12]}..., "
                             f"content {computed[:12]}...); {REBUILD}")
        if expect_model is not None and header["model"] != expect_model:
            raise InputError(f"{where}: built for model {header['model']!r}, this render needs "
                             f"{expect_model!r}; {REBUILD} for a scene that uses {expect_model!r}")
        return cls(model=header["model"], params=header["params"],
                   grid=NestedGrid.from_json(header["grid"]), channels=header["channels"],
                   psf_resolution=header["psf_resolution"],
                   **{n: arrays[n] for n, _ in ARRAYS + (ROW_ARRAYS if dual else ())},
                   stats={s: arrays[f"stat__{s}"] for s in header["stats"]},
                   checksum=stored, path=path)


# header key -> (test, what it must be)
_HEADER_TYPES = {
    "model": (lambda v: isinstance(v, str) and v != "", "a model name"),
    "params": (lambda v: isinstance(v, dict), "a JSON object"),
    "grid": (lambda v: isinstance(v, dict) and {"n", "beta", "ranges", "names"} <= set(v), "a PSF-space object"),
    "channels": (lambda v: v in (1, 3) and not isinstance(v, bool), "1 or 3"),
    "psf_resolution": (lambda v: isinstance(v, int) and not isinstance(v, bool) and v > 0, "an integer > 0"),
    "stats": (lambda v: isinstance(v, list) and all(isinstance(s, str) for s in v), "a list of names"),
}


def _check_header_types(header: dict, where: str) -> None:
    for key, (ok, want) in _HEADER_TYPES.items():
        if key not in header or not ok(header[key]):
            raise InputError(f"{where}: header {key} = {header.get(key)!r} must be {want}; {REBUILD}")


def _header_bytes(header: dict) -> bytes:
    return json.dumps(header, sort_keys=True, separators=(",", ":")).encode("utf-8")


def _checksum(header: bytes, arrays: dict) -> str:
    h = hashlib.sha256()
    h.update(header)
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"|{name}|{a.dtype.str}|{a.shape}|".encode("ascii"))
        h.update(a.tobytes())
    return h.hexdigest()


class DatabaseBuilder:
    """Collects PSF samples one by one, in cell order, and builds a :class:`SpreadletDatabase`.

    Parameters
    ----------
    model, params, grid, channels, psf_resolution
        As in :class:`SpreadletDatabase`.

    Examples
    --------
    >>> b = DatabaseBuilder("simple_lens", {"r_max": 8}, grid, 1, 256)   # doctest: +SKIP
    >>> for cell in range(grid.size):                                    # doctest: +SKIP
    ...     b.add(points, values, dense, fast_track=False, stats={"sparsity": .1, "ssim": .99, "l1": 1e-3})
    >>> db = b.build()                                                    # doctest: +SKIP
    """

    def __init__(self, model: str, params: dict, grid: NestedGrid, channels: int, psf_resolution: int):
        self.model, self.params, self.grid = model, params, grid
        self.channels, self.psf_resolution = channels, psf_resolution
        self._points, self._values, self._dense, self._fast = [], [], [], []
        self._rows: list = []   # basis "dual": (points, values, fast_track) per sample
        self._stats: dict = {}

    def __len__(self) -> int:
        return len(self._points)

    def add(self, points, values, dense, fast_track: bool = False, stats: dict | None = None,
            rows: tuple | None = None) -> int:
        """Append the next sample; returns its index.

        Parameters
        ----------
        points : array_like, (k, 2) int
            Spreadlet offsets (dx, dy) from the PSF centre in pixels, |d| < 32768.
        values : array_like, (k,) or (k, channels) float
            Spreadlet (Laplacian) values.
        dense : array_like, (2r+1, 2r+1) or (2r+1, 2r+1, channels) float
            The dense PSF cropped around its centre.
        fast_track : bool
            Splat this sample dense at run time (default False).
        stats : dict of str -> float
            This sample's statistics; the same names for every sample.
        rows : (points, values, fast_track), optional
            The sample's row differences: required for every sample of a ``"dual"`` database
            (params ``basis``), refused otherwise.
        """
        i = len(self)
        dual = isinstance(self.params, dict) and self.params.get("basis") == "dual"
        if (rows is not None) != dual:
            raise InputError(f"sample {i} rows: {'needed' if dual else 'given'} for a database of basis "
                             f"{self.params.get('basis', 'laplacian') if isinstance(self.params, dict) else 'laplacian'!r}")
        if rows is not None:
            rows = (*self._terms(i, *rows[:2]), bool(rows[2]))
        if i >= self.grid.size:
            raise InputError(f"database builder: sample {i} is beyond the {self.grid.size} cells of the grid")
        pts, vals = self._terms(i, points, values)
        d = np.asarray(dense, dtype=np.float32)
        if d.ndim == 2:
            d = d[..., None]
        if d.shape[2:] != (self.channels,):
            raise InputError(f"sample {i}: dense {d.shape} does not have {self.channels} channel(s)")
        if d.ndim != 3 or d.shape[0] != d.shape[1] or d.shape[0] % 2 != 1:
            raise InputError(f"sample {i} dense crop: shape {d.shape}, need (2r+1, 2r+1[, channels])")
        stats = dict(stats or {})
        if self._stats and set(stats) != set(self._stats):
            raise InputError(f"sample {i} stats: names {sorted(stats)} differ from earlier samples' "
                             f"{sorted(self._stats)}")
        for k, v in stats.items():
            self._stats.setdefault(k, []).append(float(v))
        self._points.append(pts)
        self._values.append(vals)
        self._dense.append(d.reshape(-1, self.channels))
        self._fast.append(bool(fast_track))
        if rows is not None:
            self._rows.append(rows)
        return i

    def _terms(self, i: int, points, values) -> tuple:
        """(int16 (k, 2), float32 (k, channels)) of one sample's spreadlets, checked."""
        pts = np.asarray(points).reshape(-1, 2)
        if pts.size and (not np.issubdtype(pts.dtype, np.integer) or np.abs(pts).max() > 32767):
            raise InputError(f"sample {i} points: need integer offsets with |d| <= 32767")
        vals = np.asarray(values, dtype=np.float32)
        vals = vals[:, None] if vals.ndim == 1 else vals
        if vals.shape != (len(pts), self.channels):
            raise InputError(f"sample {i}: values {vals.shape} do not match {len(pts)} point(s) with "
                             f"{self.channels} channel(s)")
        return pts.astype(np.int16), vals

    def build(self) -> SpreadletDatabase:
        """The database; every cell of the grid must have had its sample added."""
        if len(self) != self.grid.size:
            raise InputError(f"database builder: {len(self)} samples added, the grid has "
                             f"{self.grid.size} cells")
        counts = [len(p) for p in self._points]
        radius = [(int(round(np.sqrt(len(d)))) - 1) // 2 for d in self._dense]
        return SpreadletDatabase(
            model=self.model, params=self.params, grid=self.grid, channels=self.channels,
            psf_resolution=self.psf_resolution,
            C=np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
            P=np.concatenate(self._points).reshape(-1, 2),
            V=np.concatenate(self._values).reshape(-1, self.channels),
            fast_track=np.array(self._fast),
            dense_radius=np.array(radius, dtype=np.int32),
            dense_offsets=np.concatenate([[0], np.cumsum([len(d) for d in self._dense])]).astype(np.int64),
            dense_values=np.concatenate(self._dense),
            stats={k: np.array(v, dtype=np.float32) for k, v in self._stats.items()},
            **(_row_arrays(self._rows, self.channels) if self._rows else {}))


def _row_arrays(rows: list, channels: int) -> dict:
    """``row_C, row_P, row_V, row_fast`` of a dual database from its samples' (points, values, fast)."""
    return {"row_C": np.concatenate([[0], np.cumsum([len(p) for p, _, _ in rows])]).astype(np.int64),
            "row_P": np.concatenate([p for p, _, _ in rows]).reshape(-1, 2),
            "row_V": np.concatenate([v for _, v, _ in rows]).reshape(-1, channels),
            "row_fast": np.array([f for _, _, f in rows])}

"""Render labelled pixels into an image with a spreadlet database: LSR18's method and baselines.

``spreadlets`` (LSR18 section 6): each pixel splats its cell's spreadlets times its colour into
a padded tile plane by kind: Laplacian spreadlets, integrated by the renderer's integrator
(:mod:`runtime_cl.integrate`: by default ``fft32``,
:func:`~runtime_cl.integrate.poisson.poisson_integrate` in float32); fast-tracked cells' dense
PSFs; row differences, summed along the rows as the tiles merge, into one image plane with the
dense PSFs (:attr:`~runtime_cl.spreadlets.splat.SplatOutput.kinds`). The two canvas planes are
added and the padding cropped. ``splat``: every pixel splats its dense PSF. ``filter``: every output
pixel gathers with its own PSF. All three use the same PSFs, so they differ only by method.

Symmetries (LSR18 section 6): a database traced in one reference orientation is drawn with each
pixel's PSF turned by a per-pixel angle (``render(..., angle=...)``; the coordinate maps of
:mod:`runtime_cl.coords.maps` compute it). Without an angle the unrotated kernels run unchanged.
"""
from __future__ import annotations

import time

import numpy as np

from runtime_cl.psf.database import SpreadletDatabase
from runtime_cl.device.opencl import Device, as_f32, event_ms, get_device
from runtime_cl.psf.upload import DeviceDatabase
from runtime_cl.errors import InputError
from runtime_cl.spreadlets.gather import GatherFilter
from runtime_cl.spreadlets.highlights import HDR_RATIO, bright_pixels, splat_highlights
from runtime_cl.integrate import DEFAULT_INTEGRATOR, get_integrator
from runtime_cl.integrate.crop import integrate_support
from runtime_cl.masks import nonzero_pixels
from runtime_cl.psf.grid_cl import PsfIndexKernel, check_coords
from runtime_cl.spreadlets.angle_bank import AngleBank, angle_counts, bank_needs, entry_of
from runtime_cl.spreadlets.splat import DEFAULT_SPREADLET_ROTATION, RUN_MAX, SPREADLET_ROTATIONS, TileSplatter, half_turns



class Renderer:
    """Renders images with one database; its buffers are uploaded once, kernels built lazily.

    Parameters
    ----------
    db : SpreadletDatabase
        The PSF database.
    device : Device, optional
        Default :func:`~runtime_cl.device.opencl.get_device`.
    tile : int or (int, int), optional
        Tile size of the splat kernels in input pixels; default
        :func:`runtime_cl.spreadlets.splat.default_tile`.
    run_max : int
        Longest run of same-cell pixels the splat kernels splat together (default 32; 1 splats
        pixel by pixel, as LSR18's one-thread-per-pixel loop). Applies to both splat methods.
    spreadlet_rotation : {"bank", "bilinear", "nearest"}
        How the spreadlets method draws turned PSFs when :meth:`render` gets an angle. ``"bank"``
        (the default): every PSF (fast-tracked dense ones too) pre-turned at the nearest of a set
        of quantised angles (:mod:`runtime_cl.spreadlets.angle_bank`), the bank holding the
        entries the renderer's frames draw (:meth:`grow_bank`); ``"bilinear"``, ``"nearest"``:
        turned per pixel, spreadlets landing on pixels as
        :class:`~runtime_cl.spreadlets.splat.TileSplatter` says. Splat and Filter turn per pixel.
    integrator : str, optional
        How the ``spreadlets`` method integrates its Laplacian canvas: a registered integrator
        (:func:`runtime_cl.integrate.integrator_names`; default ``"fft32"``, the float32 FFT;
        ``"exact"``, the float64 one; ``"pyramid"``). A database of row differences (basis
        ``"rows"``) takes none: its canvas rows are summed as the tiles are merged.
    crop_integration : bool
        Integrate only the rectangle the splats reach when it is much smaller than the canvas
        (:func:`runtime_cl.integrate.crop.integrate_support`; depth layers). Default False; always
        on for a database of basis ``"dual"``, whose Laplacian plane holds only the pixels turned by
        other than 0 or pi (moving ones).
    hdr_ratio : float or None
        The ``spreadlets`` method splats pixels brighter than this times the image's typical
        level with their dense PSFs, outside the Laplacian canvas
        (:mod:`runtime_cl.spreadlets.highlights`; default :data:`HDR_RATIO`); None: never.
    """

    def __init__(self, db: SpreadletDatabase, device: Device | None = None, tile=None,
                 run_max: int = RUN_MAX, spreadlet_rotation: str = DEFAULT_SPREADLET_ROTATION,
                 integrator: str | None = None, crop_integration: bool = False,
                 hdr_ratio: float | None = HDR_RATIO):
        integrator_class = get_integrator(DEFAULT_INTEGRATOR if integrator is None else integrator)
        if db.basis == "rows" and integrator is not None:
            raise InputError(f"integrator = {integrator!r}: database {db.model!r} stores row differences "
                             "(basis 'rows'), summed along rows as they are merged, not a Laplacian; "
                             "give no integrator")
        if spreadlet_rotation not in SPREADLET_ROTATIONS:
            raise InputError(f"spreadlet_rotation = {spreadlet_rotation!r}: must be one of "
                             f"{list(SPREADLET_ROTATIONS)}")
        self.db = db
        self.device = device or get_device()
        self.ddb = DeviceDatabase(db, self.device)
        self.tile = tile
        self.run_max = run_max
        self.spreadlet_rotation = spreadlet_rotation
        # None: a row-difference database needs no integrator (TileSplatter sums its rows)
        self.integrator = None if db.basis == "rows" else integrator_class(self.device)
        self.crop_integration = bool(crop_integration) or db.basis == "dual"
        if hdr_ratio is not None and (isinstance(hdr_ratio, bool) or not (isinstance(hdr_ratio, (int, float))
                                                                    and hdr_ratio >= 1.0)):
            raise InputError(f"hdr_ratio = {hdr_ratio!r}: must be a number >= 1 (or None: no dense highlights)")
        self.hdr_ratio = hdr_ratio
        self._wrappers: dict = {}
        self._bank = None
        self._spare_bank = None   # the bank of the other Laplacian choice (grow_bank)
        self._index = None   # PsfIndexKernel of the bank's cells

    @property
    def angle_bank(self):
        """The :class:`~runtime_cl.spreadlets.angle_bank.AngleBank` of the cells this renderer's
        frames turned so far (every cell if :meth:`render` has not built one)."""
        if self._bank is None:
            self._bank = AngleBank(self.db)
        return self._bank

    def grow_bank(self, colour, coords, angle) -> bool | None:
        """With ``spreadlet_rotation="bank"``: rebuild the bank (and drop the splatters holding
        it) when this frame (float32 arrays as :meth:`render` takes them) draws bank entries the
        bank has not built, or is cheaper with(out) Laplacian entries than the bank is
        (:func:`~runtime_cl.spreadlets.angle_bank.bank_needs`). The bank builds only the entries
        (cell, angle) its frames draw -- on whirl 8.8 k of 60.5 k -- with the cells and angle
        indices of the splat kernel's own map (device cells, :func:`entry_of`'s float32 rounding),
        and holds the union over frames. :meth:`render` calls it unless told the caller did
        (``bank_checked``): it is per-pixel work (~50 ms at 1024^2).

        The renderer keeps one bank per choice (with and without Laplacian entries), each the
        union of the frames that chose it. Returns the choice, ``laplacian`` (None: no bank
        applies): a caller that grows several frames before rendering them passes each frame's
        choice to :meth:`render` (``bank_laplacian``), so it draws from the bank that holds its
        entries."""
        if self.spreadlet_rotation != "bank" or self.rotation_invariant:
            return None
        lit = nonzero_pixels(colour)
        cell = self._cells(coords[lit])
        need, laplacian = bank_needs(self.db, colour, coords, angle, self.ddb.dense_n, lit_cells=cell)
        if self._bank is not None and self._bank.laplacian != laplacian:
            # the other choice's bank, kept from earlier frames: frames that alternate (depth
            # layers, images of different content) swap banks instead of rebuilding them
            self._bank, self._spare_bank = self._spare_bank, self._bank
        bank = self._bank
        if bank is not None:
            need |= bank.cells
        K = angle_counts(self.db, need, laplacian)
        base = np.concatenate([[0], np.cumsum(K)[:-1]])
        entries = np.zeros(int(K.sum()), bool)
        cc, kk = entry_of(K, cell, angle[lit])
        entries[base[cc] + kk] = True
        if bank is not None and bank.laplacian == laplacian:
            if np.array_equal(bank.cells, need) and not np.any(entries & ~bank.built):
                return laplacian
            # the entries built so far, in the new layout (a quarter-turn cell's k of 4 is k K_i / 4)
            i = np.repeat(np.arange(self.db.n_samples), bank.angles)[bank.built]
            k = (np.arange(bank.n_entries) - np.repeat(bank.base, bank.angles))[bank.built]
            entries[base[i] + k * K[i] // bank.angles[i]] = True
        self._bank = AngleBank(self.db, cells=need, laplacian=laplacian, entries=entries)
        self._wrappers = {k: v for k, v in self._wrappers.items()
                          if bank is None or getattr(v, "bank", None) is not bank}
        return laplacian

    def _use_bank(self, laplacian: bool) -> None:
        """Make the bank of this choice (built by :meth:`grow_bank`) the current one."""
        if self._bank is None or self._bank.laplacian == laplacian:
            return
        if self._spare_bank is None or self._spare_bank.laplacian != laplacian:
            raise RuntimeError(f"no angle bank with laplacian={laplacian}: grow_bank chose it for no frame")
        self._bank, self._spare_bank = self._spare_bank, self._bank

    def _cells(self, coords) -> np.ndarray:
        """The cells of PSF coordinates ((m, ns) float32) as the splat kernel maps them."""
        if not len(coords):   # an empty frame: no cell (and a bank of nothing built)
            return np.zeros(0, np.int64)
        if self._index is None:
            self._index = PsfIndexKernel(self.db.grid, self.device, fp64=self.ddb.fp64)
        return self._index.index(coords)[0].astype(np.int64)

    def _wrapper(self, method: str, channels: int, rotate: bool, half: bool = False):
        # a splatter holding a bank is kept per bank (the two of grow_bank's choices)
        banked = rotate and not half and METHODS[method].splats_spreadlets and self.spreadlet_rotation == "bank"
        key = (method, channels, rotate, half) + ((id(self.angle_bank),) if banked else ())
        if key not in self._wrappers:
            self._wrappers[key] = METHODS[method].wrapper(self, channels, rotate, half)
        return self._wrappers[key]

    @property
    def rotation_invariant(self) -> bool:
        """The database records the symmetry ``rotation`` alone: its PSFs look the same at every
        angle, so :meth:`render` ignores an angle (no resampling, the unrotated kernels' speed)."""
        return self.db.params.get("symmetries") == ["rotation"]

    def _angle(self, angle, shape) -> np.ndarray:
        a = as_f32(angle, "angle", 2)
        if a.shape != shape:
            raise InputError(f"angle: shape {a.shape} does not match the image {shape}; need one angle "
                             "(radians) per pixel, shape (H, W)")
        if not np.all(np.isfinite(a)):
            raise InputError(f"angle: {int(np.count_nonzero(~np.isfinite(a)))} value(s) are NaN or infinite; "
                             "give every pixel a finite angle in radians (0: no rotation)")
        return a

    def render(self, colour, coords, method: str = "spreadlets", angle=None, bank_checked: bool = False,
               bank_laplacian: bool | None = None) -> tuple:
        """Render one image.

        Parameters
        ----------
        colour : array_like, float32, (H, W, C)
            Linear radiance, C = 1 or 3; zero pixels splat nothing. C = 4: radiance and opacity
            (premultiplied RGB, A) of a depth layer, the opacity drawn with the same PSFs (a
            3-channel database's green one).
        coords : array_like, float32, (H, W, ns)
            PSF coordinates per pixel (for ``simple_lens``: |CoC radius| in pixels; every model's
            map is in :mod:`runtime_cl.coords.maps`), inside the database's ranges.
        method : {"spreadlets", "splat", "filter"}
            LSR18's method or one of its two baselines (default ``"spreadlets"``).
        angle : array_like, float, (H, W), optional
            Per pixel, the angle in radians by which its stored PSF is turned, counter-clockwise
            as the image is viewed (from image +x towards y up; image rows grow downward), as
            :mod:`runtime_cl.coords.maps` computes it. Spreadlet offsets are turned and land
            on pixels as ``spreadlet_rotation`` says; dense PSFs (Splat, fast track) and the
            Filter's gather are turned by inverse bilinear mapping, scaled per channel to keep
            each PSF's energy (``kernels/spreadlets/rotate.cl``). Multiples of 90 degrees are exact
            permutations. Default None: no rotation, the unrotated kernels. Ignored for a
            database whose only symmetry is ``rotation`` (:attr:`rotation_invariant`).
        bank_checked : bool
            The caller passed this frame to :meth:`grow_bank` (the spreadlet passes do, in their
            ``prepare``); default False: :meth:`render` does.
        bank_laplacian : bool, optional
            With ``bank_checked``: the choice :meth:`grow_bank` returned for this frame, whose bank
            it draws from; default None: the current bank (that of the last frame grown).

        Returns
        -------
        image : ndarray, float32, (H, W, max(C, database channels))
        timings : dict
            Milliseconds: ``upload_ms``, ``kernel_ms`` (event profiling; split into
            ``splat_ms``/``merge_ms`` or ``filter_ms``), ``integrate_ms`` (wall clock; of it,
            ``integrate_device_ms`` and ``integrate_transfer_ms`` are event-profiled device
            kernels and copies of a device integrator), ``download_ms``,
            ``compile_ms`` (kernel builds this call needed; 0 once built), ``total_ms`` (wall
            clock of the whole call); counts ``pixels``, ``spreadlets``, ``dense_pixels``
            (splatted or gathered), ``tiles`` (splat work items; 0 for ``filter``),
            ``highlights`` (pixels the spreadlet method splat dense as HDR highlights);
            ``rotated`` (whether the PSFs were turned).
        """
        import pyopencl as cl

        start = time.perf_counter()
        if method not in METHODS:
            raise InputError(f"method = {method!r}: must be one of {list(METHODS)}")
        colour = as_f32(colour, "colour", 3)
        coords = as_f32(coords, "coords", 3)
        h, w, ch = colour.shape
        if ch not in (1, 3, 4):
            raise InputError(f"colour: {ch} channels, need 1 or 3 (shape (H, W, C)), or 4: a depth "
                             "layer's radiance and opacity (runtime_cl.spreadlets.layers)")
        if coords.shape[:2] != (h, w):
            raise InputError(f"coords: shape {coords.shape} does not match colour {colour.shape}; "
                             "need one set of PSF coordinates per pixel")
        if not np.all(np.isfinite(colour)):
            raise InputError(f"colour: {int(np.count_nonzero(~np.isfinite(colour)))} value(s) are NaN "
                             "or infinite; fix the input image")
        if h * w == 0:
            raise InputError(f"colour: empty image {colour.shape}")
        check_coords(self.db.grid, coords)
        if angle is not None:
            angle = self._angle(angle, (h, w))
        rotate = angle is not None and not self.rotation_invariant
        # only 0 and pi (the coc_sign symmetry): the turned PSFs keep their square, and the canvas its pad
        half = rotate and METHODS[method].splats and half_turns(angle)
        # HDR highlights leave the Laplacian canvas (spreadlets/highlights.py): dense, on their own
        splits = self.hdr_ratio is not None and getattr(METHODS[method], "dense_highlights", False)
        bright = bright_pixels(colour, self.hdr_ratio) if splits else None
        lit = colour if bright is None else np.where(bright[..., None], np.float32(0), colour)

        builds_before = len(self.device.builds)
        if rotate and not half and METHODS[method].splats_spreadlets and self.spreadlet_rotation == "bank":
            if not bank_checked:
                self.grow_bank(lit, coords, angle)
            elif bank_laplacian is not None:
                self._use_bank(bank_laplacian)
        wrapper = self._wrapper(method, ch, rotate, half)
        compile_ms = sum(b.ms for b in self.device.builds[builds_before:])

        ctx, q = self.device.context, self.device.queue
        mf = cl.mem_flags
        colour_buf = cl.Buffer(ctx, mf.READ_ONLY, colour.nbytes)
        coords_buf = cl.Buffer(ctx, mf.READ_ONLY, coords.nbytes)
        ups = [cl.enqueue_copy(q, colour_buf, lit, is_blocking=False),
               cl.enqueue_copy(q, coords_buf, coords, is_blocking=False)]
        angle_buf = None
        if rotate:
            angle_buf = cl.Buffer(ctx, mf.READ_ONLY, angle.nbytes)
            ups.append(cl.enqueue_copy(q, angle_buf, angle, is_blocking=False))
        upload_ms = event_ms(*ups)
        t = {"method": method, "pixels": h * w, "upload_ms": upload_ms, "compile_ms": compile_ms,
             "rotated": rotate}
        image, parts = METHODS[method].run(self, wrapper, colour_buf, coords_buf, h, w, angle_buf)
        t.update(parts)
        if bright is not None:
            more = splat_highlights(self, image, colour, coords, angle, bright)
            for k, v in more.items():
                t[k] += v
            t["kernel_ms"] += more["splat_ms"] + more["merge_ms"]
        t["highlights"] = 0 if bright is None else int(bright.sum())
        t["total_ms"] = (time.perf_counter() - start) * 1e3
        return image, t


class _Spreadlets:
    """LSR18: spreadlets into a Laplacian canvas (fast-tracked cells dense into a second one),
    integrated exactly, the dense canvas added."""

    splats_spreadlets = True   # spreadlet_rotation and run_max matter
    splats = True              # a TileSplatter: its canvas padding follows the angles
    dense_all = False
    dense_highlights = True    # pixels above HDR_RATIO x the typical level splat dense (highlights.py)

    @classmethod
    def wrapper(cls, r: Renderer, channels: int, rotate: bool, half: bool = False):
        banked = rotate and not half and not cls.dense_all and r.spreadlet_rotation == "bank"
        return TileSplatter(r.ddb, channels, dense_all=cls.dense_all, run_max=r.run_max, rotate=rotate,
                            spreadlet_rotation=r.spreadlet_rotation, half_turns=half,
                            bank=r.angle_bank if banked else None)

    @classmethod
    def run(cls, r: Renderer, wrapper, colour_buf, coords_buf, h, w, angle_buf):
        out = wrapper.run(colour_buf, coords_buf, h, w, r.tile, angle_buf)
        t0 = time.perf_counter()
        image, it = cls.image(r, out, h, w)
        return image, dict(splat_ms=out.splat_ms, merge_ms=out.merge_ms, kernel_ms=out.splat_ms + out.merge_ms,
                           download_ms=out.download_ms, integrate_ms=(time.perf_counter() - t0) * 1e3,
                           integrate_device_ms=it["device_ms"], integrate_transfer_ms=it["transfer_ms"],
                           spreadlets=out.spreadlets, dense_pixels=out.dense_pixels, tiles=out.tiles)

    @staticmethod
    def image(r: Renderer, out, h: int, w: int) -> tuple:
        """The cropped image (the integrated Laplacian plane plus the image plane, the dense and
        row planes the merge kernel summed) and the integrator's times."""
        p, times = out.pad, {"device_ms": 0.0, "transfer_ms": 0.0}
        parts = []
        for plane, kind in zip(out.canvas, out.kinds):
            if kind == "laplacian":
                # an all-zero Laplacian integrates to zero: skip the integration when nothing was splat
                if out.laplacian_box is None:
                    continue
                full, times = integrate_support(r.integrator, plane, out.laplacian_box) if r.crop_integration \
                    else r.integrator(plane)
                parts.append(full[p:p + h, p:p + w])
            else:
                parts.append(plane[p:p + h, p:p + w])
        if not parts:
            return np.zeros((h, w, out.canvas.shape[-1]), np.float32), times
        # two planes summed into a new array (not copied, then added: one full-frame pass less)
        return (parts[0].copy() if len(parts) == 1 else np.add(parts[0], parts[1])), times


class _Splat(_Spreadlets):
    """LSR18's Splat baseline: every pixel splats its dense PSF."""

    splats_spreadlets = False
    dense_all = True
    dense_highlights = False

    @staticmethod
    def image(r: Renderer, out, h: int, w: int) -> tuple:
        p = out.pad
        return out.canvas[0, p:p + h, p:p + w].copy(), {"device_ms": 0.0, "transfer_ms": 0.0}


class _Filter:
    """LSR18's Filter baseline: every output pixel gathers with its own PSF."""

    splats_spreadlets = False
    splats = False

    @staticmethod
    def wrapper(r: Renderer, channels: int, rotate: bool, half: bool = False):
        return GatherFilter(r.ddb, channels, rotate=rotate)

    @staticmethod
    def run(r: Renderer, wrapper, colour_buf, coords_buf, h, w, angle_buf):
        image, kernel_ms, download_ms, psf_px = wrapper.run(colour_buf, coords_buf, h, w, angle_buf)
        return image, dict(filter_ms=kernel_ms, kernel_ms=kernel_ms, download_ms=download_ms,
                           integrate_ms=0.0, integrate_device_ms=0.0, integrate_transfer_ms=0.0,
                           spreadlets=0, dense_pixels=psf_px, tiles=0)


# The methods a Renderer runs, by name: LSR18's method and its two baselines.
METHODS = {"spreadlets": _Spreadlets, "splat": _Splat, "filter": _Filter}

"""Exact splatting with private tiles (``kernels/spreadlets/splat.cl``): spreadlets and dense PSFs.

PoCL has no float atomics; per-work-item private buffers merged in a fixed order measured
fastest among the exact options on this stack (DESIGN.md: 648 M splats/s vs 346 M/s for a CAS
loop). Each work item owns a square tile of input pixels and a buffer of the tile plus the PSF
padding on every side, so the canvas rows a run of pixels touches stay in the core's L2
(measured 5-10 % faster than full-width row bands at 1024^2 with PSF radii up to 100, and
more work items balance the cores better). Runs of neighbouring pixels with the same PSF cell
are splat together (see ``spreadlets/splat.cl``), for spreadlets and dense PSFs alike, so LSR18's two
methods are compared with the same machinery.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from runtime_cl.device.opencl import event_ms
from runtime_cl.psf.upload import KIND_DENSE, KIND_LAPLACIAN, KIND_ROWS, DeviceDatabase
from runtime_cl.spreadlets.angle_bank import AngleBank
from runtime_cl.errors import InputError
from runtime_cl.integrate.poisson import fft_friendly

# Longest run of same-cell pixels splat together (runs also end at tile edges); 1 = pixel by
# pixel (LSR18's loop). Defocus scene, 1024^2 RGB, 128^2 tiles, CPU ms of the spreadlet kernel:
# 1196 (16), 774 (32), 684 (64), 613 (128); demo database: 1179 (32), 1021 (64), 770 (128).
RUN_MAX = 128
SPREADLET_ROTATIONS = ("bilinear", "nearest", "bank")
# The tile planes a splat pass can draw (TileSplatter.kinds), in plane order; the merge sums the
# dense and row planes into one canvas plane, "image" (SplatOutput.kinds)
KINDS = ("laplacian", "dense", "rows")
# What the Renderer and the spreadlet passes use: the angle bank (runtime_cl/spreadlets/angle_bank.py),
# built of the entries a frame draws (whirl: 8.8 k of 60.5 k turned PSFs, ~1 s once; a frame
# 640 -> 130 ms against the per-pixel turn). It was opt-in while it built every angle of every
# turned cell (~5 s; ~25 s before that). README "Where a spreadlet frame's time goes"
DEFAULT_SPREADLET_ROTATION = "bank"


@dataclass
class SplatOutput:
    """What one splat pass produced.

    Attributes
    ----------
    canvas : ndarray, float32, (planes, Hc, Wc, OC)
        One plane per entry of ``kinds``. Input pixel (x, y) sits at canvas (x + pad, y + pad).
        A view of the splatter's host buffer: valid until its next :meth:`TileSplatter.run`.
    kinds : tuple of str
        What each plane holds: ``"laplacian"`` (Laplacian spreadlets, to integrate) and
        ``"image"`` (the dense PSFs -- the Splat baseline's image, or the fast track -- plus the
        row differences summed along the rows, added on the device). In that order.
    pad : int
        Canvas padding.
    splat_ms, merge_ms, download_ms : float
        Event-profiled times in milliseconds.
    spreadlets, dense_pixels : int
        Spreadlets and dense PSF pixels splatted (pixels with zero colour splat nothing).
    tiles : int
        Number of tiles (work items).
    tile : tuple of int
        (width, height) of a tile in input pixels.
    laplacian_box : tuple of int or None
        (y0, y1, x0, x1): the canvas rectangle outside which the ``"laplacian"`` plane is zero (the
        pixels that drew Laplacian spreadlets, grown by the padding); None if none did.
    """

    canvas: np.ndarray
    kinds: tuple
    pad: int
    splat_ms: float
    merge_ms: float
    download_ms: float
    spreadlets: int
    dense_pixels: int
    tiles: int
    tile: tuple
    laplacian_box: tuple | None = None


def _laplacian_box(counts: np.ndarray, pad: int, hc: int, wc: int):
    """The canvas rectangle the Laplacian spreadlets can reach (their pixels' box, from the tiles'
    counts, grown by the padding: pixel (x, y) sits at canvas (x + pad, y + pad) and reaches less
    than pad), or None where no tile drew any."""
    drew = counts[counts[:, 2] > 0]
    if not len(drew):
        return None
    return (int(drew[:, 5].min()), min(int(drew[:, 6].max()) + 2 * pad + 1, hc),
            int(drew[:, 3].min()), min(int(drew[:, 4].max()) + 2 * pad + 1, wc))


def half_turns(angle: np.ndarray) -> bool:
    """Whether every angle (float32 radians) is 0 or +-pi: turns that ``rotation_cs`` in
    ``kernels/spreadlets/rotate.cl`` makes exact (cos, sin) = (+-1, 0), which keep every turned
    offset inside the stored PSF's square."""
    a = np.abs(angle)
    return bool(np.all((a == 0.0) | (a == np.float32(np.pi))))


def canvas_shape(height: int, width: int, pad: int) -> tuple:
    """(Hc, Wc): the padded canvas, enlarged to FFT-friendly sizes for the Poisson solve."""
    return fft_friendly(height + 2 * pad), fft_friendly(width + 2 * pad)


def default_tile(height: int, width: int, pad: int, compute_units: int) -> tuple:
    """(tile_w, tile_h): square tiles of 128 pixels (256 when the padding exceeds 128), halved
    down to 32 until there are at least four tiles per compute unit (load balance), clamped to
    the image. Larger tiles overlap less (buffer pixels per input pixel: ((T + 2 pad) / T)^2);
    smaller ones keep the canvas rows a run touches in L2.
    """
    side = 128 if pad <= 128 else 256
    while side > 32 and -(-height // side) * -(-width // side) < 4 * compute_units:
        side //= 2
    return min(side, width), min(side, height)


class TileSplatter:
    """Wrapper of ``splat_tiles`` + ``merge_tiles`` for one database and colour channel count.

    Parameters
    ----------
    ddb : DeviceDatabase
        The uploaded database.
    colour_channels : int
        1 or 3 channels in the colour input, or 4 (a depth layer's radiance and opacity, each
        drawn with the same PSFs; a 3-channel database draws the 4th with its green PSF).
    dense_all : bool
        True: LSR18's Splat baseline (every pixel splats its dense PSF); False: spreadlets, with
        fast-tracked cells splat dense into their own plane (:attr:`SplatOutput.kinds`).
    run_max : int
        Longest run of same-cell pixels splat together (default :data:`RUN_MAX`); 1 splats
        pixel by pixel. Runs change only the float rounding of the Laplacian canvas.
    rotate : bool
        Turn every pixel's PSF by its angle (``kernels/spreadlets/rotate.cl``; :meth:`run` then needs an
        angle buffer). The canvas padding grows to :attr:`SpreadletDatabase.rotated_pad`.
        Default False: the unrotated kernel, which never reads an angle.
    spreadlet_rotation : {"bilinear", "nearest", "bank"}
        With ``rotate``: how a turned spreadlet lands on the pixel grid (default ``"bilinear"``:
        shared among four pixels; ``"nearest"``: the nearest one, LSR18's cheaper way, with
        errors of 10-50 % of the PSF, see ``splat_spreadlets_rotated`` in ``kernels/spreadlets/splat.cl``;
        ``"bank"``: every PSF pre-turned at quantised angles, ``bank`` below).
    bank : AngleBank, optional
        With ``spreadlet_rotation="bank"`` (spreadlets only, not ``half_turns``): the turned PSFs
        (:class:`runtime_cl.spreadlets.angle_bank.AngleBank`); a pixel splats, unturned, the
        entry of the angle nearest its own. Default: built here from the database.
    half_turns : bool
        With ``rotate``: the caller promises every angle is 0 or +-pi (float32), as the
        ``coc_sign`` symmetry alone gives (:func:`half_turns`). A half turn maps the stored
        square onto itself, so the canvas keeps :attr:`SpreadletDatabase.pad` instead of
        growing to ``rotated_pad`` (the turned square's sqrt 2): on the demo 1208^2 instead of
        1296^2 canvas pixels to merge, download and integrate, and 128 px tiles instead of 256.
    """

    def __init__(self, ddb: DeviceDatabase, colour_channels: int, dense_all: bool, run_max: int = RUN_MAX,
                 rotate: bool = False, spreadlet_rotation: str = "bilinear", half_turns: bool = False,
                 bank=None):
        import pyopencl as cl

        if colour_channels not in (1, 3, 4):
            raise InputError(f"colour channels = {colour_channels}: must be 1, 3 or 4")
        if not (isinstance(run_max, (int, np.integer)) and 1 <= run_max <= 256):
            raise InputError(f"run_max = {run_max!r}: must be an integer in [1, 256]")
        if spreadlet_rotation not in SPREADLET_ROTATIONS:
            raise InputError(f"spreadlet_rotation = {spreadlet_rotation!r}: must be one of "
                             f"{list(SPREADLET_ROTATIONS)}")
        self.ddb, self.device = ddb, ddb.device
        self.dense_all = bool(dense_all)
        self.colour_channels = colour_channels
        self.out_channels = max(colour_channels, ddb.db.channels)
        self.run_max = int(run_max)
        self.rotate = bool(rotate)
        self.half_turns = self.rotate and bool(half_turns)
        self.bank = None
        if self.rotate and not self.half_turns and not self.dense_all and spreadlet_rotation == "bank":
            self.bank = bank if bank is not None else AngleBank(ddb.db)
        if ddb.db.basis == "rows" and self.rotate and not self.half_turns and not self.dense_all:
            raise InputError(f"database {ddb.db.model!r} stores row differences (basis 'rows'), which turn "
                             "by 180 degrees only; rebuild it with basis = 'laplacian' to turn its PSFs by any angle")
        turns = self.rotate and self.bank is None   # the kernel turns PSFs per pixel (rotate.cl)
        self.kinds = self._kinds()
        self.pad = ddb.db.rotated_pad if self.rotate and not self.half_turns else ddb.db.pad
        if self.bank is not None:
            self.pad = self.bank.pad
        options = ddb.base_options + [f"-DPAD={self.pad}", f"-DCC={colour_channels}", f"-DOC={self.out_channels}",
                                      f"-DDENSE_ALL={int(self.dense_all)}", f"-DGROUPS={self.groups}",
                                      f"-DRUN_MAX={self.run_max}", f"-DROTATE={int(turns)}",
                                      f"-DBANK={int(self.bank is not None)}",
                                      f"-DDUAL={int(ddb.db.basis == 'dual' and self.bank is None)}",
                                      f"-DCELLS={ddb.db.n_samples}",
                                      f"-DSPREADLET_BILINEAR={int(spreadlet_rotation == 'bilinear')}"]
        options += [f"-D{macro}={self.kinds.index(kind) if kind in self.kinds else -1}"
                    for kind, macro in zip(KINDS, ("LAP_GROUP", "DENSE_GROUP", "ROW_GROUP"))]
        rotate = ("spreadlets/rotate.cl",) if turns else ()
        self.turns = turns
        self._bank_buffers = self._upload_bank() if self.bank is not None else {}
        files = ("psf/psf_space.cl", "prelude/pixels.cl") + rotate + ("spreadlets/splat.cl",)
        program, self.build = self.device.program(files, options)
        self.splat_kernel = cl.Kernel(program, "splat_tiles")
        self.splat_kernel.set_scalar_arg_dtypes([None] * 22 + [np.int32] * 5)
        self.merge_kernel = cl.Kernel(program, "merge_tiles")
        self.merge_kernel.set_scalar_arg_dtypes([None, None, None] + [np.int32] * 6)
        self._scratch: dict = {}
        self._host = np.empty(0, np.float32)
        self.device.warm_up(self.build, self._warm_up)

    @property
    def groups(self) -> int:
        """Tile planes (:attr:`kinds`)."""
        return len(self.kinds)

    @property
    def canvas_kinds(self) -> tuple:
        """The canvas planes the merge writes (:attr:`SplatOutput.kinds`)."""
        return tuple(k for k, drawn in (("laplacian", "laplacian" in self.kinds),
                                        ("image", any(k != "laplacian" for k in self.kinds))) if drawn)

    def _kinds(self) -> tuple:
        """The tile planes this splatter's frames draw into (of :data:`KINDS`): those of the kinds
        its cells (or bank entries) have."""
        if self.dense_all:
            return ("dense",)
        kinds = self.bank.fast if self.bank is not None else self.ddb.kinds
        codes = (KIND_LAPLACIAN, KIND_DENSE, KIND_ROWS)
        return tuple(kind for kind, code in zip(KINDS, codes) if np.any(kinds == code))

    def _upload_bank(self) -> dict:
        """The bank's arrays on the device, under the database buffers' names they replace."""
        import pyopencl as cl

        bank = self.bank
        host = {"C": self.bank.C, "P": self.bank.P, "V": self.bank.V, "fast": self.bank.fast,
                "dense_r": self.bank.dense_r, "dense_off": self.bank.dense_off, "dense_v": self.bank.dense_v,
                "span_off": bank.span_off, "span": bank.span, "dense_n": bank.dense_n,
                "bank_k": self.bank.angles, "bank_base": self.bank.base}
        flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
        out = {}
        for name, array in host.items():
            array = np.ascontiguousarray(array)
            out[name] = cl.Buffer(self.device.context, flags, hostbuf=array) if array.nbytes else \
                cl.Buffer(self.device.context, cl.mem_flags.READ_ONLY, 16)
        return out

    def _warm_up(self):
        import pyopencl as cl

        ctx, ns = self.device.context, self.ddb.db.grid.ns
        lo = np.array([r[0] for r in self.ddb.db.grid.ranges], np.float32)
        flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
        colour = cl.Buffer(ctx, flags, hostbuf=np.ones(self.colour_channels, np.float32))
        coords = cl.Buffer(ctx, flags, hostbuf=lo.reshape(ns))
        turn = np.float32(np.pi if self.half_turns else 0.5)   # a turn this splatter's padding holds
        angle = cl.Buffer(ctx, flags, hostbuf=np.full(1, turn, np.float32)) if self.rotate else None
        self.run(colour, coords, 1, 1, angle_buf=angle)

    def _buffer(self, name: str, nbytes: int):
        import pyopencl as cl

        buf = self._scratch.get(name)
        if buf is None or buf.size < nbytes:
            self._scratch.pop(name, None)  # free the old buffer before allocating the new one
            buf = cl.Buffer(self.device.context, cl.mem_flags.READ_WRITE, max(nbytes, 16))
            self._scratch[name] = buf
        return buf

    def _host_canvas(self, shape: tuple) -> np.ndarray:
        """The host array the canvas is downloaded into, kept from run to run: a fresh 50-100 MB
        array per frame is mapped anew and page-faulted in by the copy, which measured 60-150 ms
        of a 1024^2 frame (whirl, three planes) against ~10 ms into touched pages."""
        size = int(np.prod(shape))
        if self._host.size < size:
            self._host = np.empty(size, np.float32)
        return self._host[:size].reshape(shape)

    def _layout(self, height: int, width: int, tile) -> tuple:
        """(tile_w, tile_h, tiles_x, tiles_y, bytes of the tile buffers), grown to fit the device."""
        pad = self.pad
        if tile is None:
            tw, th = default_tile(height, width, pad, self.device.device.max_compute_units)
        else:
            tw, th = (tile, tile) if isinstance(tile, (int, np.integer)) else tile
            if not (int(tw) >= 1 and int(th) >= 1):
                raise InputError(f"tile = {tile!r}: need a size >= 1 or a (width, height) pair of them")
            tw, th = min(int(tw), width), min(int(th), height)
        pixel_bytes = 4 if self.out_channels == 1 else 16  # RGB(A) tile pixels are float4

        def size(tw, th):
            tx, ty = -(-width // tw), -(-height // th)
            return tw, th, tx, ty, tx * ty * self.groups * (th + 2 * pad) * (tw + 2 * pad) * pixel_bytes

        layout = size(tw, th)
        limit = self.device.device.max_mem_alloc_size
        # larger tiles overlap less: grow them until the tile buffers fit the device
        while layout[4] > limit and (layout[0] < width or layout[1] < height):
            layout = size(min(2 * layout[0], width), min(2 * layout[1], height))
        if layout[4] > limit:
            raise InputError(f"image {height}x{width} with padding {pad}: the splat buffer needs "
                             f"{layout[4] >> 20} MiB, the OpenCL device allows {limit >> 20} "
                             "MiB per buffer; render a smaller image or tiles of it")
        return layout

    def run(self, colour_buf, coords_buf, height: int, width: int, tile=None, angle_buf=None) -> SplatOutput:
        """Splat every pixel of an image already on the device.

        Parameters
        ----------
        colour_buf, coords_buf : pyopencl.Buffer
            float32 (H, W, CC) colour and (H, W, ns) PSF coordinates (validated by the caller).
        height, width : int
            Image size in pixels.
        tile : int or (int, int), optional
            Tile size (width, height) in input pixels, clamped to the image; default
            :func:`default_tile`. The result does not depend on it beyond float rounding.
        angle_buf : pyopencl.Buffer, optional
            float32 (H, W) angles in radians (see ``kernels/spreadlets/rotate.cl``); required if and only
            if this splatter rotates.
        """
        import pyopencl as cl

        if (angle_buf is not None) != self.rotate:
            raise InputError(f"angle_buf: {'required' if self.rotate else 'not read'} by a splatter "
                             f"built with rotate={self.rotate}")
        if angle_buf is None:
            angle_buf = self._buffer("no_angle", 16)  # the unrotated kernel never reads it
        pad, oc = self.pad, self.out_channels
        hc, wc = canvas_shape(height, width, pad)
        tw, th, tiles_x, tiles_y, nbytes = self._layout(height, width, tile)
        ntiles = tiles_x * tiles_y
        tiles_buf = self._buffer("tiles", nbytes)
        counts_buf = self._buffer("counts", ntiles * 64)
        # each work item's turned dense PSF: values and row headers (splat.cl splat_dense_rotated)
        scratch = ntiles * (2 * pad + 1) * (2 * pad + 2) * 16 if self.turns and not self.half_turns else 16
        scratch_buf = self._buffer("turned", scratch)
        planes = self.canvas_kinds
        canvas_buf = self._buffer("canvas", len(planes) * hc * wc * oc * 4)
        b, q = dict(self.ddb.buffers, **self._bank_buffers), self.device.queue
        no_bank = self._buffer("no_bank", 16)   # read only by a bank kernel
        ev_splat = self.splat_kernel(
            q, (ntiles,), (1,), colour_buf, coords_buf, angle_buf, b.get("bank_k", no_bank),
            b.get("bank_base", no_bank), b["psf_thr"], b["psf_bucket"], b["C"], b["P"],
            b["V"], b["fast"], b["dense_r"], b["dense_off"], b["dense_v"], b["span_off"], b["span"], b["dense_n"],
            b["dense_sum"], b["dense_box"], tiles_buf, counts_buf, scratch_buf,
            height, width, tw, th, tiles_x)
        ev_merge = self.merge_kernel(q, (hc,), (1,), tiles_buf, counts_buf, canvas_buf, tiles_x, tiles_y, tw, th, wc, hc,
                                     wait_for=[ev_splat])
        canvas = self._host_canvas((len(planes), hc, wc, oc))
        counts = np.empty((ntiles, 8), np.int64)
        ev_down = cl.enqueue_copy(q, canvas, canvas_buf, wait_for=[ev_merge], is_blocking=False)
        ev_counts = cl.enqueue_copy(q, counts, counts_buf, wait_for=[ev_splat], is_blocking=False)
        ev_down.wait()
        ev_counts.wait()
        return SplatOutput(canvas, planes, pad, event_ms(ev_splat), event_ms(ev_merge), event_ms(ev_down),
                           int(counts[:, 0].sum()), int(counts[:, 1].sum()), ntiles, (tw, th),
                           _laplacian_box(counts, pad, hc, wc))

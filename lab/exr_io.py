"""Labelled-pixel and plain RGB EXR files (``OpenEXR.File`` API), written atomically.

A labelled-pixel EXR (DESIGN.md contract) holds float32 channels ``R, G, B`` (linear radiance),
``A`` (coverage), ``Z`` (camera-space planar depth in metres along the optical axis; ``inf`` for
background at infinity) and optional extras (``motion.X``, ``motion.Y``: pixels moved over the
shutter, X right, Y up; ``lens.U``, ``layer0.R``, ...), plus the header string attribute
``splatlab.camera`` holding the camera as JSON. Reading validates all of it and raises
:class:`~lab.errors.UserError` naming the file and the fix.

Layers: ``layerN.R, .G, .B, .A, .Z`` for N = 0, 1, ... (nearest first), colour premultiplied by
the layer's coverage A (:func:`image_layers`); the top-level R, G, B, A, Z stay the flat image.
"""
from __future__ import annotations

import json
import os
import re
import sys
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import OpenEXR

from runtime_cl.atomic_file import atomic_path
from runtime_cl.input_file import open_input
from runtime_cl.json_values import is_number, loads

from .cameras import header_camera
from .config import MAX_SIDE_PX
from .errors import UserError

CAMERA_ATTR = "splatlab.camera"
FORMAT_ATTR = "splatlab.format"
GUARD_ATTR = "splatlab.guard_px"   # guard band (LSR18 "Boundary"): margin around the frame, pixels
FORMAT = "labelled-pixels/1"
CORE = ("R", "G", "B", "A", "Z")
EXR_MAGIC = b"\x76\x2f\x31\x01"
MAX_CHANNELS = 1024     # 5 per layer: 200 layers, far beyond LES09's handful
_LAYER = re.compile(r"layer(\d+)\.(.+)")


@dataclass(frozen=True)
class LabelledImage:
    """A labelled-pixel image in memory.

    Parameters
    ----------
    rgb : (H, W, 3) float32
        Linear radiance.
    alpha : (H, W) float32
        Coverage in [0, 1].
    depth : (H, W) float32
        Camera-space planar depth in metres (> 0, ``inf`` for background).
    camera : dict
        The ``splatlab.camera`` JSON object, e.g. ``{"lens": "thin", "focal_length_mm": 50, ...}``.
    extra : dict of str -> (H, W) float32
        Further channels by their EXR names.
    guard_px : int
        Guard band: the pixels are the frame plus this margin on every side (header
        ``splatlab.guard_px``; the camera header describes the whole, widened sensor). Default 0.
    """

    rgb: np.ndarray
    alpha: np.ndarray
    depth: np.ndarray
    camera: dict
    extra: dict = field(default_factory=dict)
    guard_px: int = 0

    def frame_crop(self, image: np.ndarray) -> np.ndarray:
        """``image`` (H, W, ...) of these pixels without the guard band."""
        g = self.guard_px
        return image if g == 0 else image[g:image.shape[0] - g, g:image.shape[1] - g]

    def __post_init__(self):
        h, w = self.depth.shape
        if self.rgb.shape != (h, w, 3) or self.alpha.shape != (h, w):
            raise ValueError(f"LabelledImage: rgb {self.rgb.shape}, alpha {self.alpha.shape} and depth "
                             f"{self.depth.shape} must be (H, W, 3), (H, W), (H, W)")
        for name, ch in self.extra.items():
            if name in CORE or ch.shape != (h, w):
                raise ValueError(f"LabelledImage: extra channel {name!r} must be (H, W) and not one of {CORE}")

    @property
    def height(self) -> int:
        return self.depth.shape[0]

    def layers(self, source: str = "input") -> list[ImageLayer]:
        """The ``layerN.<channel>`` layers, nearest first (empty when there are none); see
        :func:`image_layers`."""
        return image_layers(self.extra, source)

    @property
    def width(self) -> int:
        return self.depth.shape[1]


@dataclass(frozen=True)
class ImageLayer:
    """One layer of a layered labelled image: channels ``layerN.R, .G, .B, .A, .Z``.

    ``rgb`` (H, W, 3) is premultiplied by the coverage ``alpha`` (H, W); ``depth`` (H, W) is the
    planar depth of what the layer holds (``inf`` where it holds nothing).
    """

    rgb: np.ndarray
    alpha: np.ndarray
    depth: np.ndarray


def image_layers(channels: dict, source: str) -> list[ImageLayer]:
    """The layers among ``channels`` (name -> (H, W)), checked; nearest (``layer0``) first.

    Layers hold what a layer's objects show in front of all later layers' objects, e.g. layer0 a
    foreground with alpha and layer1 the rest of the scene rendered without it.

    Raises
    ------
    UserError
        A ``layer...`` channel that is not ``layerN.R|G|B|A|Z``, numbers that are not 0..N-1, a
        layer without all five channels, coverage outside [0, 1] or bad depth.
    """
    found: dict[int, dict] = {}
    for name, data in channels.items():
        if not name.startswith("layer"):
            continue
        m = _LAYER.fullmatch(name)
        if m is None or m.group(2) not in CORE:
            raise UserError(f"{source}: channel {name!r} is not a layer channel; layers are named "
                            f"layerN.<channel> with a channel from {list(CORE)}, e.g. layer0.R")
        found.setdefault(int(m.group(1)), {})[m.group(2)] = data
    if found and sorted(found) != list(range(len(found))):
        gaps = sorted(set(range(max(found) + 1)) - set(found))
        raise UserError(f"{source}: layer channels for layers {sorted(found)} but not {gaps}; number the "
                        "layers 0, 1, ... from the nearest without gaps")
    layers = []
    for i in range(len(found)):
        missing = [f"layer{i}.{c}" for c in CORE if c not in found[i]]
        if missing:
            raise UserError(f"{source}: layer {i} lacks channel(s) {missing}; every layer needs "
                            f"layer{i}.R, .G, .B, .A (coverage) and .Z (depth)")
        ch = found[i]
        alpha = ch["A"]
        if not (np.all(alpha >= 0) and np.all(alpha <= 1)):   # NaN fails both
            raise UserError(f"{source}: layer{i}.A has values outside [0, 1] (or NaN); the coverage of "
                            "a layer must lie in [0, 1] (premultiply its colour by it)")
        _check_depth(f"{source} layer{i}.Z", ch["Z"])
        layers.append(ImageLayer(np.stack([ch[c] for c in "RGB"], axis=-1), alpha, ch["Z"]))
    return layers


def _check_shutter(data: dict, source: str):
    shutter = data.get("shutter", [0.0, 1.0])
    ok = (isinstance(shutter, list) and len(shutter) == 2
          and all(is_number(t) for t in shutter) and shutter[0] <= shutter[1])
    if not ok:
        raise UserError(f"{source}: shutter = {shutter!r} must be [open, close] with open <= close")


def validate_camera(data, source: str) -> dict:
    """Check a ``splatlab.camera`` JSON object (by its lens: :func:`lab.cameras.header_camera`,
    then the shutter); return it unchanged or raise naming ``source``."""
    header_camera(data, source)
    _check_shutter(data, source)
    return data


@contextmanager
def _c_output(lines: list):
    """Catch what OpenEXR's C++ code prints on the process's stdout and stderr (a warning per
    damaged chunk) into ``lines``, so a bad file ends in one message, not several."""
    sys.stdout.flush(), sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    with tempfile.TemporaryFile() as sink:
        os.dup2(sink.fileno(), 1), os.dup2(sink.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved[0], 1), os.dup2(saved[1], 2)
            os.close(saved[0]), os.close(saved[1])
            sink.seek(0)
            lines.extend(line.strip() for line in sink.read().decode("utf-8", "replace").splitlines() if line.strip())


def _reason(exc: Exception, printed: list, tmp=None, path=None) -> str:
    """One line saying why OpenEXR failed: its exception or, more telling, what it printed."""
    coded = [line[line.index("(EXR_ERR"):] for line in printed if "(EXR_ERR" in line]
    text = (coded or printed or str(exc).splitlines() or [type(exc).__name__])[-1]
    return text.replace(str(tmp), str(path)) if tmp is not None else text


def _atomic_write(path, header: dict, channels: dict):
    """Write to a temporary file beside ``path`` then rename, so readers never see half a file."""
    path = Path(path)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **header}
    chans = {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in channels.items()}
    with atomic_path(path, what="EXR output") as tmp, OpenEXR.File(header, chans) as exr:
        printed: list = []
        try:
            with _c_output(printed):
                exr.write(str(tmp))
        except RuntimeError as exc:   # OpenEXR reports a full disk or an I/O error this way
            raise UserError(f"EXR output {path}: cannot be written ({_reason(exc, printed, tmp, path)}); "
                            "free disk space or write to another folder") from None


def write_labelled(path, image: LabelledImage):
    """Write a labelled-pixel EXR atomically (float32 channels, ZIP compression).

    Parameters
    ----------
    path : str or Path
        Destination; parent directories are created. Written to a temporary file beside it and
        renamed, so a reader never sees a half-written file.
    image : LabelledImage
        Its camera is validated first (see :func:`validate_camera`).
    """
    validate_camera(image.camera, f"{path}: camera to write")
    channels = {"R": image.rgb[..., 0], "G": image.rgb[..., 1], "B": image.rgb[..., 2],
                "A": image.alpha, "Z": image.depth, **image.extra}
    header = {CAMERA_ATTR: json.dumps(image.camera, sort_keys=True), FORMAT_ATTR: FORMAT}
    if image.guard_px:
        header[GUARD_ATTR] = str(int(image.guard_px))
    _atomic_write(path, header, channels)


def write_rgb(path, rgb: np.ndarray, header: dict | None = None):
    """Write an (H, W, 3) linear RGB image (a reference) as a float32 EXR, atomically.

    ``header`` adds string attributes, e.g. ``{"splatlab.camera": json.dumps(...)}``.
    """
    rgb = np.asarray(rgb)
    if rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError(f"write_rgb: rgb must be (H, W, 3), got {rgb.shape}")
    _atomic_write(path, dict(header or {}), {"R": rgb[..., 0], "G": rgb[..., 1], "B": rgb[..., 2]})


def _layout(path, header: dict) -> None:
    """Refuse, before any pixel is read, what a labelled image cannot be: a size beyond
    :data:`~lab.config.MAX_SIDE_PX`, too many channels, sub-sampled channels."""
    lo, hi = (np.asarray(v, dtype=np.int64) for v in header["dataWindow"])
    w, h = (hi - lo + 1).tolist()
    if not (1 <= w <= MAX_SIDE_PX and 1 <= h <= MAX_SIDE_PX):
        raise UserError(f"{path}: data window {w} x {h} pixels; a labelled image has 1 to {MAX_SIDE_PX} pixels "
                        "a side (the largest scene resolution)")
    chans = header.get("channels", [])
    if len(chans) > MAX_CHANNELS:
        raise UserError(f"{path}: {len(chans)} channels, more than {MAX_CHANNELS} (5 per layer and a few "
                        "more); write fewer layers")
    sub = sorted(c.name for c in chans if (c.xSampling, c.ySampling) != (1, 1))
    if sub:
        raise UserError(f"{path}: channel(s) {sub} are sub-sampled (x/y sampling "
                        f"{sorted({(c.xSampling, c.ySampling) for c in chans if c.name in sub})}); write every "
                        "channel at full resolution (x/y sampling 1)")


def _open(path) -> tuple[dict, dict]:
    printed: list = []
    with open_input(path, "EXR", "pass an OpenEXR file (.exr)") as fh:
        if fh.read(4) != EXR_MAGIC:
            raise UserError(f"{path}: not a readable OpenEXR file (it does not start with the EXR magic number); pass "
                            "a labelled-pixel .exr (from `splatlab reference SCENE` or a renderer's EXR output)")
        fh.seek(0)
        try:
            with _c_output(printed), OpenEXR.File(fh, header_only=True) as exr:
                header = dict(exr.header())
            _layout(path, header)
            fh.seek(0)
            with _c_output(printed), OpenEXR.File(fh, separate_channels=True) as exr:
                channels = {name: ch.pixels for name, ch in exr.channels().items()}
        except UserError:
            raise
        except Exception as exc:  # noqa: BLE001 - OpenEXR raises RuntimeError, ValueError, KeyError ... for a bad file
            raise UserError(f"{path}: not a readable OpenEXR file ({_reason(exc, printed)}); "
                            "re-export it as a scanline or tiled float EXR") from None
    for name, pixels in channels.items():
        if not isinstance(pixels, np.ndarray) or pixels.dtype not in (np.float16, np.float32):
            raise UserError(f"{path}: channel {name} is {getattr(pixels, 'dtype', type(pixels).__name__)}; "
                            "use half or float channels")
    return header, {name: np.asarray(p, dtype=np.float32) for name, p in channels.items()}


def _require(path, channels: dict, names, hint: str):
    missing = [n for n in names if n not in channels]
    if missing:
        raise UserError(f"{path}: missing channel(s) {missing} (has {sorted(channels)}); {hint}")


def read_rgb(path) -> np.ndarray:
    """Read the R, G, B channels of an EXR (a reference image).

    Returns
    -------
    (H, W, 3) float32

    Raises
    ------
    UserError
        Missing or unreadable file, missing R/G/B, integer channels.
    """
    _, channels = _open(path)
    _require(path, channels, "RGB", "write the image with R, G and B channels")
    return np.stack([channels[c] for c in "RGB"], axis=-1)


def _check_depth(path, z: np.ndarray):
    bad = ~(z > 0)  # NaN compares false, so it counts as bad
    if np.any(bad):
        y, x = np.argwhere(bad)[0]
        raise UserError(f"{path}: {int(bad.sum())} pixel(s) with NaN or non-positive depth Z, first at "
                        f"(x={x}, y={y}) Z={z[y, x]}; Z must be planar camera depth in metres > 0 "
                        "(inf for background at infinity): fix the renderer's depth output")


def _check_motion(path, channels: dict):
    """motion.X and motion.Y come together and are finite (pixels over the shutter)."""
    found = [c for c in ("motion.X", "motion.Y") if c in channels]
    if len(found) == 1:
        raise UserError(f"{path}: channel {found[0]} without its partner; motion vectors need both motion.X "
                        "and motion.Y (pixels over the shutter, Y up)")
    for c in found:
        bad = ~np.isfinite(channels[c])
        if np.any(bad):
            y, x = np.argwhere(bad)[0]
            raise UserError(f"{path}: {int(bad.sum())} pixel(s) of {c} are NaN or infinite, first at (x={x}, "
                            f"y={y}); give every pixel a finite motion in pixels (0 for a still one)")


def _header_camera(path, header: dict) -> dict:
    raw = header.get(CAMERA_ATTR)
    if raw is None:
        raise UserError(f"{path}: no '{CAMERA_ATTR}' header, so the lens is unknown; pass the camera "
                        "with --camera FILE.toml (a file with a [camera] table)")
    data = loads(raw, f"{path} header '{CAMERA_ATTR}'", "pass the camera with --camera FILE.toml",
                 infinite_keys=("surfaces",))   # a thick lens's flat faces
    return validate_camera(data, f"{path} header '{CAMERA_ATTR}'")


def read_labelled(path, camera: dict | None = None) -> LabelledImage:
    """Read and validate a labelled-pixel EXR.

    Parameters
    ----------
    path : str or Path
        The EXR file.
    camera : dict, optional
        Camera JSON that overrides the ``splatlab.camera`` header (``--camera FILE.toml``; build it
        with ``lab.scene.load_camera(FILE).camera_json()``). Needed when the header is missing.

    Returns
    -------
    LabelledImage
        ``A`` defaults to 1 (full coverage) when the file has no A channel.
    """
    header, channels = _open(path)
    fmt = header.get(FORMAT_ATTR, FORMAT)
    if fmt != FORMAT:   # not repr() of a non-string: OpenEXR's opaque attributes may not print
        shown = repr(fmt) if isinstance(fmt, str) else f"an attribute of type {type(fmt).__name__}"
        raise UserError(f"{path}: {FORMAT_ATTR} = {shown}, this version reads {FORMAT!r}; "
                        "re-render the input with this splatlab")
    _require(path, channels, "RGB", "a labelled-pixel EXR needs linear R, G, B radiance")
    if "Z" not in channels:
        raise UserError(f"{path}: an EXR without Z (has {sorted(channels)}); the splatting runtime "
                        "needs per-pixel depth: render the input with `splatlab reference SCENE` or add a Z "
                        "channel (planar camera depth in metres)")
    z = channels["Z"]
    wrong = {name: ch.shape for name, ch in channels.items() if ch.shape != z.shape}
    if wrong:
        raise UserError(f"{path}: channel(s) {sorted(wrong)} are {sorted(set(wrong.values()))} pixels, Z is "
                        f"{z.shape}; write every channel at full resolution (x/y sampling 1)")
    _check_motion(path, channels)
    _check_depth(path, z)
    if camera is not None:
        camera = validate_camera(camera, f"{path}: --camera override")
    else:
        camera = _header_camera(path, header)
    rgb = np.stack([channels[c] for c in "RGB"], axis=-1)
    alpha = channels.get("A", np.ones_like(z))
    extra = {k: v for k, v in channels.items() if k not in CORE}
    image_layers(extra, str(path))
    return LabelledImage(rgb=rgb, alpha=alpha, depth=z, camera=camera, extra=extra,
                         guard_px=_guard(path, header, z.shape))


def _guard(path, header: dict, shape: tuple) -> int:
    """The ``splatlab.guard_px`` header: 0 when absent, else a margin narrower than half the image."""
    raw = header.get(GUARD_ATTR)
    if raw is None:
        return 0
    text = raw if isinstance(raw, str) else None
    if text is None or not text.isdigit() or not 2 * int(text) < min(shape):
        shown = repr(text) if text is not None else f"an attribute of type {type(raw).__name__}"
        raise UserError(f"{path}: header {GUARD_ATTR} = {shown}; the guard band is a whole number of pixels "
                        f"narrower than half the image ({shape[0]}x{shape[1]}): re-render the input or drop it")
    return int(text)

"""Scene files (TOML) -> validated, frozen dataclasses.

A scene file has the tables ``[scene]`` (name, resolution), ``[camera]``, ``[render]``,
``[materials.NAME]``, ``[[shapes]]``, ``[[emitters]]``, ``[medium]`` (:class:`lab.medium.Medium`),
``[psf.MODEL]`` and ``[precompute]``.
Every table goes through :func:`lab.config.from_table`, so unknown keys are errors that name the
file, the table and the known keys. Materials, shapes and emitters live in
:mod:`lab.scene_objects`; the ``[camera]`` table is read by its model's class in :mod:`lab.cameras`.

Units: positions in metres, focal length and sensor width in millimetres, angles in degrees.
"""
from __future__ import annotations

import re
import tomllib
from pathlib import Path
from dataclasses import dataclass, field

from runtime_cl.input_file import read_text

from .cameras import Camera, parse_camera
from .config import MAX_SIDE_PX, check_finite, from_table, to_table
from .errors import UserError
from .medium import Medium
from .scene_objects import Emitter, Material, Shape, parse_material, parse_shape, strip_none

SECTIONS = ("scene", "camera", "render", "materials", "shapes", "emitters", "medium", "psf", "precompute")
MAX_SCENE_CHARS = 1 << 20   # scenes are a few kB; a megabyte is not a scene file
RENDER_BOUNDS = {
    "reference_spp": (1 << 20, "a million samples per pixel is past any converged reference"),
    "input_spp": (1 << 16, "the labelled input needs only its edges anti-aliased"),
    "max_depth": (1024, "longer paths carry no energy a reference can show"),
}
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,63}")

MAX_DEPTH_LAYERS = 16   # [render] depth_layers, `report --layers`: LSR18 uses a handful


def check_name(name: str) -> str:
    """A scene name, which becomes a folder under reports/ and .cache/: a letter or digit, then
    letters, digits, ``.``, ``_`` or ``-`` (no slashes, no ``..``), at most 64 characters."""
    if not _NAME.fullmatch(name) or ".." in name:
        raise UserError(f"name = {name!r}: a scene name becomes a folder name under reports/ and .cache/; "
                        "use letters, digits, '.', '_' or '-' (starting with a letter or digit, at most 64, "
                        "no '..'), e.g. name = \"my_scene\"")
    return name


@dataclass(frozen=True)
class SceneInfo:
    """``[scene]``: a name for reports and the image size ``resolution = [width, height]`` (px)."""

    name: str
    resolution: tuple[int, int]

    def __post_init__(self):
        check_name(self.name)
        w, h = self.resolution
        if w <= 0 or h <= 0:
            raise UserError(f"resolution = {list(self.resolution)}: width and height must be > 0 "
                            "pixels, e.g. resolution = [1024, 1024]")
        if max(w, h) > MAX_SIDE_PX:
            raise UserError(f"resolution = {list(self.resolution)}: at most {MAX_SIDE_PX} pixels a side (an "
                            f"RGB float image of {MAX_SIDE_PX}^2 is 3.2 GB, and the references and the runtime "
                            "hold several); e.g. resolution = [1024, 1024]")


@dataclass(frozen=True)
class AdaptiveSettings:
    """``[render] reference_adaptive = { extra_spp = E, tiles = K }``: after the reference's own
    samples, ``E`` more samples per pixel of the frame, spent on at most ``K`` tiles of ``tile_px``
    where a pilot of ``pilot_spp`` (default reference_spp / 8, at least 8) finds the most noise
    (:mod:`lab.reference.adaptive`)."""

    extra_spp: int
    tiles: int = 16
    tile_px: int = 32
    pilot_spp: int | None = None

    def __post_init__(self):
        # every refined tile is its own Mitsuba launch and kernel build: thousands would cost more than they save
        for key, low, high in (("extra_spp", 1, RENDER_BOUNDS["reference_spp"][0]), ("tiles", 1, 4096),
                               ("tile_px", 8, 4096), ("pilot_spp", 8, RENDER_BOUNDS["reference_spp"][0])):
            value = getattr(self, key)
            if value is not None and not low <= value <= high:
                raise UserError(f"reference_adaptive.{key} = {value} must be between {low} and {high}, e.g. "
                                "reference_adaptive = { extra_spp = 512, tiles = 16 }")


@dataclass(frozen=True)
class RenderSettings:
    """``[render]``: samples per pixel of the reference and of the input, seed, path length.

    ``peel_layers`` (optional): peel up to this many layers from the lens centre with LES10's
    umbra offset into the input (:mod:`lab.reference.peel`) and trace lens rays through them
    (the ``layered`` pass, ``lens_rays`` per pixel, default 100). ``peel_spp`` (optional, default
    ``input_spp``): samples per pixel of the peeled layers behind the first; the first layer is the
    pinhole input itself (``input_spp``), where in-focus grain shows, while what lies behind it is
    mostly seen through blur, which averages its grain away.

    ``guard_band`` (default false): render the labelled input with a margin of the largest CoC
    plus half the largest motion around the frame (LSR18 "Boundary"; :mod:`lab.reference.guard_band`).
    ``depth_layers`` (optional): a thin lens's plan (round, moving or stylized) adds its spreadlet
    passes with this many global depth layers (labels ``spreadlets_layers``, ...; the passes'
    option ``layers``); other plans say in their skipped steps why they cannot.
    ``reference_adaptive`` (optional): spend extra reference samples where its noise is
    (:class:`AdaptiveSettings`).
    """

    reference_spp: int = 256
    input_spp: int = 64
    seed: int = 0
    max_depth: int = 8
    peel_layers: int | None = None
    lens_rays: int | None = None
    peel_spp: int | None = None
    guard_band: bool = False
    depth_layers: int | None = None
    reference_adaptive: AdaptiveSettings | None = None

    def __post_init__(self):
        if isinstance(self.reference_adaptive, dict):
            object.__setattr__(self, "reference_adaptive",
                               from_table(AdaptiveSettings, self.reference_adaptive, "reference_adaptive"))
        elif not isinstance(self.reference_adaptive, (AdaptiveSettings, type(None))):
            raise UserError(f"reference_adaptive = {self.reference_adaptive!r} must be a table, e.g. "
                            "reference_adaptive = { extra_spp = 512, tiles = 16 }")
        for key in ("reference_spp", "input_spp", "max_depth"):
            if getattr(self, key) < 1:
                raise UserError(f"{key} = {getattr(self, key)} must be >= 1")
        if not isinstance(self.guard_band, bool):
            raise UserError(f"guard_band = {self.guard_band!r} must be true or false")
        # LES10 needed <= 10 layers; LSR18 uses a handful of depth layers
        for key, bound in (("peel_layers", 64), ("lens_rays", 4096), ("depth_layers", MAX_DEPTH_LAYERS),
                           ("peel_spp", RENDER_BOUNDS["input_spp"][0])):
            if getattr(self, key) is not None and not 1 <= getattr(self, key) <= bound:
                raise UserError(f"{key} = {getattr(self, key)} must be between 1 and {bound} (or remove it)")
        if self.lens_rays is not None and self.peel_layers is None:
            raise UserError(f"lens_rays = {self.lens_rays}: lens rays trace peeled layers; add peel_layers "
                            "(e.g. 8) or remove lens_rays")
        if self.peel_spp is not None and self.peel_layers is None:
            raise UserError(f"peel_spp = {self.peel_spp}: the samples of peeled layers; add peel_layers (e.g. 8) "
                            "or remove peel_spp")
        for key, (bound, why) in RENDER_BOUNDS.items():
            if getattr(self, key) > bound:
                raise UserError(f"{key} = {getattr(self, key)}: at most {bound} ({why})")
        if not 0 <= self.seed < 2**31:
            raise UserError(f"seed = {self.seed} must be in [0, 2^31)")


@dataclass(frozen=True)
class Scene:
    """A validated scene file; ``source`` is the file it came from (messages only, not compared)."""

    source: str = field(compare=False)
    info: SceneInfo
    camera: Camera
    render: RenderSettings
    materials: dict[str, Material]
    shapes: tuple[Shape, ...]
    emitters: tuple[Emitter, ...]
    psf: dict[str, dict]
    precompute: dict
    medium: Medium | None = None

    @property
    def name(self) -> str:
        return self.info.name

    @property
    def width(self) -> int:
        return self.info.resolution[0]

    @property
    def height(self) -> int:
        return self.info.resolution[1]

    def input_layers(self) -> list[list[int]]:
        """Shape indices per layer of the layered labelled input, nearest first; empty when no
        shape has a ``layer`` key. The last layer holds the shapes without one (and the sky)."""
        tagged = sorted({s.layer for s in self.shapes if s.layer is not None})
        if not tagged:
            return []
        return [[i for i, s in enumerate(self.shapes) if s.layer == k] for k in tagged] + \
            [[i for i, s in enumerate(self.shapes) if s.layer is None]]

    def to_dict(self) -> dict:
        """Canonical, JSON-serialisable contents (no file name; ``None`` dropped) for hashing.

        ``parse_scene(scene.to_dict(), ...)`` gives back an equal scene.
        """
        return strip_none({
            "scene": to_table(self.info), "camera": to_table(self.camera),
            "render": to_table(self.render),
            "materials": {k: to_table(m) for k, m in sorted(self.materials.items())},
            "shapes": [to_table(s) for s in self.shapes],
            "emitters": [to_table(e) for e in self.emitters],
            "psf": {k: dict(v) for k, v in sorted(self.psf.items())}, "precompute": dict(self.precompute),
            "medium": None if self.medium is None else to_table(self.medium),
        })


def _table(data: dict, key: str, source: str, kind=dict, default=None):
    value = data.get(key, default)
    if not isinstance(value, kind):
        shape = f"[{key}]" if kind is dict else f"[[{key}]]"
        raise UserError(f"{source}: {key} must be written as {shape} table(s), got {value!r}")
    return value


def parse_scene(data: dict, source: str = "<scene>") -> Scene:
    """Validate a scene given as a dict (parsed TOML, or :meth:`Scene.to_dict`).

    Parameters
    ----------
    data : dict
        Tables as in a scene file.
    source : str
        Names the scene in error messages (the file path for :func:`load_scene`).

    Raises
    ------
    UserError
        Unknown tables or keys, wrong types, bad values, undefined material names.
    """
    check_finite(data, source)
    unknown = sorted(set(data) - set(SECTIONS))
    if unknown:
        raise UserError(f"{source}: unknown table(s) {unknown}; known tables are {list(SECTIONS)}")
    for key in ("scene", "camera"):
        if key not in data:
            raise UserError(f"{source}: missing the [{key}] table")
    info = from_table(SceneInfo, _table(data, "scene", source), f"{source} [scene]")
    camera = parse_camera(_table(data, "camera", source), f"{source} [camera]")
    render = from_table(RenderSettings, _table(data, "render", source, default={}), f"{source} [render]")
    materials = {name: parse_material(table, f"{source} [materials.{name}]")
                 for name, table in _table(data, "materials", source, default={}).items()}
    shapes = tuple(parse_shape(t, f"{source} [[shapes]] #{i + 1}", materials)
                   for i, t in enumerate(_table(data, "shapes", source, list, [])))
    emitters = tuple(from_table(Emitter, t, f"{source} [[emitters]] #{i + 1}")
                     for i, t in enumerate(_table(data, "emitters", source, list, [])))
    psf = _table(data, "psf", source, default={})
    for model, table in psf.items():
        if not isinstance(table, dict):
            raise UserError(f"{source}: psf.{model} must be a [psf.{model}] table, got {table!r}")
    if not shapes and not emitters:
        raise UserError(f"{source}: the scene is empty; add [[shapes]] or [[emitters]]")
    layers = sorted({s.layer for s in shapes if s.layer is not None})
    if layers and render.peel_layers is not None:
        raise UserError(f"{source}: [[shapes]] layer keys and [render] peel_layers both make the input's "
                        "layerN.* layers; keep one")
    if layers != list(range(len(layers))):
        raise UserError(f"{source}: [[shapes]] use layer = {layers}; number the input layers 0, 1, ... "
                        "from the nearest without gaps (untagged shapes form the last layer)")
    medium = None
    if "medium" in data:
        medium = from_table(Medium, _table(data, "medium", source), f"{source} [medium]")
    return Scene(source=source, info=info, camera=camera, render=render, materials=materials,
                 shapes=shapes, emitters=emitters, psf={k: dict(v) for k, v in psf.items()},
                 precompute=dict(_table(data, "precompute", source, default={})), medium=medium)


def _read_toml(path, what: str = "scene file", fix: str = "check the path (scenes live in scenes/)") -> dict:
    text = read_text(path, what, fix)
    if len(text) > MAX_SCENE_CHARS:
        raise UserError(f"{path}: {len(text)} characters, more than a scene file may hold ({MAX_SCENE_CHARS}: "
                        "scenes are a few kB); check that this is the scene file")
    try:
        return tomllib.loads(text)
    except (tomllib.TOMLDecodeError, RecursionError, ValueError) as exc:
        raise UserError(f"{path}: not valid TOML ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__}); "
                        "fix the syntax there") from None


def load_scene(path) -> Scene:
    """Read and validate a scene file.

    Parameters
    ----------
    path : str or Path
        A TOML scene file, e.g. ``scenes/demo.toml``.

    Returns
    -------
    Scene

    Raises
    ------
    UserError
        Missing file, bad TOML, or any validation error; the message names the file, the table
        and the key.
    """
    return parse_scene(_extended(_read_toml(path), Path(path)), str(path))


MAX_EXTENDS = 4   # scene files a chain of ``extends`` may go through (a cycle is refused)


def _extended(data: dict, path: Path, depth: int = 0) -> dict:
    """``data`` on top of the scene it names in ``[scene] extends`` (a file in the same folder),
    recursively: tables merge key by key, every other value (arrays of tables such as
    ``[[shapes]]`` included) replaces the base's. A variant of a scene (more samples, another
    name) is then a few lines, not a copy."""
    scene = data.get("scene")
    base = scene.get("extends") if isinstance(scene, dict) else None
    if base is None:
        return data
    if not (isinstance(base, str) and base.endswith(".toml") and Path(base).name == base):
        raise UserError(f"{path} [scene] extends = {base!r}: give the file name of a scene in the same "
                        'folder, e.g. extends = "demo.toml"')
    if depth >= MAX_EXTENDS:
        raise UserError(f"{path} [scene] extends = {base!r}: the chain of extended scenes is more than "
                        f"{MAX_EXTENDS} files long (a cycle?); extend a scene that extends nothing")
    base_path = path.parent / base
    parent = _extended(_read_toml(base_path, "scene file (extended)", f"fix [scene] extends in {path}"),
                       base_path, depth + 1)
    child = dict(data, scene={k: v for k, v in scene.items() if k != "extends"})
    return _merged(parent, child)


def _merged(base: dict, over: dict) -> dict:
    out = dict(base)
    for key, value in over.items():
        both = isinstance(value, dict) and isinstance(base.get(key), dict)
        out[key] = _merged(base[key], value) if both else value
    return out


def load_camera(path) -> Camera:
    """The ``[camera]`` table of a TOML file, for ``--camera FILE.toml``.

    Parameters
    ----------
    path : str or Path
        A scene file or a file holding only a ``[camera]`` table (other tables are ignored).

    Returns
    -------
    lab.cameras.Camera
        Use ``load_camera(path).camera_json()`` as the EXR camera override.
    """
    data = _read_toml(path, "--camera file", "pass a TOML file with a [camera] table (e.g. scenes/demo.toml)")
    if "camera" not in data:
        raise UserError(f"{path}: no [camera] table; a --camera file needs one (see scenes/demo.toml)")
    return parse_camera(_table(data, "camera", str(path)), f"{path} [camera]")

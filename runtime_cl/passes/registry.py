"""The runtime pass registry: every way the runtime renders labelled pixels, by name.

A pass is one module that registers a :class:`RuntimePass` subclass (``@register_pass``); import
the registry's functions from :mod:`runtime_cl.passes`, whose import registers every pass. The
class declares what it needs: a database (of which models) or none, the input channels, and
whether it renders depth layers. The pipeline, ``splatlab render --method``, the benchmarks and
the reports iterate this registry; none of them switches on a method name.

Life of a pass: construct it once per camera and database (kernel builds, uploads), call
:meth:`RuntimePass.prepare` once per input (per-pixel PSF parameters from the camera and
depth), then call the pass on the prepared input as often as needed; :func:`run_pass` does all
three and times the calls with :func:`runtime_cl.timing.measure`.
"""
from __future__ import annotations

import abc
import inspect
import time
from typing import ClassVar

from runtime_cl.errors import InputError
from runtime_cl.registry import Registry
from runtime_cl.timing import measure

__all__ = ["RuntimePass", "register_pass", "get_pass", "integrating_passes", "pass_names", "pass_options",
           "run_pass"]

_PASSES = Registry("runtime pass", sort=False)   # registration order is report order


class RuntimePass(abc.ABC):
    """One way of rendering a :class:`~runtime_cl.frame.Frame`.

    Class attributes
    ----------------
    name : str
        Registry name (``--method NAME``), set by :func:`register_pass`.
    summary : str
        One line for ``--help`` and reports.
    database_models : tuple of str or None
        Database models the pass renders with: ``None`` any model the runtime has a coordinate
        map for (:mod:`runtime_cl.coords.maps`), ``()`` none (no database).
    channels : tuple of str
        Input channels it reads (EXR names); ``motion.X, motion.Y`` only for motion databases.
    layered : bool
        Whether it renders global depth layers (``layers > 1``) and layered input.
    draws_aperture : bool
        Whether it draws the camera's aperture shape itself (option ``aperture``: the lab hands
        it the camera's rectified iris), rather than the PSFs of a database.
    timing_reference : bool
        Whether reports compare the other passes' times against it, measured in the same run
        (LSR18's dense Splat: the machine's load cancels in the ratio).
    integrates : bool
        Whether it integrates a Laplacian canvas, so takes the option ``integrator`` (a name
        from :func:`runtime_cl.integrate.integrator_names`).
    far_field : bool
        Whether it takes the option ``far_field`` (a ``volume_far`` database whose halos it adds
        to a ``volume`` database's render: :mod:`runtime_cl.psf.far_field`).

    Parameters
    ----------
    camera : runtime camera
        E.g. :class:`runtime_cl.camera.thin_lens.ThinLens`.
    db : SpreadletDatabase, optional
        Required if and only if ``database_models != ()``.
    layers : int, default 1
        Global depth layers; more than 1 only for a ``layered`` pass.
    device : Device, optional
    **options
        Pass-specific settings (see each pass).
    """

    name: ClassVar[str]
    summary: ClassVar[str]
    database_models: ClassVar[tuple | None]
    channels: ClassVar[tuple]
    layered: ClassVar[bool]
    draws_aperture: ClassVar[bool] = False
    timing_reference: ClassVar[bool] = False
    integrates: ClassVar[bool] = False
    far_field: ClassVar[bool] = False

    def __init__(self, camera, db=None, *, layers: int = 1, device=None, **options):
        if isinstance(layers, bool) or not isinstance(layers, int) or layers < 1:
            raise InputError(f"layers = {layers!r}: the number of depth layers must be an integer >= 1 "
                             "(1 splats everything into one layer, without occlusion)")
        if layers > 1 and not self.layered:
            layered = [n for n in pass_names() if get_pass(n).layered]
            raise InputError(f"layers = {layers}: the {self.name!r} pass renders one layer; depth "
                             f"layers are rendered by {layered}")
        if self.database_models == () and db is not None:
            raise InputError(f"db: the {self.name!r} pass uses no PSF database; drop it")
        if self.database_models != () and db is None:
            raise InputError(f"db: the {self.name!r} pass needs a spreadlet database "
                             "(runtime_cl.load_database(path), made by `splatlab precompute`)")
        if db is not None and self.database_models is not None and db.model not in self.database_models:
            raise InputError(f"db: a {db.model!r} database; the {self.name!r} pass renders with "
                             f"{list(self.database_models)}")
        self.camera, self.db, self.layers, self.device = camera, db, layers, device
        self.configure(**options)

    def configure(self, **options) -> None:
        """Take the pass-specific ``options``; by default there are none."""
        if options:
            raise InputError(f"{sorted(options)}: unknown option(s) of the {self.name!r} pass")

    @abc.abstractmethod
    def prepare(self, frame):
        """Per-pixel PSF parameters of ``frame`` (computed once, not timed); an opaque object."""

    @abc.abstractmethod
    def __call__(self, prepared) -> tuple:
        """Render the prepared frame once: ``(image (H, W, C) float32, CallTimes)``."""


def register_pass(name: str):
    """Class decorator: register a :class:`RuntimePass` under ``name``."""
    return _PASSES.register(name)


def pass_names() -> list[str]:
    """Registered pass names, in registration order (the order reports list them)."""
    return _PASSES.names()


def integrating_passes() -> list[str]:
    """The passes that take the option ``integrator``."""
    return [n for n in pass_names() if _PASSES.get(n).integrates]


def pass_options(cls) -> dict:
    """The keyword options of the pass class ``cls`` and their defaults: its ``configure``'s, and
    those of the base classes' ``configure`` its ``**options`` hands on to."""
    out: dict = {}
    for klass in cls.__mro__:
        if "configure" not in vars(klass):
            continue
        params = inspect.signature(vars(klass)["configure"]).parameters
        out.update({k: p.default for k, p in params.items() if p.kind is p.KEYWORD_ONLY and k not in out})
        if not any(p.kind is p.VAR_KEYWORD for p in params.values()) or klass is RuntimePass:
            break
    return out


def get_pass(name: str) -> type:
    """The :class:`RuntimePass` class registered as ``name``."""
    if name not in _PASSES:
        raise InputError(f"method = {name!r}: unknown runtime pass; choose one of {pass_names()}")
    return _PASSES.get(name)


def run_pass(name: str, frame, camera, db=None, *, runs: int = 0, min_ms: float = 0.0, layers: int = 1,
             device=None, **options):
    """Render ``frame`` with the pass ``name`` and time it (:func:`runtime_cl.timing.measure`).

    Returns ``(image, Timing)``; ``runs`` timed calls (more until they add up to ``min_ms``) follow
    one warm-up call (0: one call). The
    image is the frame: a guard band (``frame.guard_px``) is rendered, timed and cropped off.
    """
    start = time.perf_counter()
    p = get_pass(name)(camera, db, layers=layers, device=device, **options)
    build_ms = (time.perf_counter() - start) * 1e3
    start = time.perf_counter()
    prepared = p.prepare(frame)
    prepare_ms = (time.perf_counter() - start) * 1e3
    image, timing = measure(lambda: p(prepared), runs, prepare_ms, build_ms, min_ms)
    return frame.crop(image), timing

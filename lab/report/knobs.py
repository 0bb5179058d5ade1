"""The knobs a sweep turns (``splatlab report --sweep``): one registry entry each.

A knob is keyed by what it sets: a PSF-model setting (``psf``: the scene's ``[psf.<model>]``
value, so its databases come from :mod:`lab.precompute`'s content-hashed cache), a runtime-pass
option (``pass``: an option the pass's ``configure`` or constructor accepts), or a render setting
of the reference (``reference``). Its values are derived from the setting's value in the run the
report scores (the 1x point), so a sweep always passes through the report's own figures.

A knob applies to a method when the method's pass takes the option (or renders a database whose
model has the setting); otherwise :meth:`Knob.skip_reason` says why, and the report lists it. A new
knob (e.g. spreadlet depth layers once the pass accepts ``layers``) is one :func:`register_knob`
call; nothing else changes.
"""
from __future__ import annotations

import dataclasses
import inspect
from dataclasses import dataclass
from typing import Callable

from runtime_cl.errors import InputError

__all__ = ["Knob", "KNOBS", "register_knob", "select_knobs", "pass_accepts", "REFERENCE"]

REFERENCE = "path tracer"   # the method name of the reference-spp points (Mitsuba against the reference)


@dataclass(frozen=True)
class Knob:
    """One thing a sweep varies.

    Attributes
    ----------
    name : str
        Registry key and the name reports use (``--knobs NAME,...``).
    kind : str
        ``"psf"`` (a PSF-model setting), ``"pass"`` (a runtime-pass option) or ``"reference"``
        (a render setting of the scene's reference).
    key : str
        The setting or option name.
    label : str
        What a reader calls it.
    values : callable
        ``values(base) -> list``: the swept values from the run's own value ``base`` (include it).
    applies : callable, optional
        ``applies(pass_class) -> bool``: for ``pass`` knobs instead of :func:`pass_accepts`; for
        ``psf`` knobs on top of the model having the setting (a setting only some passes use).
    scale_with : tuple of str
        ``psf`` knobs: further settings scaled by the same factor (value / base) when present.
    why_not : str
        The reason a pass that ``applies`` refuses is skipped (``{pass}``, ``{key}`` filled in).
    refuses : callable, optional
        ``refuses(table) -> str | None``: why the knob does not apply to a database of the scene's
        settings for the model (its ``[psf.<model>]`` table over the model's defaults), if so.
    """

    name: str
    kind: str
    key: str
    label: str
    values: Callable
    applies: Callable | None = None
    scale_with: tuple = ()
    why_not: str = "the {pass!r} pass takes no option {key!r}"
    refuses: Callable | None = None

    def skip_reason(self, pass_cls, model_config=None) -> str | None:
        """Why this knob does not apply to a method of pass ``pass_cls`` rendering a database of
        configuration class ``model_config`` (None: no database); None when it applies."""
        if self.kind == "reference":
            return "a setting of the reference, swept once per scene"
        if self.kind == "psf":
            if model_config is None:
                return f"the {pass_cls.name!r} pass uses no PSF database"
            if self.key not in {f.name for f in dataclasses.fields(model_config)}:
                return f"its PSF model ({model_config.__name__}) has no setting {self.key!r}"
            return None if self.applies is None or self.applies(pass_cls) else \
                self.why_not.format(**{"pass": pass_cls.name, "key": self.key})
        accepts = self.applies or (lambda cls: pass_accepts(cls, self.key))
        return None if accepts(pass_cls) else self.why_not.format(**{"pass": pass_cls.name, "key": self.key})


def pass_accepts(cls, option: str) -> bool:
    """Whether the runtime pass class ``cls`` takes the option ``option``: a keyword of its
    ``configure``, or ``layers`` (the constructor's) for a pass that renders depth layers."""
    if option == "layers":
        return bool(cls.layered)
    return option in inspect.signature(cls.configure).parameters


def pass_default(cls, option: str):
    """The default of a pass option (the value the pass uses when the plan gives none)."""
    if option == "layers":
        return 1
    if option == "integrator":   # None: the database's own (fft32 for a Laplacian, none for rows)
        from runtime_cl.integrate import DEFAULT_INTEGRATOR

        return DEFAULT_INTEGRATOR
    p = inspect.signature(cls.configure).parameters.get(option)
    return None if p is None or p.default is inspect.Parameter.empty else p.default


def _scaled(factors, integer: bool, least: float = 1):
    """values(base): ``base * f`` for each factor, integers rounded (at least ``least``), unique."""
    def values(base):
        out = []
        for f in factors:
            v = base * f
            v = max(int(least), int(round(v))) if integer else float(v)
            if v not in out:
                out.append(v)
        return out
    return values


def _integrators(base):
    from runtime_cl.integrate import integrator_names

    return integrator_names()


KNOBS: dict[str, Knob] = {}


def register_knob(knob: Knob) -> Knob:
    """Add ``knob`` to :data:`KNOBS` (registration order is report order)."""
    if knob.kind not in ("psf", "pass", "reference"):
        raise ValueError(f"knob {knob.name!r}: kind {knob.kind!r} is not psf, pass or reference")
    KNOBS[knob.name] = knob
    return knob


# LSR18's operating point: the sparsifier's spreadlet density (lab.sparsify.spreadlets.MASS / density).
# Only a pass that draws the spreadlets (and integrates them) sees it; Splat and Filter draw the dense PSFs.
register_knob(Knob("operating_point", "psf", "density", "spreadlet density (operating point)",
                   _scaled((0.5, 1.0, 2.0), integer=False), applies=lambda cls: bool(getattr(cls, "integrates", False)),
                   why_not="the {pass!r} pass draws the dense PSFs, not spreadlets: their {key!r} is not used"))
register_knob(Knob("psf_samples", "psf", "samples", "PSF samples", _scaled((0.5, 1.0, 2.0), integer=True)))
# A PSF's rays are max(rays_per_psf, rays_per_pixel * disc area): both scale, so every cell's count does.
register_knob(Knob("rays_per_psf", "psf", "rays_per_psf", "rays per PSF", _scaled((0.25, 1.0, 4.0), integer=True),
                   scale_with=("rays_per_pixel",)))
# The polygon pass's global depth layers (and any pass that renders layers, e.g. spreadlets once they do);
# a pass that traces its input's own layers takes their count as max_layers (the next knob), not this.
register_knob(Knob("layers", "pass", "layers", "depth layers", lambda base: sorted({1, 2, 4, 8, int(base)}),
                   applies=lambda cls: pass_accepts(cls, "layers") and not pass_accepts(cls, "max_layers"),
                   why_not="the {pass!r} pass renders no depth layers of its own (option {key!r})"))
# LES10: how many of the input's peeled layers the lens rays traverse (None, the default: all of them).
register_knob(Knob("traced_layers", "pass", "max_layers", "input layers traced",
                   lambda base: [1, 2, 4, 8] if base is None else sorted({1, 2, max(1, int(base) // 2), int(base)})))
register_knob(Knob("lens_rays", "pass", "rays", "lens rays per pixel",
                   lambda base: sorted({max(1, int(base) // 8), max(1, int(base) // 2), int(base), 2 * int(base)})))
register_knob(Knob("integrator", "pass", "integrator", "Poisson integrator", _integrators,
                   applies=lambda cls: bool(getattr(cls, "integrates", False)),
                   refuses=lambda table: "its database stores row differences (basis 'rows'), summed along rows "
                   "as they are merged: no Poisson solve" if table.get("basis") == "rows" else None))
# What a spreadlet is (lab/sparsify/rows.py): LSR18's Laplacian or row differences, same PSFs
# (combined: both, "dual").
register_knob(Knob("basis", "psf", "basis", "spreadlet basis",
                   lambda base: ["laplacian", "dual" if base == "dual" else "rows"],
                   applies=lambda cls: bool(getattr(cls, "integrates", False)),
                   why_not="the {pass!r} pass draws the dense PSFs, not spreadlets: their {key!r} is not used"))
# The path tracer itself as a method: fewer samples, an independent seed, scored against the reference.
register_knob(Knob("reference_spp", "reference", "reference_spp", "reference samples per pixel",
                   lambda base: [v for v in (base // 8, base // 4, base // 2, base) if v >= 1]))


def select_knobs(names=None) -> list[Knob]:
    """The knobs named (``--knobs a,b``; None: all), in registry order; an unknown name is an
    :class:`~runtime_cl.errors.InputError` listing the known ones."""
    if names is None:
        return list(KNOBS.values())
    names = [n.strip() for n in names if n.strip()]
    unknown = [n for n in names if n not in KNOBS]
    if unknown or not names:
        raise InputError(f"--knobs {','.join(names)!s}: unknown knob(s) {unknown}; choose from "
                         f"{','.join(KNOBS)} (comma-separated), or drop --knobs for all of them")
    return [k for k in KNOBS.values() if k.name in names]


"""Load Mitsuba 3 in the ``llvm_ad_rgb`` variant, once, with a clear error when LLVM is unusable.

Only ``lab.reference`` imports Mitsuba/Dr.Jit, and only through :func:`mitsuba` (scenes through
:func:`load_scene_dict`), so the rest of
the lab (scene files, plans, EXR I/O) imports without them.
"""
from __future__ import annotations

from ..errors import UserError
from ..llvm_check import problem

VARIANT = "llvm_ad_rgb"


def mitsuba():
    """Return the ``mitsuba`` module with the ``llvm_ad_rgb`` variant set.

    Raises
    ------
    UserError
        When Dr.Jit finds no libLLVM >= 16 (it would abort later), with the install command.
    """
    msg = problem()
    if msg:
        raise UserError(msg)
    import mitsuba as mi

    if mi.variant() != VARIANT:
        mi.set_variant(VARIANT)
    return mi


def load_scene_dict(data: dict):
    """``mi.load_dict(data)`` without Mitsuba's scene optimisation: since 3.7 it merges the meshes
    that share a BSDF, in an order that changes from load to load, so the emitter list (and with it
    which light a random number picks) did too, and a scene with many emitting boxes (rain)
    rendered different noise on every run from the same seeds. Unmerged, a shape is also still the
    one its ``shape_N`` id names (motion transforms, per-shape hits)."""
    return mitsuba().load_dict(data, optimize=False)

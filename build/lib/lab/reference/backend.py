"""Load Mitsuba 3 in the ``llvm_ad_rgb`` variant, once, with a clear error when LLVM is unusable.

Only ``lab.reference`` imports Mitsuba/Dr.Jit, and only through :func:`mitsuba`, so the rest of
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

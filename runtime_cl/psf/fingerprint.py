"""Does a database match the input? Its fingerprint against the ``splatlab.camera`` header.

A database records what its PSFs were traced for, in the header's own terms (``params
["fingerprint"]``: header key -> value, e.g. ``{"aperture": None}`` for a round aperture,
``{"surfaces": [[inf, 15.0, "air", 11.5], ...], "focal_length_mm": 49.7, ...}`` for a traced
thick lens). A render whose header says otherwise would draw the wrong bokeh without a word;
:func:`check_header` refuses it. Numbers match within 1 %, lists (a lens's surfaces) entry by
entry; anything else exactly.
A database without a fingerprint (written before it existed) is not checked.
"""
from __future__ import annotations

import math

from runtime_cl.errors import InputError

__all__ = ["check_header"]

REL = 0.01


def _same(traced, given) -> bool:
    if isinstance(traced, bool) or isinstance(given, bool):
        return traced is given
    if isinstance(traced, (int, float)) and isinstance(given, (int, float)):
        return math.isclose(traced, given, rel_tol=REL, abs_tol=1e-9)
    if isinstance(traced, dict) and isinstance(given, dict):
        return traced.keys() == given.keys() and all(_same(traced[k], given[k]) for k in traced)
    if isinstance(traced, (list, tuple)) and isinstance(given, (list, tuple)):
        return len(traced) == len(given) and all(_same(a, b) for a, b in zip(traced, given))
    return traced == given


def check_header(db, header: dict, source: str = "input camera header") -> None:
    """InputError unless every fingerprint entry of ``db`` agrees with ``header``.

    Parameters
    ----------
    db : SpreadletDatabase
    header : dict
        The input's ``splatlab.camera`` JSON (a missing key reads as None: e.g. no ``aperture``
        is the round one).
    source : str
        Where the header came from, for the message.
    """
    for key, traced in (db.params.get("fingerprint") or {}).items():
        given = header.get(key)
        if not _same(traced, given):
            raise InputError(f"{source}: {key} = {given!r}, but the {db.model!r} database was traced for "
                             f"{key} = {traced!r}; render with a database traced for this camera "
                             "(`splatlab precompute SCENE`) or give the input the camera it was traced for")

"""JSON from a user's file, parsed with limits, and the type checks its values get.

Headers (the EXR's ``splatlab.camera``, a database's header, a baseline report) come from files
anyone can edit, so :func:`loads` bounds what Python's ``json`` would otherwise accept: the size,
the nesting depth (deep nesting recurses in the decoder), the digits of an integer (a 400-digit
integer overflows every float conversion later) and the non-JSON constants ``NaN`` and
``Infinity`` (``Infinity`` only where a caller names the key that may hold it: a flat lens
surface's radius, under ``surfaces``). :func:`is_number` is the one test for a number: ``true`` is not 1.
"""
from __future__ import annotations

import json
import math

from runtime_cl.errors import InputError

__all__ = ["MAX_BYTES", "MAX_DEPTH", "MAX_INT_DIGITS", "is_number", "loads"]

MAX_BYTES = 1 << 20      # the largest header written is a few kB (a thick lens: ~2 kB)
MAX_DEPTH = 16           # headers nest 3 deep (a lens's surface rows); 16 leaves room to grow
MAX_INT_DIGITS = 19      # int64: counts and sizes; a float beyond is written with an exponent


def is_number(value, finite: bool = True) -> bool:
    """True for an int or float that is not a bool (and finite, unless ``finite=False``)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    return not finite or isinstance(value, int) or math.isfinite(value)


def _depth(text: str) -> int:
    """Deepest nesting of ``[`` / ``{`` outside strings (no recursion, whatever the input)."""
    depth = deepest = 0
    in_string = escaped = False
    for ch in text:
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
        elif ch == '"':
            in_string = True
        elif ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "]}":
            depth -= 1
    return deepest


def _int(text: str) -> int:
    if len(text.lstrip("-")) > MAX_INT_DIGITS:
        raise ValueError(f"an integer of {len(text.lstrip('-'))} digits (at most {MAX_INT_DIGITS})")
    return int(text)


def _float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{text} is beyond float range; write a finite number")
    return value


def _constant(name: str):
    raise ValueError(f"{name} is not a JSON number; write a finite number")


def _infinity(name: str):
    if name in ("Infinity", "-Infinity"):
        return float(name)
    return _constant(name)


def _finite_outside(value, keys, path: str = "") -> str | None:
    """The path of the first infinite number in ``value`` not under one of ``keys``, else None."""
    if isinstance(value, float) and not math.isfinite(value):
        return path or "(top)"
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for k, v in items:
        if not (isinstance(k, str) and k in keys):
            found = _finite_outside(v, keys, f"{path}[{k!r}]" if path else repr(k))
            if found:
                return found
    return None


def loads(raw, source: str, fix: str, max_bytes: int = MAX_BYTES, allow_nan: bool = False,
          infinite_keys: tuple = ()):
    """Parse JSON from a user's file with the module's limits.

    Parameters
    ----------
    raw : str or bytes
        The JSON text (bytes must be UTF-8).
    source : str
        The file and attribute, e.g. ``"in.exr header 'splatlab.camera'"``.
    fix : str
        What to do about bad JSON, ending the message.
    max_bytes : int, default MAX_BYTES
        The most characters accepted.
    allow_nan : bool, default False
        Accept ``NaN`` and ``Infinity`` (a report's missing figures are NaN).
    infinite_keys : tuple of str
        Keys under which ``Infinity`` is accepted (never NaN), e.g. ``("surfaces",)``.

    Raises
    ------
    InputError
        Not UTF-8, too large, nested too deep, an over-long integer, NaN or Infinity, or
        invalid JSON; one line naming ``source``.
    """
    if isinstance(raw, (bytes, bytearray)):
        try:
            raw = bytes(raw).decode("utf-8")
        except UnicodeDecodeError as exc:
            raise InputError(f"{source}: not UTF-8 (byte {exc.start}); {fix}") from None
    if not isinstance(raw, str):
        raise InputError(f"{source}: expected JSON text, got {type(raw).__name__}; {fix}")
    if len(raw) > max_bytes:
        raise InputError(f"{source}: {len(raw)} characters of JSON, more than the {max_bytes} it may "
                         f"hold; {fix}")
    depth = _depth(raw)
    if depth > MAX_DEPTH:
        raise InputError(f"{source}: JSON nested {depth} deep, more than {MAX_DEPTH} (headers nest a few "
                         f"levels); {fix}")
    try:
        if allow_nan:
            return json.loads(raw, parse_int=_int)
        data = json.loads(raw, parse_int=_int, parse_float=_float,
                          parse_constant=_infinity if infinite_keys else _constant)
    except (ValueError, RecursionError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{source}: not JSON ({reason}); {fix}") from None
    where = _finite_outside(data, infinite_keys) if infinite_keys else None
    if where:
        raise InputError(f"{source}: not JSON (Infinity at {where}, where only a finite number fits; only a flat "
                         f"surface's radius under {list(infinite_keys)} may be Infinity); {fix}")
    return data

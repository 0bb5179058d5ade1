"""Validated, frozen configuration dataclasses built from TOML tables.

``from_table(Cls, table, where)`` checks every key against the dataclass fields (unknown keys are
an error that lists them with the known ones), the types (int/float/bool/str/tuples of them) and
then calls the dataclass, whose ``__post_init__`` checks the values. ``where`` names the file and
table for messages, e.g. ``"scenes/demo.toml [psf.simple_lens]"``.
"""
from __future__ import annotations

import dataclasses
import math
import typing

from .errors import UserError

MAX_SIDE_PX = 16384    # pixels a side of a scene or labelled image: an RGB float image of 16384^2 is 3.2 GB


def _check_type(value, annotation, where, key):
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if annotation is typing.Any:
        return value
    if origin is typing.Union or str(origin) == "<class 'types.UnionType'>":
        if value is None and type(None) in args:
            return None
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _check_type(value, arg, where, key)
            except UserError:
                continue
        raise UserError(f"{where}: {key} = {value!r} has the wrong type; expected {annotation}")
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise UserError(f"{where}: {key} = {value!r} must be a list")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_check_type(v, args[0], where, key) for v in value)
        if len(value) != len(args):
            raise UserError(f"{where}: {key} = {value!r} must have {len(args)} entries")
        return tuple(_check_type(v, a, where, key) for v, a in zip(value, args))
    if annotation is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise UserError(f"{where}: {key} = {value!r} must be a number")
        return float(value)
    if annotation is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise UserError(f"{where}: {key} = {value!r} must be an integer")
        return value
    if annotation is bool:
        if not isinstance(value, bool):
            raise UserError(f"{where}: {key} = {value!r} must be true or false")
        return value
    if annotation is str:
        if not isinstance(value, str):
            raise UserError(f"{where}: {key} = {value!r} must be a string")
        return value
    if annotation is dict:
        if not isinstance(value, dict):
            raise UserError(f"{where}: {key} = {value!r} must be a table")
        return value
    return value


def from_table(cls, table: dict, where: str):
    """Build the frozen dataclass ``cls`` from a TOML ``table``; errors name ``where`` and the key."""
    if not isinstance(table, dict):
        raise UserError(f"{where}: expected a table, got {table!r}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(table) - set(fields))
    if unknown:
        raise UserError(f"{where}: unknown key(s) {unknown}; known keys are {sorted(fields)}")
    missing = [name for name, f in fields.items() if name not in table
               and f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING]
    if missing:
        raise UserError(f"{where}: missing key(s) {missing}")
    values = {k: _check_type(v, hints[k], where, k) for k, v in table.items()}
    try:
        return cls(**values)
    except UserError as exc:
        raise UserError(f"{where}: {exc}") from None


def to_table(obj) -> dict:
    """The inverse of :func:`from_table` (tuples become lists), for hashing and reports."""
    out = {}
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        if dataclasses.is_dataclass(v):
            v = to_table(v)
        elif isinstance(v, tuple):
            v = [list(x) if isinstance(x, tuple) else x for x in v]
        out[f.name] = v
    return out


# Tables where ``inf`` means something (a lens's flat face: radius inf, in [camera] and in
# [psf.physical_lens]); NaN never does.
INF_ALLOWED = ("surfaces",)


def check_finite(data, where: str, key: str = "", allow_inf=INF_ALLOWED, _tables: tuple = ()) -> None:
    """UserError at the first NaN or infinite number anywhere in ``data`` (a parsed TOML file),
    naming its key (e.g. ``shapes #3.center[0]``); ``inf`` passes under a key in ``allow_inf``."""
    if isinstance(data, dict):
        for k, value in data.items():
            check_finite(value, where, f"{key}.{k}" if key else str(k), allow_inf, _tables + (str(k),))
    elif isinstance(data, list):
        for i, value in enumerate(data):
            part = f" #{i + 1}" if isinstance(value, dict) else f"[{i}]"
            check_finite(value, where, key + part, allow_inf, _tables)
    elif isinstance(data, float) and not math.isfinite(data):
        if math.isinf(data) and set(_tables) & set(allow_inf):
            return
        raise UserError(f"{where}: {key} = {data}: must be a finite number (NaN and inf are no position, "
                        "size or setting); write a real value")

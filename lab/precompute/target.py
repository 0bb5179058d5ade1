"""What ``splatlab precompute TARGET`` builds: a registered PSF model, or every model a scene needs.

A model name takes the model's default configuration plus ``--set KEY=VALUE`` overrides. Values
are TOML literals (``64``, ``2.5``, ``true``, ``[2.0, 1.0]``, ``"circle"``); a value that is not
valid TOML is taken as a bare string (``--set aperture=hexagon``). The table is then validated by
the model's config dataclass (:func:`lab.config.from_table`), so an unknown key, a missing
required key or a bad value is an error naming it - before anything is traced.
"""
from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

from lab.errors import UserError

__all__ = ["Target", "parse_sets", "resolve_target", "load_target_model"]

_KEY = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


@dataclass(frozen=True)
class Target:
    """A resolved precompute target: ``kind`` is ``"model"`` (``name``) or ``"scene"`` (``path``)."""

    kind: str
    name: str | None = None
    path: Path | None = None


def parse_sets(items, example: str = "max_coc_px=64") -> dict:
    """``["key=value", ...]`` from ``--set`` as a table of TOML values (text that is no TOML value
    stays a string); ``example`` is the one the messages show.

    Raises
    ------
    UserError
        An item without ``=``, a key that is not a name, or a key given twice.
    """
    table: dict = {}
    for item in items or ():
        key, sep, text = str(item).partition("=")
        key = key.strip()
        if not sep or not _KEY.match(key):
            raise UserError(f"--set {item!r}: expected KEY=VALUE with KEY a setting name, "
                            f"e.g. --set {example}")
        if key in table:
            raise UserError(f"--set {key}: given twice ({table[key]!r} and {text.strip()!r}); keep one")
        try:
            value = tomllib.loads(f"v = {text.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            value = text.strip()
        table[key] = value
    return table


def resolve_target(text: str) -> Target:
    """A registered model name, or a scene file (``.toml`` or an existing path).

    Raises
    ------
    UserError
        Neither: the message lists the registered models.
    """
    from lab.psf_tracing.models import model_names

    if text in model_names():
        return Target("model", name=text)
    path = Path(text)
    if path.suffix == ".toml" or path.exists():
        return Target("scene", path=path)
    raise UserError(f"precompute target {text!r}: not a registered PSF model {model_names()} and not "
                    "a scene file; pass a model name or a scene .toml")


def load_target_model(name: str, sets=None):
    """Model ``name`` with its defaults and the ``--set`` overrides, validated (nothing traced)."""
    from lab.psf_tracing.models import load_model

    return load_model(name, parse_sets(sets), f"splatlab precompute {name} --set")

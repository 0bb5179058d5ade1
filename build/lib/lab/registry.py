"""Registries by name (Mitsuba's ``register_integrator`` style): no if/elif chains over kinds."""
from __future__ import annotations

from .errors import UserError


class Registry:
    """Classes registered under names; ``kind`` names them in messages ("PSF model", "aperture").

    ``register(name)`` is a class decorator that also sets ``cls.name``; ``get(name)`` raises
    :class:`UserError` listing the known names; ``names()`` lists them sorted.
    """

    def __init__(self, kind: str):
        self.kind = kind
        self._entries: dict[str, type] = {}

    def register(self, name: str):
        def decorate(cls):
            if name in self._entries:
                raise ValueError(f"{self.kind} {name!r} is registered twice ({self._entries[name]} and {cls})")
            cls.name = name
            self._entries[name] = cls
            return cls
        return decorate

    def names(self) -> list[str]:
        return sorted(self._entries)

    def get(self, name: str) -> type:
        try:
            return self._entries[name]
        except (KeyError, TypeError):
            raise UserError(f"{self.kind} {name!r} is unknown; known {self.kind}s are {self.names()}") from None

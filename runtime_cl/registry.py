"""Registries by name (Mitsuba's ``register_integrator`` style): no if/elif chains over kinds.

One class serves every registry of splatlab: runtime passes and cameras here, PSF models,
cameras and apertures in the lab.
"""
from __future__ import annotations

from runtime_cl.errors import InputError

__all__ = ["Registry"]


class Registry:
    """Classes registered under names; ``kind`` names them in messages ("PSF model", "aperture").

    Parameters
    ----------
    kind : str
        What the entries are, for messages.
    attribute : str, default "name"
        :meth:`register` sets this class attribute to the entry's name.
    sort : bool, default True
        :meth:`names` sorted; False keeps the registration order.
    """

    def __init__(self, kind: str, attribute: str = "name", sort: bool = True):
        self.kind, self.attribute, self.sort = kind, attribute, sort
        self._entries: dict[str, type] = {}

    def register(self, name: str):
        """Class decorator: register the class under ``name`` (twice is an error)."""
        def decorate(cls):
            if name in self._entries:
                raise ValueError(f"{self.kind} {name!r} is registered twice ({self._entries[name]} and {cls})")
            setattr(cls, self.attribute, name)
            self._entries[name] = cls
            return cls
        return decorate

    def names(self) -> list[str]:
        return sorted(self._entries) if self.sort else list(self._entries)

    def __contains__(self, name) -> bool:
        return isinstance(name, str) and name in self._entries

    def get(self, name: str) -> type:
        """The class registered as ``name``; InputError listing the known names otherwise."""
        if name not in self:
            raise InputError(f"{self.kind} {name!r} is unknown; known {self.kind}s are {self.names()}")
        return self._entries[name]

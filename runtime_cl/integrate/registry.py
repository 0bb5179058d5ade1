"""The integrator registry: every way the runtime turns a Laplacian canvas back into an image.

An integrator is one module that registers an :class:`Integrator` subclass
(``@register_integrator("name")``) and is imported by :mod:`runtime_cl.integrate`. The spreadlet
:class:`~runtime_cl.spreadlets.renderer.Renderer`, the ``spreadlets`` pass's ``integrator``
option, ``splatlab render --integrator`` and ``splatlab bench integrate`` pick it up by name.
"""
from __future__ import annotations

import abc
from typing import ClassVar

from runtime_cl.errors import InputError
from runtime_cl.registry import Registry

__all__ = ["DEFAULT_INTEGRATOR", "Integrator", "register_integrator", "get_integrator", "integrator_names"]

# fft32: the exact solve's float32 twin, within ~1e-5 of its largest value (SSIM 1.0000 on the
# demo) at about half its time, which is a third of a 1024^2 spreadlet frame
DEFAULT_INTEGRATOR = "fft32"
_INTEGRATORS = Registry("integrator", sort=False)   # registration order is the listing order


class Integrator(abc.ABC):
    """Inverts the 5-point Laplacian on a canvas whose image is zero on its border ring.

    Class attributes
    ----------------
    name : str
        Registry name, set by :func:`register_integrator`.
    summary : str
        One line for ``--help``.

    Parameters
    ----------
    device : runtime_cl.device.opencl.Device, optional
        For integrators that run on the OpenCL device (default: the process's device).
    """

    name: ClassVar[str]
    summary: ClassVar[str]

    def __init__(self, device=None):
        self.device = device

    @abc.abstractmethod
    def __call__(self, laplacian) -> tuple:
        """Integrate ``laplacian`` (H, W) or (H, W, C).

        Returns
        -------
        image : ndarray, float32, same shape
            Its border ring averages to zero; the canvas's mean Laplacian is ignored.
        times : dict
            ``device_ms`` and ``transfer_ms`` (OpenCL event times; 0 for a host integrator).
        """


def register_integrator(name: str):
    """Class decorator: register an :class:`Integrator` under ``name``."""
    return _INTEGRATORS.register(name)


def integrator_names() -> list[str]:
    """Registered integrator names, in registration order."""
    return _INTEGRATORS.names()


def get_integrator(name) -> type:
    """The :class:`Integrator` class registered as ``name``; InputError naming the valid ones."""
    if name not in _INTEGRATORS:
        raise InputError(f"integrator = {name!r}: unknown; choose one of {integrator_names()}")
    return _INTEGRATORS.get(name)

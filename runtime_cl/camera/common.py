"""What every runtime camera shares: the registry by header ``"lens"`` name and the depth check.

A runtime camera is a frozen dataclass in the units of the ``splatlab.camera`` EXR header,
registered with :func:`register_lens` under the header's ``"lens"`` value (which sets the class
attribute ``lens``). It provides ``from_json(data, source)`` (validate a header and build the
camera; errors name ``source``), ``to_json()`` (the header entries it owns), ``fov_x_deg()``
and ``coc_radius_px(z_m, width_px)`` (signed circle of confusion in pixels, positive behind the
focus plane). :func:`from_header` builds whichever camera a header names.
"""
from __future__ import annotations

import numpy as np

from runtime_cl.errors import InputError
from runtime_cl.registry import Registry

__all__ = ["depth_m", "from_header", "lens_names", "register_lens"]

_LENSES = Registry("camera lens", attribute="lens")


def register_lens(name: str):
    """Class decorator: register a runtime camera under the header's ``"lens"`` value ``name``."""
    return _LENSES.register(name)


def lens_names() -> list[str]:
    """The registered header ``"lens"`` values, sorted."""
    return _LENSES.names()


def from_header(data, source: str = "camera"):
    """The camera a ``splatlab.camera`` JSON object describes, by its ``"lens"`` key.

    Parameters
    ----------
    data : dict
        The parsed header, e.g. ``{"lens": "thin", "focal_length_mm": 50, "f_number": 2.0,
        "focus_distance_m": 3.0, "sensor_width_mm": 36, "shutter": [0, 1]}``.
    source : str
        Where the header came from (a file and attribute), for error messages.

    Returns
    -------
    object
        An instance of the class registered under ``data["lens"]``, e.g.
        :class:`runtime_cl.camera.thin_lens.ThinLens`.

    Raises
    ------
    InputError
        ``data`` is not a dict, its lens is not registered (the message lists the known ones), or
        the camera's own ``from_json`` rejects it.
    """
    if not isinstance(data, dict):
        raise InputError(f"{source}: the camera must be a JSON object, got {data!r}")
    lens = data.get("lens")
    if lens not in _LENSES:
        raise InputError(f"{source}: lens = {lens!r} is not known; use one of {lens_names()}")
    return _LENSES.get(lens).from_json(data, source)


def depth_m(z_m) -> np.ndarray:
    """``z_m`` (scalar or array, metres) as float64; InputError unless every depth is > 0 (inf is
    allowed: background at infinity; NaN is not)."""
    z = np.asarray(z_m, dtype=np.float64)
    bad = ~(z > 0)  # catches NaN too
    if np.any(bad):
        first = float(z[bad].flat[0])
        raise InputError(f"depth Z = {first!r} at {int(bad.sum())} pixel(s): depths must be > 0 "
                         "metres (use inf for background at infinity)")
    return z

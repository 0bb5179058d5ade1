"""The runtime's public functions: load a database, render labelled pixels, list the methods."""
from __future__ import annotations

from runtime_cl.frame import Frame
from runtime_cl.integrate import get_integrator, integrator_names
from runtime_cl.passes import get_pass, pass_names, run_pass
from runtime_cl.psf.database import SpreadletDatabase

__all__ = ["integrators", "load_database", "methods", "render"]


def load_database(path, *, expect_model: str | None = None) -> SpreadletDatabase:
    """Read and verify a spreadlet database (``.spdb``, made by ``splatlab precompute``).

    Parameters
    ----------
    path : str or Path
        The database file.
    expect_model : str, optional
        Refuse a database of another PSF model (e.g. ``"simple_lens"``).

    Raises
    ------
    InputError
        The file is missing, truncated, foreign, of another format version or model, or its
        checksum does not match.
    """
    return SpreadletDatabase.load(path, expect_model=expect_model)


def methods() -> dict:
    """Every registered runtime pass: name -> one-line summary."""
    return {name: get_pass(name).summary for name in pass_names()}


def integrators() -> dict:
    """Every registered Poisson integrator (the ``integrator`` option): name -> one-line summary."""
    return {name: get_integrator(name).summary for name in integrator_names()}


def render(rgb, depth, camera, db=None, *, method: str = "spreadlets", layers: int = 1, motion=None,
           alpha=None, input_layers=(), runs: int = 0, device=None, **options):
    """Render depth of field (and motion blur) from labelled pixels.

    Parameters
    ----------
    rgb : array_like, float, (H, W, C), C = 1 or 3
        Linear radiance, premultiplied by ``alpha``.
    depth : array_like, float, (H, W)
        Camera-space depth Z in metres (> 0; ``inf`` for the background).
    camera : runtime camera
        E.g. ``runtime_cl.camera.thin_lens.ThinLens(85.0, 1.2, 1.0)`` (focal length mm,
        f-number, focus distance m, sensor width mm = 36).
    db : SpreadletDatabase, optional
        From :func:`load_database`; needed by every method but ``"polygon"``.
    method : str, default "spreadlets"
        A registered runtime pass (:func:`methods`): ``"spreadlets"``, ``"splat"``,
        ``"filter"`` or ``"polygon"``.
    layers : int, default 1
        Global depth layers (occlusion, LSR18 section 6) for a pass that renders them.
    motion : array_like, float, (H, W, 2), optional
        Per-pixel motion over the shutter in pixels (X right, Y up); motion databases need it.
    alpha : array_like, float, (H, W), optional
        Coverage in [0, 1] (default 1); depth layers read it.
    input_layers : sequence of Frame, optional
        The layers of a layered input (``layerN.*``), nearest first, for ``layered_input=True``.
    runs : int, default 0
        Timed calls after one warm-up call; 0 renders once (its time includes first-call costs).
    device : runtime_cl.device.opencl.Device, optional
        Default: PoCL's CPU device (or ``$SPLATLAB_CL_PLATFORM``).
    **options
        The pass's own options, e.g. ``aperture="hexagon"`` and ``layered_input=True`` for
        ``"polygon"``, ``tile`` and ``run_max`` for the spreadlet passes, ``integrator``
        (``"exact"``, ``"fft32"``, ``"pyramid"``: :func:`integrators`) for ``"spreadlets"``.

    Returns
    -------
    image : ndarray, float32, (H, W, C')
        Linear radiance; C' = max(C, database channels) for the spreadlet passes.
    timing : runtime_cl.timing.Timing
        Median times over ``runs`` calls (see :mod:`runtime_cl.timing` for each figure).

    Raises
    ------
    InputError
        Any bad input, with the argument, the value and the fix.
    """
    frame = Frame(rgb, depth, alpha=alpha, motion=motion, layers=tuple(input_layers))
    return run_pass(method, frame, camera, db, runs=runs, layers=layers, device=device, **options)

"""One timing contract for every runtime pass: what a render costs, split so passes compare.

Every pass (:mod:`runtime_cl.passes`) is timed the same way by :func:`measure`: one warm-up
call, then ``runs`` timed calls, each figure the median over the timed calls:

=============  ===============================================================================
``time_ms``    wall clock of one render call, input arrays on the host to the image on the
               host: what a user waits for, and what the accuracy-vs-time plots show
``device_ms``  OpenCL event profiling of the pass's kernels
``transfer_ms``  OpenCL event profiling of its host <-> device copies (a buffer created from
               host memory is copied by the host: host time)
``host_ms``    ``time_ms - device_ms - transfer_ms`` (>= 0): host work the device does not
               hide, e.g. validation, the FFT Poisson integration, layer binning and compositing
``compile_ms`` building the pass plus how much longer the warm-up call took than a timed one:
               kernel builds, uploads of the database, first launches, radius tables;
               excluded from ``time_ms``
``prepare_ms`` per-pixel PSF parameters from the camera and depth (coordinates, CoC), computed
               once per input before the calls; excluded from ``time_ms``
=============  ===============================================================================

A pass's call returns its image and a :class:`CallTimes` (the event-profiled parts and counts);
:func:`measure` adds the wall clock. The wall clock is right here because every call ends by
waiting for its downloads: nothing of the call is still running on the device.
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

import numpy as np

from runtime_cl.errors import InputError

__all__ = ["CallTimes", "Timing", "COLUMNS", "MAX_RUNS", "measure"]

# What each Timing figure means, for reports and --help.
COLUMNS = {
    "time_ms": "median wall clock of a render call (host arrays in, host image out)",
    "device_ms": "OpenCL event-profiled kernel time",
    "transfer_ms": "OpenCL event-profiled host<->device copies",
    "host_ms": "host work the device does not hide (time - device - transfer): validation, "
               "FFT integration, layer compositing",
    "compile_ms": "set-up and the warm-up call's extra time (kernel builds, database upload, first "
                  "launches, tables); not in time",
    "prepare_ms": "per-pixel PSF parameters from camera and depth, once per input; not in time",
}


@dataclass
class CallTimes:
    """What one call of a pass measured itself: event-profiled milliseconds and counts."""

    device_ms: float = 0.0
    transfer_ms: float = 0.0
    counts: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Timing:
    """The cost of a pass on one input (see the module docstring for every field)."""

    time_ms: float
    device_ms: float
    transfer_ms: float
    host_ms: float
    compile_ms: float
    prepare_ms: float
    runs: int
    counts: dict

    def to_json(self) -> dict:
        return asdict(self)


def _check_runs(runs) -> int:
    if isinstance(runs, bool) or not isinstance(runs, (int, np.integer)) or runs < 0:
        raise InputError(f"runs = {runs!r}: the number of timed calls must be an integer >= 0 "
                         "(0: one call without a warm-up)")
    return int(runs)


MAX_RUNS = 200   # the most timed calls ``min_ms`` adds


def measure(call, runs: int = 3, prepare_ms: float = 0.0, build_ms: float = 0.0, min_ms: float = 0.0):
    """Warm up with one call of ``call()``, then time ``runs`` calls; ``(first image, Timing)``.

    Parameters
    ----------
    call : callable
        ``call() -> (image, CallTimes)``, one whole render.
    runs : int, default 3
        Timed calls after the warm-up; 0 calls once, without a warm-up (the one call's time
        then includes what a first call costs beyond ``build_ms``).
    prepare_ms : float, default 0
        Recorded as :attr:`Timing.prepare_ms`.
    build_ms : float, default 0
        Set-up before the first call (building the pass), added to :attr:`Timing.compile_ms`.
    min_ms : float, default 0
        With ``runs`` > 0, more calls are timed until they add up to ``min_ms`` (at most
        ``MAX_RUNS``): a median of a few-millisecond call over three runs is at the mercy of one
        burst of load on a shared machine, a median over a hundred is not.

    Returns
    -------
    image : ndarray
        The warm-up call's image (every call renders the same image).
    timing : Timing
        Medians over the timed calls (or the one call's figures); ``counts`` of the first call.
    """
    runs = _check_runs(runs)
    start = time.perf_counter()
    image, first = call()
    warm_ms = (time.perf_counter() - start) * 1e3
    if runs == 0:
        return image, Timing(time_ms=warm_ms, device_ms=first.device_ms, transfer_ms=first.transfer_ms,
                             host_ms=max(0.0, warm_ms - first.device_ms - first.transfer_ms),
                             compile_ms=build_ms, prepare_ms=float(prepare_ms), runs=0,
                             counts=dict(first.counts))
    walls, device, transfer = [], [], []
    while len(walls) < runs or (sum(walls) < min_ms and len(walls) < MAX_RUNS):
        start = time.perf_counter()
        _, times = call()
        walls.append((time.perf_counter() - start) * 1e3)
        device.append(times.device_ms)
        transfer.append(times.transfer_ms)
    wall = float(np.median(walls))
    host = float(np.median([max(0.0, w - d - t) for w, d, t in zip(walls, device, transfer)]))
    return image, Timing(time_ms=wall, device_ms=float(np.median(device)),
                         transfer_ms=float(np.median(transfer)), host_ms=host,
                         compile_ms=build_ms + max(0.0, warm_ms - wall), prepare_ms=float(prepare_ms), runs=len(walls),
                         counts=dict(first.counts))

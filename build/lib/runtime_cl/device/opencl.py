"""OpenCL set-up: one platform/device, one context, one profiling queue, a program cache.

The device is picked once per process (:func:`get_device`): the platform whose name contains
``$SPLATLAB_CL_PLATFORM`` (case-insensitive) if that is set, else the PoCL CPU device, else the
first device found; PoCL's worker threads are pinned to the CPUs first (:func:`pin_pocl_threads`).
Programs are built once per process per (kernel files, build options); the build time is
recorded so reports can show compile time apart from run time. PoCL keeps its
own on-disk cache in ``$POCL_CACHE_DIR``, so a "cold" build in a new process that finds the
binary there takes ~0.03 s instead of ~0.5 s; :attr:`Device.builds` records every build.

Kernel sources live in ``runtime_cl/kernels``. Several files are concatenated in the given order
instead of using ``#include``: PoCL's cache key is the source text, so an edited included file
could otherwise be served stale from the cache.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from runtime_cl.errors import InputError

KERNEL_DIR = Path(__file__).resolve().parents[1] / "kernels"
PLATFORM_ENV = "SPLATLAB_CL_PLATFORM"
PIN_ENV = "POCL_AFFINITY"   # PoCL pins its worker thread i to CPU i


def _import_cl():
    try:
        import pyopencl as cl
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise InputError(f"pyopencl is not importable ({exc}); install it with "
                         "`pip install pyopencl pocl-binary-distribution`") from exc
    return cl


@dataclass
class BuildRecord:
    """One program request: which files and options, how long, and whether it was built now."""

    files: tuple
    options: tuple
    ms: float
    built: bool  # False: served from this process's cache (0 ms)


@dataclass
class Device:
    """An OpenCL device with its context, profiling queue and program cache.

    Use :func:`get_device` rather than constructing this directly.
    """

    platform: object
    device: object
    context: object
    queue: object
    builds: list = field(default_factory=list)
    _programs: dict = field(default_factory=dict, repr=False)

    @property
    def fp64(self) -> bool:
        """Whether the device has double precision (``cl_khr_fp64``)."""
        return "cl_khr_fp64" in self.device.extensions

    def program(self, files, options=()):
        """Build (once per process) the program made of the kernel ``files`` with ``options``.

        Parameters
        ----------
        files : str or sequence of str
            File names under ``runtime_cl/kernels``, concatenated in this order.
        options : sequence of str
            Build options, e.g. ``["-DPAD=12"]``; part of the cache key.

        Returns
        -------
        program : pyopencl.Program
        record : BuildRecord
            ``record.ms`` is the build time in milliseconds, 0 when served from the cache.
        """
        cl = _import_cl()
        files = (files,) if isinstance(files, str) else tuple(files)
        options = tuple(str(o) for o in options)
        key = (files, options)
        if key in self._programs:
            record = BuildRecord(files, options, 0.0, False)
            self.builds.append(record)
            return self._programs[key], record
        source = "\n".join((KERNEL_DIR / f).read_text() for f in files)
        start = time.perf_counter()  # build() is synchronous, so wall-clock timing is right here
        try:
            program = cl.Program(self.context, source).build(options=list(options))
        except cl.RuntimeError as exc:
            from runtime_cl.device.pocl_cpu import FIX, UNKNOWN_CPU

            hint = (f"\nPoCL's LLVM does not know this CPU; fix it with `{FIX}`"
                    if UNKNOWN_CPU in str(exc) else "")
            raise RuntimeError(f"OpenCL build of {files} with {options} failed:\n{exc}{hint}") from exc
        record = BuildRecord(files, options, (time.perf_counter() - start) * 1e3, True)
        self._programs[key] = program
        self.builds.append(record)
        return program, record

    def warm_up(self, record: BuildRecord, launch) -> None:
        """Run ``launch()`` (enqueue on tiny inputs and wait) once after ``record``'s fresh build.

        PoCL compiles each kernel's work-group function at its first launch (hundreds of ms
        without a disk cache); doing it here books that time as compile time, not run time.
        """
        if not record.built:
            return
        start = time.perf_counter()
        launch()
        self.builds.append(BuildRecord(record.files, record.options + ("<first launch>",),
                                       (time.perf_counter() - start) * 1e3, True))

    def describe(self) -> dict:
        """Platform, device, versions and compute units, for reports and ``splatlab doctor``."""
        d = self.device
        return {
            "platform": self.platform.name.strip(),
            "platform_version": self.platform.version.strip(),
            "device": d.name.strip(),
            "device_version": d.version.strip(),
            "driver_version": d.driver_version.strip(),
            "compute_units": int(d.max_compute_units),
            "global_mem_mib": int(d.global_mem_size) >> 20,
            "max_alloc_mib": int(d.max_mem_alloc_size) >> 20,
            "fp64": self.fp64,
            "pocl_cache_dir": os.environ.get("POCL_CACHE_DIR"),
            "threads_pinned": os.environ.get(PIN_ENV) == "1",   # see pin_pocl_threads
        }

    def compile_ms(self) -> float:
        """Total build time spent in this process so far, in milliseconds."""
        return float(sum(b.ms for b in self.builds))


def _choose(platforms, wanted: str | None):
    """(platform, device) for the override substring, else PoCL's CPU, else the first device."""
    pairs = [(p, d) for p in platforms for d in p.get_devices()]
    if not pairs:
        return None
    if wanted:
        hits = [(p, d) for p, d in pairs
                if wanted.lower() in p.name.lower() or wanted.lower() in d.name.lower()]
        if not hits:
            names = sorted({p.name.strip() for p, _ in pairs})
            raise InputError(f"{PLATFORM_ENV}={wanted!r}: no OpenCL platform or device matches; "
                             f"available platforms are {names}; unset it or pick one of these")
        return hits[0]
    for p, d in pairs:
        if "portable computing language" in p.name.lower() or "pocl" in p.name.lower():
            return p, d
    return pairs[0]


_DEVICES: dict = {}


def pin_pocl_threads() -> bool:
    """Ask PoCL to pin its worker threads, thread ``i`` to CPU ``i`` (``POCL_AFFINITY=1``), unless
    the variable is set already or this process may not run on CPUs ``0 .. n-1``. True if set.

    Must run before PoCL starts (the first platform query). Unpinned, Linux often queues a just
    woken worker behind the other one on a CPU until its next load balancing, milliseconds
    later: on a 2-core VM a third of the uniform polygon blurs at 1024^2 that followed an FFT
    ran on one core, at twice the time; pinned, none did (``splatlab bench polygon``).
    """
    if PIN_ENV in os.environ or not hasattr(os, "sched_getaffinity"):
        return False
    cpus = os.sched_getaffinity(0)
    threads = os.environ.get("POCL_MAX_PTHREAD_COUNT", "")
    if cpus != set(range(len(cpus))) or (threads.isdigit() and int(threads) > len(cpus)):
        return False
    os.environ[PIN_ENV] = "1"
    return True


def get_device(platform: str | None = None) -> Device:
    """The process-wide :class:`Device` (one per platform choice).

    Parameters
    ----------
    platform : str, optional
        Substring of the platform or device name; default ``$SPLATLAB_CL_PLATFORM``, else PoCL.

    Raises
    ------
    InputError
        No OpenCL platform is installed, or none matches the requested name.
    """
    cl = _import_cl()
    wanted = platform if platform is not None else os.environ.get(PLATFORM_ENV) or None
    if wanted in _DEVICES:
        return _DEVICES[wanted]
    if not _DEVICES:
        pin_pocl_threads()
    try:
        platforms = cl.get_platforms()
    except cl.Error:  # pyopencl raises when the ICD loader finds nothing
        platforms = []
    chosen = _choose(platforms, wanted)
    if chosen is None:
        raise InputError("OpenCL: no platform or device found; install the CPU runtime with "
                         "`pip install pocl-binary-distribution`")
    p, d = chosen
    context = cl.Context([d])
    queue = cl.CommandQueue(context, d, properties=cl.command_queue_properties.PROFILING_ENABLE)
    dev = Device(p, d, context, queue)
    _DEVICES[wanted] = dev
    return dev


def event_ms(*events) -> float:
    """Sum of the profiled durations of finished OpenCL events, in milliseconds."""
    total = 0
    for ev in events:
        ev.wait()
        total += ev.profile.end - ev.profile.start
    return total * 1e-6


def as_f32(array, name: str, ndim: int) -> np.ndarray:
    """C-contiguous float32 view/copy of ``array`` checked to have ``ndim`` dimensions."""
    a = np.ascontiguousarray(array, dtype=np.float32)
    if a.ndim != ndim:
        raise InputError(f"{name}: shape {a.shape} has {a.ndim} dimension(s), need {ndim}")
    return a

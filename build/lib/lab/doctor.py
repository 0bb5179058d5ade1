"""``splatlab doctor``: what this machine has for splatlab, what is missing and how to install it."""
from __future__ import annotations

import importlib
from importlib import metadata


def _check_module(name: str, dist: str, say) -> str | None:
    try:
        importlib.import_module(name)
    except Exception as exc:  # noqa: BLE001 - report any import failure
        return f"{dist}: cannot import {name} ({exc}); install it: .venv/bin/pip install {dist}"
    say(f"  ok   {dist} {metadata.version(dist)}")
    return None


def diagnose(say=print) -> list[str]:
    """Print one line per check; return the problems (each with its fix)."""
    problems = []
    say("Python packages:")
    for module, dist in (("numpy", "numpy"), ("scipy", "scipy"), ("pyopencl", "pyopencl"),
                         ("OpenEXR", "openexr"), ("skimage", "scikit-image"), ("numba", "numba"),
                         ("drjit", "drjit"), ("mitsuba", "mitsuba")):
        msg = _check_module(module, dist, say)
        if msg:
            problems.append(msg)
    say("Dr.Jit LLVM backend:")
    from .llvm_check import llvm_version, problem

    msg = problem()
    if msg:
        problems.append(msg)
    else:
        say(f"  ok   LLVM {'.'.join(map(str, llvm_version()))}")
        try:
            import mitsuba as mi

            mi.set_variant("llvm_ad_rgb")
            say(f"  ok   Mitsuba variant llvm_ad_rgb ({mi.__version__})")
        except Exception as exc:  # noqa: BLE001
            problems.append(f"Mitsuba cannot use llvm_ad_rgb ({exc}); reinstall: .venv/bin/pip install "
                            "--force-reinstall mitsuba==3.9.1")
    say("OpenCL device:")
    try:
        from runtime_cl.device.opencl import get_device

        d = get_device().describe()
        say(f"  ok   {d['platform']} / {d['device']} ({d['device_version']}), {d['compute_units']} compute "
            f"units{' (threads pinned)' if d['threads_pinned'] else ''}, fp64={d['fp64']}, kernel "
            f"cache {d['pocl_cache_dir'] or 'PoCL default'}")
    except Exception as exc:  # noqa: BLE001
        problems.append(f"OpenCL: {exc}; install PoCL: .venv/bin/pip install pocl-binary-distribution")
    else:
        from runtime_cl.device.pocl_cpu import probe, problem

        built = probe()
        msg = problem(built)
        if msg:
            problems.append(msg)
        else:
            say(f"  ok   PoCL builds kernels ({built['device']})")
    say("problems:" if problems else "everything splatlab needs is here")
    for p in problems:
        say(f"  - {p}")
    return problems

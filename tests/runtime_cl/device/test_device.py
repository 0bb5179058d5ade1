"""OpenCL device set-up: platform choice, program cache, messages when OpenCL is missing,
PoCL's pinned threads."""
import os
from pathlib import Path

import pyopencl as cl
import pytest

import runtime_cl.device.opencl as device_mod
from runtime_cl.device.opencl import get_device
from runtime_cl.errors import InputError


def test_default_device_is_pocl_and_shared():
    dev = get_device()
    assert dev is get_device()
    info = dev.describe()
    assert {"platform", "device", "device_version", "compute_units", "fp64"} <= set(info)
    assert "portable computing language" in info["platform"].lower()
    assert info["compute_units"] >= 1
    assert dev.queue.properties & cl.command_queue_properties.PROFILING_ENABLE


def test_program_is_built_once_per_options():
    dev = get_device()
    files = ("psf/psf_space.cl", "psf/psf_index.cl")
    options = _grid_options() + ["-DDEVICE_TEST_TOKEN=1"]  # no other code builds with this option
    p1, r1 = dev.program(files, options)
    p2, r2 = dev.program(files, options)
    assert p1 is p2
    assert r1.built and r1.ms > 0.0
    assert not r2.built and r2.ms == 0.0
    p3, r3 = dev.program(files, _grid_options() + ["-DDEVICE_TEST_TOKEN=2"])
    assert p3 is not p1 and r3.built
    assert dev.compile_ms() >= r1.ms + r3.ms


def _grid_options():
    from runtime_cl.psf.grid import NestedGrid
    from runtime_cl.psf.grid_cl import PsfSpaceTables

    return PsfSpaceTables(NestedGrid(9, (2.0, 1.0), ((0, 1), (0, 1)), ("a", "b")), True).options


def test_unknown_platform_override_lists_the_available_ones(monkeypatch):
    monkeypatch.setenv("SPLATLAB_CL_PLATFORM", "no-such-platform-xyz")
    with pytest.raises(InputError, match=r"SPLATLAB_CL_PLATFORM='no-such-platform-xyz'.*Portable"):
        get_device()


def test_no_opencl_platform_says_what_to_install(monkeypatch):
    def none():
        raise cl.LogicError("clGetPlatformIDs", cl.status_code.PLATFORM_NOT_FOUND_KHR, "no platforms")

    monkeypatch.setattr(cl, "get_platforms", none)
    monkeypatch.setattr(device_mod, "_DEVICES", {})
    with pytest.raises(InputError, match="pip install pocl-binary-distribution"):
        get_device()


def test_pocl_threads_are_pinned_when_the_cpus_allow():
    """get_device asked PoCL to pin its workers (this process may use CPUs 0..n-1): each of its
    threads is allowed one CPU, a different one each."""
    dev = get_device()
    if os.sched_getaffinity(0) != set(range(len(os.sched_getaffinity(0)))):
        pytest.skip("this process may not run on CPUs 0..n-1: nothing is pinned")
    if os.environ.get(device_mod.PIN_ENV, "1") != "1":
        pytest.skip(f"{device_mod.PIN_ENV} set by the user")   # pin_pocl_threads only sets "1"
    assert os.environ.get(device_mod.PIN_ENV) == "1" and dev.describe()["threads_pinned"]
    pinned = set()
    for status in Path("/proc/self/task").glob("*/status"):
        cpus = [l.split(":")[1].strip() for l in status.read_text().splitlines()
                if l.startswith("Cpus_allowed_list")][0]
        if cpus.isdigit():
            pinned.add(int(cpus))
    assert pinned == set(range(int(dev.device.max_compute_units)))


def test_pinning_respects_the_user_and_the_cpu_set(monkeypatch):
    monkeypatch.setenv(device_mod.PIN_ENV, "0")
    assert not device_mod.pin_pocl_threads() and os.environ[device_mod.PIN_ENV] == "0"
    monkeypatch.delenv(device_mod.PIN_ENV)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {2, 3})   # a cpuset off CPU 0
    assert not device_mod.pin_pocl_threads() and device_mod.PIN_ENV not in os.environ
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1})
    monkeypatch.setenv("POCL_MAX_PTHREAD_COUNT", "8")                     # more threads than CPUs
    assert not device_mod.pin_pocl_threads()
    monkeypatch.delenv("POCL_MAX_PTHREAD_COUNT")
    assert device_mod.pin_pocl_threads() and os.environ[device_mod.PIN_ENV] == "1"

"""PoCL's CPU-name patch: the level from CPU flags, and a patched copy of the real libpocl,
loaded through the ICD loader, builds and runs a kernel for it."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from runtime_cl.device import pocl_cpu

V3 = ["cx16", "lahf_lm", "popcnt", "sse4_1", "sse4_2", "ssse3", "avx", "avx2", "bmi1", "bmi2",
      "f16c", "fma", "abm", "movbe", "xsave"]
V4 = V3 + ["avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl"]


@pytest.mark.parametrize("flags, level", [
    (V4 + ["sha_ni"], "x86-64-v4"), (V3, "x86-64-v3"),
    ([f for f in V4 if f != "avx512vl"], None),   # PoCL would load its AVX-512 library: no level
    ([f for f in V3 if f != "movbe"], None),      # an AVX2 machine without all of v3
    (["fpu", "sse2", "avx"], None),               # no AVX2: LLVM 14 knows such CPUs itself
])
def test_level_matches_the_kernel_library_pocl_loads(flags, level):
    assert pocl_cpu.cpu_level(flags) == level


def test_host_flags_read_the_first_processor(tmp_path):
    info = tmp_path / "cpuinfo"
    info.write_text("processor\t: 0\nflags\t\t: fpu sse2 avx2\n\nprocessor\t: 1\nflags\t\t: fpu\n")
    assert pocl_cpu.host_flags(info) == ["fpu", "sse2", "avx2"]


@pytest.fixture(scope="module")
def pocl_original():
    """The libpocl this Python loads, unpatched (its saved original where it was patched)."""
    state = pocl_cpu.probe()
    assert state["library"], state
    lib = Path(state["library"])
    backup = pocl_cpu.backup_path(lib)
    return lib, (backup if backup.exists() else lib).read_bytes()


def test_installed_pocl_builds_kernels():
    """`make setup` leaves a PoCL that builds kernels (patched only where it had to be)."""
    state = pocl_cpu.probe()
    assert state["ok"], state["error"]


def test_patched_copy_runs_a_kernel_for_the_given_level(pocl_original, tmp_path):
    lib, data = pocl_original
    level = pocl_cpu.cpu_level(pocl_cpu.host_flags())
    if level is None:
        pytest.skip("not an AVX2/AVX-512 host: the patch does not apply here")
    patched = pocl_cpu.patch_bytes(data, level)
    assert pocl_cpu.patched_name(patched) == level
    assert pocl_cpu.patched_name(data) is None
    # The library's RPATH and data paths are relative to it: mirror the wheel's layout.
    libs = tmp_path / "pyopencl" / ".libs"
    libs.mkdir(parents=True)
    dist = lib.parent.parent.parent / "pocl_binary_distribution"
    (tmp_path / "pocl_binary_distribution").symlink_to(dist)
    copy = libs / "libpocl-test.so"
    copy.write_bytes(patched)
    (tmp_path / "test.icd").write_text(f"{copy}\n")
    code = ("import json, numpy as np, pyopencl as cl\n"
            "d = cl.get_platforms()[0].get_devices()[0]\n"
            "ctx = cl.Context([d]); q = cl.CommandQueue(ctx)\n"
            "p = cl.Program(ctx, '__kernel void k(__global float *a) "
            "{ int i = get_global_id(0); a[i] = sqrt((float)i); }').build()\n"
            "a = np.zeros(64, np.float32); b = cl.Buffer(ctx, cl.mem_flags.WRITE_ONLY, a.nbytes)\n"
            "p.k(q, a.shape, None, b); cl.enqueue_copy(q, a, b); q.finish()\n"
            "maps = [l.split()[-1] for l in open('/proc/self/maps') if 'libpocl' in l]\n"
            "print(json.dumps({'version': d.version, 'a': a.tolist(), 'libs': sorted(set(maps))}))\n")
    env = dict(os.environ, OCL_ICD_VENDORS=str(tmp_path), POCL_CACHE_DIR=str(tmp_path / "cache"))
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert run.returncode == 0, run.stderr[-3000:]
    out = json.loads(run.stdout.strip().splitlines()[-1])
    assert out["libs"] == [str(copy)]             # the copy, not the installed library
    assert out["version"].endswith(f"-{level}")
    assert out["a"] == pytest.approx([i ** 0.5 for i in range(64)], rel=1e-6)


def test_patch_refuses_code_it_does_not_know(pocl_original):
    _, data = pocl_original
    patched = pocl_cpu.patch_bytes(data, "x86-64-v3")
    with pytest.raises(ValueError, match="not the PoCL 3.0 code"):
        pocl_cpu.patch_bytes(patched, "x86-64-v3")          # already patched: not the original
    with pytest.raises(ValueError, match="has no 'znver9'"):
        pocl_cpu.patch_bytes(data, "znver9")


def test_patch_library_keeps_the_original_and_restores_it(pocl_original, tmp_path):
    _, data = pocl_original
    lib = tmp_path / "libpocl-copy.so"
    lib.write_bytes(data)
    pocl_cpu.patch_library(lib, "x86-64-v2")
    assert pocl_cpu.patched_name(lib.read_bytes()) == "x86-64-v2"
    assert pocl_cpu.backup_path(lib).read_bytes() == data
    assert pocl_cpu.restore_library(lib)
    assert lib.read_bytes() == data and not pocl_cpu.backup_path(lib).exists()
    assert not pocl_cpu.restore_library(lib)


@pytest.mark.parametrize("version, name", [
    ("OpenCL 3.0 PoCL HSTR: pthread-x86_64-unknown-linux-gnu-znver3", "znver3"),
    ("OpenCL 3.0 PoCL HSTR: pthread-x86_64-unknown-linux-gnu-x86-64-v4", "x86-64-v4"),
    ("OpenCL 3.0 PoCL", None), (None, None),
])
def test_built_cpu_reads_the_device_version(version, name):
    assert pocl_cpu.built_cpu(version) == name


def test_a_zen4_named_znver3_is_a_mismatch_on_an_avx512_host():
    """LLVM 14 calls a Zen 4 (family 25) znver3, without AVX-512, while PoCL loads its AVX-512
    library for the avx512f flag: seen here as INVALID_KERNEL_NAME from the polygon kernels."""
    state = {"ok": True, "device": "OpenCL 3.0 PoCL HSTR: pthread-x86_64-unknown-linux-gnu-znver3"}
    assert pocl_cpu.mismatch(state, V4) == "znver3"
    assert pocl_cpu.mismatch(state, V3) is None                       # AVX2 library: znver3 fits
    fixed = {"ok": True, "device": "OpenCL 3.0 PoCL HSTR: pthread-x86_64-unknown-linux-gnu-x86-64-v4"}
    assert pocl_cpu.mismatch(fixed, V4) is None
    assert pocl_cpu.mismatch({**state, "device": state["device"].replace("znver3", "icelake-server")}, V4) is None


def test_installed_pocl_builds_for_the_library_it_loads():
    """`make setup` leaves PoCL compiling for a CPU with the vector extension of its kernel library."""
    assert pocl_cpu.mismatch(pocl_cpu.probe(), pocl_cpu.host_flags()) is None

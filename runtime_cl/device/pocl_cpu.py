"""PoCL on a CPU its LLVM does not know (``python -m runtime_cl.device.pocl_cpu [--patch]``).

``pocl-binary-distribution`` 3.0, PyPI's only PoCL, links LLVM 14 into ``libpocl``. LLVM 14
calls a CPU newer than itself (AMD Zen 5, family 26, say) ``"generic"``, a name its own clang
rejects as a target CPU, so every kernel build fails with ``unknown target CPU 'generic'``;
PoCL 3.0 has no setting that names the CPU instead (its build options reject ``-target-cpu``).

``--patch`` rewrites two instructions of ``pocl_get_llvm_cpu_name`` in the libpocl this Python
loads: it always takes its empty-name branch, and that branch returns the x86-64 level of the
kernel library PoCL loads on this host (``x86-64-v4`` for its AVX-512 library, ``x86-64-v3``
for AVX2; names LLVM 14 knows, from its own string table). The function's bytes are checked
first against the PoCL 3.0 build this was written for (any other is refused); the file is
replaced atomically, the original kept beside it (``--restore`` puts it back). A CPU that
LLVM 14 knows builds kernels as it is, and nothing is patched -- unless LLVM 14 names it after
an older CPU without the vector extension of the kernel library PoCL loads: an AMD Zen 4 (family
25, like Zen 3) is ``znver3`` to LLVM 14, no AVX-512, while PoCL loads its AVX-512 library for
the host's ``avx512f`` flag. Kernels then build against the wrong vector ABI (some fail with
``INVALID_KERNEL_NAME``, others compute garbage), and ``--patch`` names the level here too
(:func:`mismatch`).
"""
from __future__ import annotations

import argparse
import io
import json
import os
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

from runtime_cl.atomic_file import atomic_path

__all__ = ["probe", "problem", "built_cpu", "mismatch", "cpu_level", "host_flags", "patch_bytes", "patched_name", "patch_library",
           "restore_library", "backup_path", "FIX"]

SYMBOL = "pocl_get_llvm_cpu_name"
FIX = f"{sys.executable} -m runtime_cl.device.pocl_cpu --patch"
UNKNOWN_CPU = "unknown target CPU"   # the build error of a CPU that LLVM 14 calls "generic"

# pocl_get_llvm_cpu_name of PoCL 3.0 (pocl-binary-distribution 3.0) as compiled, None where a
# rel32 displacement sits (call getHostCPUName/malloc/strncpy, lea of "generic"):
#   +0x06 call getHostCPUName; test rdx, rdx; je +0x40 (empty name)
#   +0x1a malloc(len + 1); strncpy; NUL; return
#   +0x40 mov edi, 8; mov ebx, 7; lea rbp, "generic"; jmp +0x1a
_ORIGINAL = (bytes.fromhex("55534883ec08e8"), None,
             bytes.fromhex("4885d274304889c54889d3488d7a01e8"), None,
             bytes.fromhex("4889da4889ee4889c7e8"), None,
             bytes.fromhex("c60418004883c4085b5dc30f1f840000000000"
                           "bf08000000bb07000000488d2d"), None, bytes.fromhex("ebc7"))
_JUMP = bytes.fromhex("eb38909090")
# LLVM 14's CPU names whose feature set includes AVX-512F (X86.td): the only names a host whose
# PoCL loads the avx512f kernel library may build for.
_AVX512_CPUS = frozenset({"knl", "knm", "skylake-avx512", "cascadelake", "cooperlake", "cannonlake",
                          "icelake-client", "icelake-server", "rocketlake", "tigerlake", "sapphirerapids",
                          "x86-64-v4"})  # at +0x06: jmp +0x40 (the empty-name branch), nops
# PoCL loads the kernel library built for the host's vector extension (avx512, avx2, ...; its
# own feature test), and the target CPU must have the same ones: code built for fewer passes
# vectors to that library in other registers and computes garbage (seen here with x86-64-v3 on
# an AVX-512 host). So the level mirrors PoCL's choice. CPUs newer than LLVM 14 (2022) all have
# AVX2; older ones LLVM 14 names itself.
_LEVELS = (  # (LLVM name, PoCL's library variant, /proc/cpuinfo flags the name assumes)
    ("x86-64-v4", "avx512f", ("avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl")),
    ("x86-64-v3", "avx2", ("avx", "avx2", "bmi1", "bmi2", "f16c", "fma", "abm", "movbe",
                           "xsave", "cx16", "lahf_lm", "popcnt", "sse4_1", "sse4_2", "ssse3")),
)
_PROBE = r"""
import json, pyopencl as cl
out = {"ok": False, "error": None, "library": None, "device": None}
try:
    devs = [d for p in cl.get_platforms() for d in p.get_devices()
            if "portable computing language" in p.name.lower()]
    if not devs:
        raise RuntimeError("no PoCL OpenCL platform; install it: pip install pocl-binary-distribution")
    dev = devs[0]
    out["device"] = dev.version
    ctx = cl.Context([dev])
    cl.Program(ctx, "__kernel void k(__global float *a) { a[0] = 1.0f; }").build()
    out["ok"] = True
except Exception as exc:
    out["error"] = str(exc)
with open("/proc/self/maps") as fh:
    libs = [l.split()[-1] for l in fh if "libpocl" in l and l.strip().endswith(".so")]
out["library"] = libs[0] if libs else None
print(json.dumps(out))
"""


def probe() -> dict:
    """Build a one-line kernel on PoCL in a fresh process (a patched library is only seen by a
    new process): ``{"ok", "error", "library" (path of the loaded libpocl), "device"}``."""
    with tempfile.TemporaryDirectory(prefix="pocl-probe-") as cache:   # a real build, not a hit
        run = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True,
                             env=dict(os.environ, POCL_CACHE_DIR=cache), timeout=300)
    if run.returncode != 0:
        return {"ok": False, "error": run.stderr.strip()[-2000:], "library": None, "device": None}
    return json.loads(run.stdout.strip().splitlines()[-1])


def built_cpu(device_version: str | None) -> str | None:
    """The CPU name PoCL compiles for, from its device version (``... HSTR: pthread-x86_64-
    unknown-linux-gnu-znver3``), None if the version does not say."""
    if not device_version or "HSTR:" not in device_version:
        return None
    parts = device_version.split("HSTR:", 1)[1].strip().split("-", 5)   # pthread-arch-vendor-os-env-cpu
    return parts[5].strip() if len(parts) == 6 and parts[5].strip() else None


def mismatch(state: dict, flags) -> str | None:
    """The CPU name PoCL builds for when it lacks AVX-512 on a host whose flags make PoCL load
    its AVX-512 kernel library (the vector ABIs differ), else None."""
    name = built_cpu(state.get("device"))
    if name is None or "avx512f" not in set(flags) or name in _AVX512_CPUS:
        return None
    return name


def problem(state: dict | None = None) -> str | None:
    """None when PoCL builds kernels right (``state`` from :func:`probe`, probed if not given),
    else one line saying why and what to do."""
    state = probe() if state is None else state
    if state["ok"]:
        wrong = mismatch(state, host_flags())
        if wrong is None:
            return None
        return (f"PoCL's LLVM 14 builds for {wrong!r}, a CPU without the AVX-512 of the kernel library it "
                f"loads on this host: kernels would fail or compute garbage; fix it: {FIX}")
    if UNKNOWN_CPU in (state["error"] or ""):
        return f"PoCL's LLVM 14 does not know this CPU, no kernel builds; fix it: {FIX}"
    return f"PoCL cannot build a kernel: {state['error']}"


def cpu_level(flags) -> str | None:
    """The x86-64 level that matches the kernel library PoCL picks for a host with ``flags``,
    None if it is neither an AVX-512 nor an AVX2 machine (or lacks a flag the level assumes)."""
    have = set(flags)
    for name, variant, need in _LEVELS:
        if variant in have:   # PoCL's pick; the level's other flags must be there too
            return name if set(need) <= have else None
    return None


def host_flags(cpuinfo: str = "/proc/cpuinfo") -> list[str]:
    """The ``flags`` of the first processor in ``cpuinfo``."""
    for line in Path(cpuinfo).read_text().splitlines():
        if line.startswith("flags"):
            return line.split(":", 1)[1].split()
    return []


def _segments(data: bytes):
    """The PT_LOAD segments ``(vaddr, offset, filesz, flags)`` of the ELF image ``data`` and the
    address of :data:`SYMBOL` in it (None when it has no such symbol)."""
    try:
        from elftools.elf.elffile import ELFFile
    except ImportError as exc:
        raise ValueError(f"patching needs pyelftools ({exc}): pip install pyelftools") from exc

    elf = ELFFile(io.BytesIO(data))
    loads = [(s["p_vaddr"], s["p_offset"], s["p_filesz"], s["p_flags"])
             for s in elf.iter_segments() if s["p_type"] == "PT_LOAD"]
    syms = elf.get_section_by_name(".dynsym")
    hits = syms.get_symbol_by_name(SYMBOL) if syms is not None else None
    return loads, (hits[0]["st_value"] if hits else None)


def _offset(loads, vaddr: int) -> int:
    for va, off, size, _ in loads:
        if va <= vaddr < va + size:
            return off + vaddr - va
    raise ValueError(f"address {vaddr:#x} is in no loaded segment")


def _vaddr(loads, offset: int) -> int:
    for va, off, size, _ in loads:
        if off <= offset < off + size:
            return va + offset - off
    raise ValueError(f"file offset {offset:#x} is in no loaded segment")


def _matches_original(code: bytes) -> bool:
    pos = 0
    for part in _ORIGINAL:
        if part is None:
            pos += 4
            continue
        if code[pos:pos + len(part)] != part:
            return False
        pos += len(part)
    return pos == 0x53


def patched_name(data: bytes) -> str | None:
    """The CPU name a patched library returns, None if ``data`` is not patched by us."""
    loads, func = _segments(data)
    if func is None:
        return None
    f = _offset(loads, func)
    code = data[f:f + 0x53]
    if code[6:11] != _JUMP or code[0x40] != 0xBF or code[0x45] != 0xBB:
        return None
    n = struct.unpack_from("<i", code, 0x46)[0]
    target = func + 0x51 + struct.unpack_from("<i", code, 0x4D)[0]
    at = _offset(loads, target)
    return data[at:at + n].decode("ascii", "replace")


def patch_bytes(data: bytes, name: str) -> bytes:
    """``data`` (a libpocl image) with ``pocl_get_llvm_cpu_name`` returning ``name``.

    Raises
    ------
    ValueError
        The library is not the PoCL 3.0 build this patch was written for, or LLVM's table has
        no ``name``.
    """
    loads, func = _segments(data)
    if func is None:
        raise ValueError(f"no symbol {SYMBOL}: not a PoCL library")
    f = _offset(loads, func)
    if not _matches_original(data[f:f + 0x53]):
        raise ValueError(f"{SYMBOL} is not the PoCL 3.0 code this patch knows; install "
                         "pocl-binary-distribution==3.0 or a PoCL whose LLVM knows this CPU")
    at = data.find(b"\0" + name.encode() + b"\0")   # LLVM's CPU table: NUL-delimited names
    if at < 0:
        raise ValueError(f"LLVM's CPU table in this libpocl has no {name!r}")
    target = _vaddr(loads, at + 1)
    out = bytearray(data)
    out[f + 6:f + 11] = _JUMP
    out[f + 0x40:f + 0x51] = (b"\xbf" + struct.pack("<i", len(name) + 1) + b"\xbb"
                              + struct.pack("<i", len(name)) + b"\x48\x8d\x2d"
                              + struct.pack("<i", target - (func + 0x51)))
    return bytes(out)


def backup_path(path) -> Path:
    """Where :func:`patch_library` keeps the unpatched library."""
    return Path(f"{path}.unpatched")


def _replace(path: Path, data: bytes, mode: int) -> None:
    with atomic_path(path, fsync=True, mode=mode) as tmp:
        tmp.write_bytes(data)


def patch_library(path, name: str) -> None:
    """Patch the libpocl file at ``path`` in place (temp file + rename, mode kept), keeping
    the original beside it (:func:`backup_path`) for :func:`restore_library`."""
    path = Path(path)
    data = path.read_bytes()
    new = patch_bytes(data, name)
    backup = backup_path(path)
    if not backup.exists():
        _replace(backup, data, path.stat().st_mode)
    _replace(path, new, path.stat().st_mode)


def restore_library(path) -> bool:
    """Put the unpatched library back; False if there is no backup."""
    path, backup = Path(path), backup_path(path)
    if not backup.exists():
        return False
    os.replace(backup, path)
    return True


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m runtime_cl.device.pocl_cpu", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    what = ap.add_mutually_exclusive_group()
    what.add_argument("--patch", action="store_true",
                      help="patch libpocl when its LLVM cannot name this CPU, or names one without the "
                           "AVX-512 of its kernel library (else only report)")
    what.add_argument("--restore", action="store_true",
                      help="put back the libpocl that --patch saved as <library>.unpatched")
    args = ap.parse_args(argv)
    state = probe()
    if args.restore:
        if state["library"] is None or not restore_library(state["library"]):
            print("nothing to restore: no patched libpocl with a saved original", file=sys.stderr)
            return 1
        print(f"restored {state['library']}")
        return 0
    wrong = mismatch(state, host_flags()) if state["ok"] else None
    if state["ok"] and wrong is None:
        print(f"PoCL builds kernels: {state['device']}")
        return 0
    error = state["error"] or ""
    if wrong is None and UNKNOWN_CPU not in error:
        print(problem(state), file=sys.stderr)
        return 1
    level = cpu_level(host_flags())
    if level is None:
        print("PoCL's LLVM 14 does not know this CPU, and it is no AVX2 or AVX-512 machine this "
              "patch can name; install a PoCL built with a newer LLVM", file=sys.stderr)
        return 1
    if not args.patch:
        why = (f"it builds for {wrong!r}, without the AVX-512 of its kernel library" if wrong else
               next(line.strip() for line in error.splitlines() if UNKNOWN_CPU in line))
        print(f"PoCL's LLVM 14 {'misnames' if wrong else 'does not know'} this CPU ({why}); "
              f"run `{FIX}` to make it use {level}", file=sys.stderr)
        return 1
    if state["library"] is None:
        print("PoCL fails to build but no loaded libpocl was found to patch", file=sys.stderr)
        return 1
    try:
        patch_library(state["library"], level)
    except (ValueError, OSError) as exc:
        print(f"{state['library']}: cannot patch: {exc}", file=sys.stderr)
        return 1
    after = probe()
    if not after["ok"] or mismatch(after, host_flags()):
        print(f"patched {state['library']} to {level}, but PoCL still fails: {after['error']}",
              file=sys.stderr)
        return 1
    print(f"patched {state['library']}: PoCL now compiles for {level} ({after['device']})")
    return 0


if __name__ == "__main__":
    sys.exit(main())

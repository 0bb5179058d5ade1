"""Check that Dr.Jit's LLVM backend found libLLVM >= 16 (``python -m lab.llvm_check``).

Dr.Jit 1.5 aborts with ``Cannot select ... fminimum`` on Debian's libLLVM 14/15.
Exit status 0 when usable, 1 with the install command otherwise.
"""
import sys

MIN_LLVM = 16
FIX = "apt-get install -y libllvm19  (or set DRJIT_LIBLLVM_PATH=/path/to/libLLVM.so before starting)"


def llvm_version():
    """Return Dr.Jit's LLVM version tuple, or None when the backend cannot load LLVM."""
    try:
        import drjit as dr

        version = tuple(dr.detail.llvm_version())
    except Exception:  # noqa: BLE001 - any failure here means "not usable"
        return None
    return version if version and version[0] > 0 else None


def problem():
    """Return None when Dr.Jit can use LLVM, else a one-line message with the fix."""
    version = llvm_version()
    if version is None:
        return f"Dr.Jit found no libLLVM; install it: {FIX}"
    if version[0] < MIN_LLVM:
        return f"Dr.Jit found LLVM {'.'.join(map(str, version))}, needs >= {MIN_LLVM}; install it: {FIX}"
    return None


def main():
    msg = problem()
    if msg:
        print(msg, file=sys.stderr)
        return 1
    print("Dr.Jit LLVM " + ".".join(map(str, llvm_version())))
    return 0


if __name__ == "__main__":
    sys.exit(main())

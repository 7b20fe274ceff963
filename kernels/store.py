"""The kernel cache's store: one folder per CPU and kernel source (cache_dir), entries
written whole or not at all (store), checked before they are loaded (verified), and a
lock that makes concurrent first runs compile each entry once (lock).  No Numba here.

An entry is two files: KEY.o, the object code, and KEY.json, its description (the
signature of kernels/signature.py, the symbols it imports, the code's size and sha256),
written last.  See docs/engines.md, "The compiled entries and the kernel cache".
"""

import functools
import hashlib
import json
import os
import sys
from pathlib import Path

from .signature import Signature

# Every source the compiled code can depend on: the workers with their Numba option sets
# (jit/) and what they import (the contract's constants, the signatures), so any change
# gives a new cache folder.
KERNEL_SOURCES = Path(__file__).parent
COMPILED_SOURCES = ("jit/*.py", "contract.py", "signature.py")


def cache_dir():
    """The kernel cache of this CPU and kernel source: CSW_KERNEL_CACHE, else
    NUMBA_CACHE_DIR/csw (the folder CI setups already keep between runs), else the user's
    cache folder; in a subfolder named by everything the machine code depends on."""
    root = os.environ.get("CSW_KERNEL_CACHE") or None  # set but empty: not set
    if root is None and os.environ.get("NUMBA_CACHE_DIR"):
        root = Path(os.environ["NUMBA_CACHE_DIR"]) / "csw"
    if root is None:
        base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
        root = Path(base) / "csw" / "kernels"
    return Path(root) / _fingerprint()


_FINGERPRINT = {}


def target_cpu():
    """The CPU the kernels are compiled for, as LLVM names it (znver1, skylake-avx512 ...):
    Numba's NUMBA_CPU_NAME when set to one, else this host's."""
    named = os.environ.get("NUMBA_CPU_NAME", "")
    if named and named != "host":
        return named
    import llvmlite.binding as llvm

    return llvm.get_host_cpu_name()


def compile_features():
    """The CPU features csw's kernels are compiled with, in NUMBA_CPU_FEATURES' form
    (kernels/compiler.py gives them to its compiles), or None for Numba's own: the
    user's NUMBA_CPU_FEATURES, or a NUMBA_CPU_NAME naming a CPU, are followed as they
    are.  Else, on an Intel CPU with AVX-512 with 16-bit lanes (AVX-512BW), the host's
    features less LLVM's "prefer-256-bit" tuning: LLVM vectorises loops 512 bits wide on
    AMD's Zen 4 (its znver names: None here, nothing to change) but 256 on every Intel
    AVX-512 CPU.  On a 2-core Intel Xeon (LLVM's rocketlake), csw's 8- and 16-bit loops
    so compiled were never slower than at 256 bits in alternating processes, and at
    times up to a tenth faster (a KITTI semi-global match on one thread: 88 against 93
    ms); the results are the same bit for bit."""
    named = os.environ.get("NUMBA_CPU_NAME", "")
    if os.environ.get("NUMBA_CPU_FEATURES") or (named and named != "host"):
        return None
    import llvmlite.binding as llvm

    features = llvm.get_host_cpu_features().flatten()
    if "+avx512bw" not in features.split(",") or llvm.get_host_cpu_name().startswith("znver"):
        return None
    return f"{features},-prefer-256-bit"


def _fingerprint():
    """A name for everything the compiled code depends on: the kernel sources, Python,
    Numba and llvmlite, the CPU, Numba's CPU settings and csw's (compile_features).
    Numba's version is read from its metadata: a warm run never imports Numba.  One
    llvmlite release serves several Numba releases, whose code generation differs."""
    if "value" not in _FINGERPRINT:
        import llvmlite
        import llvmlite.binding as llvm

        digest = hashlib.sha256()
        for path in sorted(p for pattern in COMPILED_SOURCES
                           for p in KERNEL_SOURCES.glob(pattern)):
            name = path.relative_to(KERNEL_SOURCES).as_posix()
            digest.update(name.encode() + b"\0" + path.read_bytes())
        for part in (sys.version, numba_version(), llvmlite.__version__,
                     llvm.get_host_cpu_name(),
                     llvm.get_host_cpu_features().flatten(),
                     os.environ.get("NUMBA_CPU_NAME", ""),
                     os.environ.get("NUMBA_CPU_FEATURES", ""),
                     os.environ.get("NUMBA_OPT", "")):
            digest.update(str(part).encode() + b"\0")
        features = compile_features()
        if features is not None:  # (a cache made without them keeps its folder)
            digest.update(features.encode() + b"\0")
        _FINGERPRINT["value"] = f"{llvm.get_host_cpu_name()}-{digest.hexdigest()[:16]}"
    return _FINGERPRINT["value"]


def numba_version():
    """Numba's installed version without importing Numba: from the name of its dist-info
    folder beside the package (a millisecond), else its metadata (importlib.metadata's
    search of every installed distribution took 60 ms of a warm run)."""
    import importlib.util

    spec = importlib.util.find_spec("numba")
    if spec is not None and spec.origin:
        found = sorted(Path(spec.origin).parent.parent.glob("numba-*.dist-info"))
        if len(found) == 1:
            return found[0].name[len("numba-"):-len(".dist-info")]
    from importlib.metadata import version

    return version("numba")


# Modes of the cache's folders and files, whatever the umask: machine code that other
# users could replace would run in every csw process that loads it.
FOLDER_MODE, FILE_MODE = 0o755, 0o644


def is_stored(folder, key):
    return (folder / f"{key}.json").is_file() and (folder / f"{key}.o").is_file()


def _safe_mode(path):
    """Whether ``path`` is not writable by the group or others."""
    return not os.stat(path).st_mode & 0o022


def verified(folder, key, found, discard=False):
    """Whether the entry ``key`` is complete and intact: its description reads, names its
    symbol and layout, its object file has the size and sha256 the description gives,
    and neither is writable by others.  The description goes into ``found``.  With
    ``discard`` (the caller holds the lock) a damaged entry is removed, to be compiled
    again."""
    if key in found:
        return True
    meta_path, code_path = folder / f"{key}.json", folder / f"{key}.o"
    try:
        meta = json.loads(meta_path.read_text())
        code = code_path.read_bytes()
        Signature.from_description(meta)  # raises on a description of another layout
        intact = (isinstance(meta, dict) and isinstance(meta.get("symbol"), str)
                  and isinstance(meta.get("arrays"), list)
                  and isinstance(meta.get("scalars"), list)
                  and isinstance(meta.get("imports"), list)
                  and meta.get("size") == len(code)
                  and meta.get("sha256") == hashlib.sha256(code).hexdigest()
                  and _safe_mode(folder) and _safe_mode(meta_path) and _safe_mode(code_path))
    except (OSError, ValueError, TypeError, KeyError):
        intact = False
    if intact:
        found[key] = meta
    elif discard:
        for path in (meta_path, code_path):
            path.unlink(missing_ok=True)
    return intact


def make_folder(folder):
    """``folder`` and its missing parents, each FOLDER_MODE whatever the umask."""
    folder = Path(folder)
    missing = []
    while not folder.is_dir():
        missing.append(folder)
        folder = folder.parent
    for path in reversed(missing):
        try:
            path.mkdir()
        except FileExistsError:
            continue
        os.chmod(path, FOLDER_MODE)


def store(folder, key, symbol, code):
    """Write the object file, then its description with the code's size and sha256: an
    entry is complete once its .json exists and matches, and both are renamed into
    place, so a killed compile leaves no entry and a damaged one is found."""
    meta, obj = code
    make_folder(folder)
    description = dict(meta, symbol=symbol, size=len(obj),
                       sha256=hashlib.sha256(obj).hexdigest())
    for suffix, payload in ((".o", obj), (".json", json.dumps(description).encode())):
        tmp = folder / f".{key}{suffix}.{os.getpid()}.tmp"
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, FILE_MODE)
        try:
            os.fchmod(fd, FILE_MODE)
            with os.fdopen(fd, "wb") as handle:
                handle.write(payload)
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            raise OSError(exc.errno, f"can't store a compiled kernel ({exc.strerror})",
                          str(folder)) from None
        os.replace(tmp, folder / f"{key}{suffix}")


class lock:
    """An exclusive lock on a file beside the entries (released by the system if the
    process dies); a no-op where the platform has no fcntl."""

    def __init__(self, folder):
        self.folder = folder

    def __enter__(self):
        try:
            make_folder(self.folder)
            if not _safe_mode(self.folder):  # made by an older csw under a loose umask
                os.chmod(self.folder, FOLDER_MODE)
            self.handle = open(os.open(self.folder / ".lock", os.O_RDWR | os.O_CREAT,
                                       FILE_MODE))
        except OSError as exc:  # the path alone would not say it is csw's kernel cache
            raise OSError(exc.errno, f"{exc.strerror}; it is csw's kernel cache: set "
                                     "CSW_KERNEL_CACHE to a writable folder",
                          str(self.folder)) from None
        try:
            import fcntl

            fcntl.flock(self.handle, fcntl.LOCK_EX)
        except ImportError:
            return self
        # Only the lock's holder writes entries: a temporary file now is a killed
        # compile's, and can go.
        for stale in self.folder.glob(".*.tmp"):
            stale.unlink(missing_ok=True)
        return self

    def __exit__(self, *exc):
        self.handle.close()  # closing releases the lock
        return False


@functools.cache  # a handful of variants, looked up on every call of an entry
def entry_key(kernel, variant):
    """The name of a variant's entry in the cache: the kernel and the variant's values."""
    return "-".join([kernel, *(str(int(v)) if isinstance(v, bool) else str(v)
                               for v in variant)])

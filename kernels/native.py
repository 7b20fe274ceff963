"""csw's compiled kernels: compiled once per CPU, then loaded without Numba.

Every kernel has a C-callable entry over raw arrays (see ``jit/``).  The first run that
needs an entry compiles it with Numba and stores its machine code as an object file in
the kernel cache; every later process loads that file with llvmlite (Numba's own code
generator, a small import) and calls the entry through ctypes, which releases the GIL so
that row stripes run in parallel threads.  ``import numba`` (about 0.3 s) and Numba's
cache lookups happen only when something must be compiled.

An entry is named by its kernel and its *variant*: the parameters fixed at compile time
(the cost, the pixel types, which optional maps it makes), so that a run compiles only
what it uses and each entry carries no code for the maps it does not make.

The cache (``cache_dir()``) is one folder per CPU, Python, llvmlite and kernel source:
any change of those gives a new folder, never a stale entry.  Entries are written to a
temporary file and renamed, and a lock beside them makes concurrent first runs compile
each entry once while the others wait.  The process holding the lock compiles what is
missing in worker processes, one per core, since Numba compiles on one.  With
``NUMBA_DISABLE_JIT=1`` the entries run as plain Python (for debugging and coverage),
with the same results.
"""

import ctypes
import functools
import hashlib
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from .signature import Signature, spec_of

JIT_DISABLED = os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0")
# Every source the compiled code can depend on: the workers and what they import (the
# Numba option sets, the contract's constants), so any change gives a new cache folder.
KERNEL_SOURCES = Path(__file__).parent
COMPILED_SOURCES = ("jit/*.py", "config.py", "contract.py", "signature.py")

# Seconds Numba takes to compile each kernel's entry on the machines csw was measured on
# (2-core AMD EPYC); the notice before a compile sums them for what is missing.
COMPILE_SECONDS = {"fast": 4.0, "window": 1.5, "census": 1.0, "filters": 0.8}
START_SECONDS = 1.0  # importing Numba and its first compile's set-up

# What happened in this process: entries loaded from the cache, and entries compiled.
STATS = {"loaded": 0, "compiled": 0, "compile_seconds": 0.0, "load_seconds": 0.0}


class Entry:
    """A loaded kernel entry: ``entry(**arguments)`` runs it, every array and scalar of
    its signature (kernels/signature.py) by name.  Arrays: C-contiguous numpy arrays of
    the signature's dtypes and dimensions; scalars: ints."""

    def __init__(self, key, signature, function, worker=None):
        self.key, self.signature, self.function = key, signature, function
        self.worker = worker  # the plain-Python worker, with the JIT off

    def __call__(self, **arguments):
        arrays, scalars = self.signature.ordered(arguments, self.key)
        for array, a in zip(arrays, self.signature.arrays, strict=True):
            if array.dtype != a.dtype or array.ndim != a.ndim or not array.flags.c_contiguous:
                raise TypeError(f"kernel {self.key}: {a.name} must be C-contiguous {a.dtype} "
                                f"with {a.ndim} dimensions, got {array.dtype} {array.shape}")
        if self.function is None:  # NUMBA_DISABLE_JIT: the worker is plain Python
            return int(self.worker(*arrays, np.array(scalars, np.int64)))
        pointers = (ctypes.c_void_p * max(len(arrays), 1))(*map(_address, arrays))
        dims = [d for a in arrays for d in a.shape]
        dims = (ctypes.c_int64 * max(len(dims), 1))(*dims)
        values = (ctypes.c_int64 * max(len(scalars), 1))(*(int(v) for v in scalars))
        return self.function(pointers, dims, values)


def _address(array):
    """The address of a C-contiguous array's data.  Through ctypes' view of its buffer it
    takes about 0.3 us, where ``array.ctypes.data`` takes 1 to 1.6 (an entry takes up to
    16 arrays, a default match makes six calls); read-only and empty arrays, which that
    view refuses, take the slow way."""
    try:
        return ctypes.addressof(ctypes.c_char.from_buffer(array))
    except (TypeError, ValueError):
        return array.ctypes.data


_LOADED = {}  # key -> Entry, in this process
_ENGINES = []  # llvmlite execution engines, kept alive with the code they hold
_NOTICE = {"shown": False}


def notify(message):
    """Say something about compiling on stderr (the CLI and notebooks alike see it)."""
    print(message, file=sys.stderr, flush=True)


def entry(kernel, variant):
    """The entry of ``kernel`` for ``variant`` (a tuple of str/int/bool), loaded from the
    cache or compiled into it."""
    key = entry_key(kernel, variant)
    if key not in _LOADED:
        ensure([(kernel, variant)])
    return _LOADED[key]


@functools.cache  # a handful of variants, looked up on every call of an entry
def entry_key(kernel, variant):
    return "-".join([kernel, *(str(int(v)) if isinstance(v, bool) else str(v)
                               for v in variant)])


def ensure(wanted, progress=None, notice=True):
    """Load every (kernel, variant) of ``wanted``, compiling the missing ones first (one
    notice on stderr when that takes more than about a second); return the seconds
    spent.  Concurrent processes compile each entry once: the others wait for it.
    progress(key, compiled): called for each entry as it is compiled (True) or found.
    notice: say on stderr when a compile is ahead (off for a caller that shows progress)."""
    start = time.perf_counter()
    wanted = [(k, tuple(v)) for k, v in dict.fromkeys((k, tuple(v)) for k, v in wanted)]
    todo = [(k, v) for k, v in wanted if entry_key(k, v) not in _LOADED]
    if not todo:
        return 0.0
    if JIT_DISABLED:
        for kernel, variant in todo:
            spec = spec_of(kernel, variant)
            _LOADED[entry_key(kernel, variant)] = Entry(entry_key(kernel, variant),
                                                        spec.signature, None, spec.worker)
        return time.perf_counter() - start
    folder = cache_dir()
    found = {}  # key -> its verified description
    missing = [(k, v) for k, v in todo if not _verified(folder, entry_key(k, v), found)]
    if missing:
        with _lock(folder):  # another process may be compiling them: wait, then look again
            missing = [(k, v) for k, v in missing
                       if not _verified(folder, entry_key(k, v), found, discard=True)]
            if missing:
                _compile(folder, missing, progress, notice)
            for kernel, variant in missing:
                if not _verified(folder, entry_key(kernel, variant), found):
                    raise RuntimeError(f"csw could not store the kernel "
                                       f"{entry_key(kernel, variant)} in {folder}")
    loading = time.perf_counter()
    for kernel, variant in todo:
        key = entry_key(kernel, variant)
        _LOADED[key] = Entry(key, Signature.from_description(found[key]),
                             _load(folder, key, found[key]))
        STATS["loaded"] += 1
        if progress is not None and (kernel, variant) not in missing:
            progress(key, False)
    STATS["load_seconds"] += time.perf_counter() - loading
    return time.perf_counter() - start


def _compile(folder, missing, progress=None, notice=True):
    from .runtime import cores

    shares = _shares(missing, min(len(missing), cores()))
    estimate = START_SECONDS + max(sum(COMPILE_SECONDS.get(k, 1.0) for k, _ in share)
                                   for share in shares)
    if notice and estimate >= 1.0 and not _NOTICE["shown"]:
        _NOTICE["shown"] = True
        notify(f"csw: compiling csw's kernels for this CPU, once: about {estimate:.0f} s "
               f"(later runs load them from {folder})")
    if len(shares) > 1:
        missing = _compile_in_processes(folder, missing, shares, progress)
    for kernel, variant in missing:  # all of them on one core, or what the others left
        from .jit import build

        start = time.perf_counter()
        key = entry_key(kernel, variant)
        symbol, code = build.compile_entry(kernel, variant)
        _store(folder, key, symbol, code)
        STATS["compiled"] += 1
        STATS["compile_seconds"] += time.perf_counter() - start
        if progress is not None:
            progress(key, True)


# A compile worker: a Python process of its own (nothing of the caller's program is
# imported in it, unlike a multiprocessing child) that compiles the entries named on its
# command line into the folder given, in order.
_WORKER = ("import json, sys; from {package} import native; "
           "native._compile_here(sys.argv[1], json.loads(sys.argv[2]), int(sys.argv[3]))")


def _shares(missing, workers):
    """``missing`` dealt to ``workers`` (at least one) processes, the longest entries
    first, each to the process with the least estimated time so far."""
    shares = [[] for _ in range(max(workers, 1))]
    loads = [0.0] * len(shares)
    for kernel, variant in sorted(missing, key=lambda e: -COMPILE_SECONDS.get(e[0], 1.0)):
        i = loads.index(min(loads))
        shares[i].append((kernel, variant))
        loads[i] += COMPILE_SECONDS.get(kernel, 1.0)
    return shares


def _compile_in_processes(folder, missing, shares, progress=None):
    """Compile ``missing`` in one process per share (see _shares), all at once: Numba
    compiles on one core.  The caller holds the cache's lock.  Returns the entries still
    missing (a worker failed), for the caller to compile here, where an error shows as
    it is."""
    import subprocess

    start = time.perf_counter()
    code = _WORKER.format(package=__package__)
    # -P: no current folder on the workers' path, where a folder named like the package
    # (a source checkout) could hand them other kernel sources than this process's,
    # compiled into this process's cache under its fingerprint.
    procs = [subprocess.Popen([sys.executable, "-P", "-c", code, str(folder),
                               json.dumps([(k, list(v)) for k, v in share]),
                               str(os.getpid())],
                              stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL) for share in shares]
    reported = set()
    try:
        while True:
            running = [p for p in procs if p.poll() is None]
            for kernel, variant in missing:  # progress as each entry lands
                key = entry_key(kernel, variant)
                if key not in reported and _stored(folder, key):
                    reported.add(key)
                    if progress is not None:
                        progress(key, True)
            if not running:
                break
            time.sleep(0.05)
    finally:
        for proc in procs:  # a Ctrl-C here stops the workers too
            if proc.poll() is None:
                proc.kill()
            proc.wait()
    left = [(k, v) for k, v in missing if not _stored(folder, entry_key(k, v))]
    STATS["compiled"] += len(missing) - len(left)
    STATS["compile_seconds"] += time.perf_counter() - start
    return left


def _compile_here(folder, share, parent):
    """A compile worker's job: compile each (kernel, variant) of ``share`` into
    ``folder``; stop if the process ``parent`` that started it dies (it holds the lock:
    without it, the next holder may be compiling the same entries)."""
    try:  # Linux: be killed with the parent (PR_SET_PDEATHSIG = 1, SIGKILL = 9)
        ctypes.CDLL(None, use_errno=True).prctl(1, 9)
    except (AttributeError, OSError):
        pass
    if os.getppid() != parent:  # it died before that took hold
        return
    from .jit import build

    for kernel, variant in share:
        variant = tuple(variant)
        symbol, code = build.compile_entry(kernel, variant)
        _store(Path(folder), entry_key(kernel, variant), symbol, code)


# ---------------------------------------------------------------------------- the cache


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


def _fingerprint():
    """A name for everything the compiled code depends on: the kernel sources, Python,
    llvmlite (which fixes Numba's version), the CPU and Numba's CPU settings."""
    if "value" not in _FINGERPRINT:
        import llvmlite
        import llvmlite.binding as llvm

        digest = hashlib.sha256()
        for path in sorted(p for pattern in COMPILED_SOURCES
                           for p in KERNEL_SOURCES.glob(pattern)):
            name = path.relative_to(KERNEL_SOURCES).as_posix()
            digest.update(name.encode() + b"\0" + path.read_bytes())
        for part in (sys.version, llvmlite.__version__, llvm.get_host_cpu_name(),
                     llvm.get_host_cpu_features().flatten(),
                     os.environ.get("NUMBA_CPU_NAME", ""),
                     os.environ.get("NUMBA_CPU_FEATURES", ""),
                     os.environ.get("NUMBA_OPT", "")):
            digest.update(str(part).encode() + b"\0")
        _FINGERPRINT["value"] = f"{llvm.get_host_cpu_name()}-{digest.hexdigest()[:16]}"
    return _FINGERPRINT["value"]


# Modes of the cache's folders and files, whatever the umask: machine code that other
# users could replace would run in every csw process that loads it.
FOLDER_MODE, FILE_MODE = 0o755, 0o644


def _stored(folder, key):
    return (folder / f"{key}.json").is_file() and (folder / f"{key}.o").is_file()


def _safe_mode(path):
    """Whether ``path`` is not writable by the group or others."""
    return not os.stat(path).st_mode & 0o022


def _verified(folder, key, found, discard=False):
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
        intact = (isinstance(meta, dict) and isinstance(meta.get("symbol"), str)
                  and isinstance(meta.get("arrays"), list)
                  and isinstance(meta.get("scalars"), list)
                  and isinstance(meta.get("imports"), list)
                  and meta.get("size") == len(code)
                  and meta.get("sha256") == hashlib.sha256(code).hexdigest()
                  and Signature.from_description(meta) is not None
                  and _safe_mode(folder) and _safe_mode(meta_path) and _safe_mode(code_path))
    except (OSError, ValueError, TypeError):
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


def _store(folder, key, symbol, code):
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


class _lock:
    """An exclusive lock on a file beside the entries (released by the system if the
    process dies); a no-op where the platform has no fcntl."""

    def __init__(self, folder):
        self.folder = folder

    def __enter__(self):
        make_folder(self.folder)
        if not _safe_mode(self.folder):  # made by an older csw under a loose umask
            os.chmod(self.folder, FOLDER_MODE)
        self.handle = open(os.open(self.folder / ".lock", os.O_RDWR | os.O_CREAT, FILE_MODE))
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


def _load(folder, key, meta):
    """The ctypes function of a stored entry (``meta``: its verified description),
    through an llvmlite execution engine."""
    import llvmlite.binding as llvm

    if not _ENGINES:
        llvm.initialize_native_target()
        llvm.initialize_native_asmprinter()
    _resolve([*meta["imports"], "memset", "memcpy", "memmove"])
    target = llvm.Target.from_default_triple().create_target_machine(
        cpu=llvm.get_host_cpu_name(), features=llvm.get_host_cpu_features().flatten(),
        opt=3, jit=True)
    engine = llvm.create_mcjit_compiler(llvm.parse_assembly(""), target)
    engine.add_object_file(llvm.ObjectFileRef.from_data((folder / f"{key}.o").read_bytes()))
    engine.finalize_object()
    _ENGINES.append(engine)
    address = engine.get_function_address(meta["symbol"])
    if not address:
        raise RuntimeError(f"csw's kernel cache entry {folder / key} is damaged; delete "
                           f"{folder} and run again")
    c_pointers = ctypes.POINTER(ctypes.c_void_p)
    c_ints = ctypes.POINTER(ctypes.c_int64)
    return ctypes.CFUNCTYPE(ctypes.c_int64, c_pointers, c_ints, c_ints)(address)


def _resolve(names):
    """Give the execution engine the address of every symbol an entry's code uses from
    outside it: the C library's (memset ...) and Python's from this process.  Numba's
    runtime helpers are not loaded without Numba: they serve only the paths that report
    an exception, which csw's kernels never take (no checks, numpy's error model), so
    they point at abort(), and a kernel bug stops the process at once."""
    import llvmlite.binding as llvm

    process = ctypes.CDLL(None)
    for name in names:
        if llvm.address_of_symbol(name):
            continue
        found = getattr(process, name, None) if not name.startswith(("numba_", "NRT_")) \
            else None
        llvm.add_symbol(name, ctypes.cast(found or process.abort, ctypes.c_void_p).value)


def clear():
    """Forget the entries loaded in this process (tests: to load them again)."""
    _LOADED.clear()

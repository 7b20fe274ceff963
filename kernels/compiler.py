"""Compiling missing kernel entries with Numba, under the cache's lock: in one worker
process per core (Numba compiles on one), each a Python of its own that imports nothing
of the caller's program, or here when only one is missing or a worker failed.  Where
csw compiles with CPU features of its own (kernels/store.py:compile_features), every
entry is compiled by a worker, whose environment carries them: this process's Numba
may have made its code generator before, with its own."""

import ctypes
import json
import os
import subprocess
import sys
import time
from pathlib import Path

from .catalogue import compile_seconds
from .store import compile_features, entry_key, is_stored, store

# Each kernel's compile takes the seconds its catalogue row gives (kernels/catalogue.py),
# measured on the 2-core AMD EPYC csw is measured on, shared with other work as a CI
# runner is: 15 entries of `csw compile --preset accurate` took 99 s there (2026-12-03),
# a default first run 20-55 s, where an idle core's times (fast 4, window 1.5, census 1,
# filters 0.8) had the notice say "about 7 s".  The notice before a compile sums them
# for what is missing.
START_SECONDS = 3.0  # importing Numba and its first compile's set-up

_NOTICE = {"shown": False}


def notify(message):
    """Say something about compiling on stderr (the CLI and notebooks alike see it)."""
    print(message, file=sys.stderr, flush=True)


def compile_missing(folder, missing, progress=None, notice=True):
    """Compile every (kernel, variant) of ``missing`` into ``folder`` (the caller holds
    the cache's lock); one notice on stderr first, once per process, when it will take a
    second or more.  progress(key, True) as each entry lands.  Returns how many it
    compiled."""
    from .runtime import cores

    shares = _shares(missing, min(len(missing), cores()))
    estimate = START_SECONDS + max(sum(compile_seconds(k) for k, _ in share)
                                   for share in shares)
    if notice and estimate >= 1.0 and not _NOTICE["shown"]:
        _NOTICE["shown"] = True
        notify(f"csw: compiling csw's kernels for this CPU, once: about {estimate:.0f} s "
               f"(later runs load them from {folder})")
    count = len(missing)
    if len(shares) > 1 or compile_features() is not None:
        missing = _compile_in_processes(folder, missing, shares, progress)
    # All of them on one core, or what a worker left (here its error shows).  An entry
    # compiled here takes this process's CPU features: maybe narrower, as exact.
    for kernel, variant in missing:
        from .jit import build

        key = entry_key(kernel, variant)
        symbol, code = build.compile_entry(kernel, variant)
        store(folder, key, symbol, code)
        if progress is not None:
            progress(key, True)
    return count


# A compile worker: a Python process of its own (nothing of the caller's program is
# imported in it, unlike a multiprocessing child) that compiles the entries named on its
# command line into the folder given, in order.
_WORKER = ("import json, sys; from {package} import compiler; "
           "compiler.compile_here(sys.argv[1], json.loads(sys.argv[2]), int(sys.argv[3]))")


def _shares(missing, workers):
    """``missing`` dealt to ``workers`` (at least one) processes, the longest entries
    first, each to the process with the least estimated time so far."""
    shares = [[] for _ in range(max(workers, 1))]
    loads = [0.0] * len(shares)
    for kernel, variant in sorted(missing, key=lambda e: -compile_seconds(e[0])):
        i = loads.index(min(loads))
        shares[i].append((kernel, variant))
        loads[i] += compile_seconds(kernel)
    return shares


def _compile_in_processes(folder, missing, shares, progress=None):
    """Compile ``missing`` in one process per share (see _shares), all at once: Numba
    compiles on one core.  Their environment names csw's CPU features
    (compile_features).  The caller holds the cache's lock.  Returns the entries still
    missing (a worker failed), for the caller to compile here, where an error shows as
    it is."""
    code = _WORKER.format(package=__package__)
    features = compile_features()
    env = None if features is None else dict(os.environ, NUMBA_CPU_FEATURES=features)
    # -P: no current folder on the workers' path, where a folder named like the package
    # (a source checkout) could hand them other kernel sources than this process's,
    # compiled into this process's cache under its fingerprint.
    procs = [subprocess.Popen([sys.executable, "-P", "-c", code, str(folder),
                               json.dumps([(k, list(v)) for k, v in share]),
                               str(os.getpid())],
                              stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, env=env) for share in shares]
    reported = set()
    try:
        while True:
            running = [p for p in procs if p.poll() is None]
            for kernel, variant in missing:  # progress as each entry lands
                key = entry_key(kernel, variant)
                if key not in reported and is_stored(folder, key):
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
    return [(k, v) for k, v in missing if not is_stored(folder, entry_key(k, v))]


def compile_here(folder, share, parent):
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
        store(Path(folder), entry_key(kernel, variant), symbol, code)

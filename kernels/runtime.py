"""Running kernel entries in parallel: the drivers hand their stripes of rows to a pool of
threads (an entry called through ctypes releases the GIL), each stripe with its own
scratch, and stop them within a row on Ctrl-C.  No Numba here."""

import os
import threading
from concurrent.futures import FIRST_EXCEPTION, ThreadPoolExecutor, wait

import numpy as np

# Runs smaller than this (in pixel-disparity-window operations: about 10 ms) run in the
# calling thread, as one stripe: starting threads would cost a few percent of them, and
# a Ctrl-C waits no longer than the run itself.
DIRECT_WORK = 50_000_000

# A run under this much work (about 100 ms) runs its last stripe in the calling thread
# while the pool runs the others: the pool's hand-off of that stripe and the wake at the
# run's end, a few tenths of a millisecond, are saved on each of a match's steps.  A
# Ctrl-C waits for that stripe: at most about 100 ms on one thread, 50 on two.
INLINE_WORK = 10 * DIRECT_WORK


_CORES = {}  # pid -> cores: a system call per run cost about 20 us of a frame's overhead


def cores():
    """The cores this process may run on (read once per process: a change of affinity
    after the first run is not followed)."""
    pid = os.getpid()
    if pid not in _CORES:
        try:
            _CORES[pid] = len(os.sched_getaffinity(0))
        except AttributeError:  # not Linux
            _CORES[pid] = os.cpu_count() or 1
    return _CORES[pid]


def max_threads():
    """The threads csw may use: NUMBA_NUM_THREADS where set (Dask workers set it to share
    the cores between them), else cores()."""
    value = os.environ.get("NUMBA_NUM_THREADS", "").strip()
    if value:
        try:
            count = int(value)
        except ValueError:
            count = 0
        if count < 1:
            error = ValueError(f"NUMBA_NUM_THREADS must be a whole number of threads, at "
                               f"least 1, got {value[:40]!r}")
            error.variable = "NUMBA_NUM_THREADS"
            raise error
        return count
    return cores()


_DEFAULT = {"threads": None}


class default_threads:
    """Within a ``with``, runs that don't say how many threads use ``n`` (scripts that
    time everything on one thread)."""

    def __init__(self, n):
        self.n = thread_count(n)

    def __enter__(self):
        self.previous, _DEFAULT["threads"] = _DEFAULT["threads"], self.n
        return self

    def __exit__(self, *exc):
        _DEFAULT["threads"] = self.previous
        return False


def thread_count(threads):
    """The number of threads for a run: ``threads`` checked, or the default (all)."""
    limit = max_threads()
    if threads is None:
        return _DEFAULT["threads"] or limit
    if isinstance(threads, bool) or int(threads) != threads or not 1 <= threads <= limit:
        raise ValueError(f"threads must be between 1 and {limit}, got {threads}")
    return int(threads)


# (pid, name, size) -> ThreadPoolExecutor: a forked child has the object, not threads.
_POOLS = {}


def kept_pool(size, name="csw-kernel"):
    """This process's pool of ``size`` threads called ``name``, made once and kept: a
    thread keeps its scratch from run to run (kernels/workspace.py).  The row stripes'
    pool is "csw-kernel"; a stream's frames have their own ("csw-frame"), since a
    frame's own stripes may come here."""
    key = (os.getpid(), name, size)
    if key not in _POOLS:
        _POOLS[key] = ThreadPoolExecutor(max_workers=size, thread_name_prefix=name)
    return _POOLS[key]


def run_stripes(task, count, threads, work, direct_work=DIRECT_WORK):
    """Run ``task(i, stop)`` for i in range(count) (stripe i of a run), ``threads`` at a
    time, and return their results in order.

    stop: uint8 (1,), the flag every entry checks before each row.  Python acts on a
    Ctrl-C only in the main thread and between bytecodes, never inside an entry, so the
    stripes run in the pool's threads while this thread waits: on a Ctrl-C it sets the
    flag, the stripes return within a row, and the interrupt is raised again here.
    work: the run's size; a run under direct_work runs in the calling thread, as does a
    run on one thread asked for from a thread other than the main one; a run under
    INLINE_WORK runs its last stripe there.
    """
    stop = new_stop_flag()
    if work < direct_work or (threads == 1 and
                              threading.current_thread() is not threading.main_thread()):
        # One thread asked for by a thread that is not the main one (a stream's frames
        # side by side): run here, since the frames would otherwise queue for the one
        # pool thread of size 1; only the main thread sees a Ctrl-C, and it stops
        # starting frames.
        return [task(i, stop) for i in range(count)]
    inline = count <= threads and work < INLINE_WORK
    futures = [kept_pool(threads).submit(task, i, stop) for i in range(count - inline)]
    try:
        last = [task(count - 1, stop)] if inline else []
        pending = futures
        while pending:
            done, pending = wait(pending, timeout=0.05, return_when=FIRST_EXCEPTION)
            for future in done:
                future.result()  # raises a stripe's error at once
    except BaseException:
        stop[0] = 1
        wait(futures)
        raise
    return [future.result() for future in futures] + last


def even_split(n, count):
    """int64 (count + 1,): the edges of ``count`` near-equal parts of 0..n (stripes of
    rows); one part without np.linspace, which costs about 8 us a call."""
    if count == 1:
        return np.array([0, n], np.int64)
    return np.linspace(0, n, count + 1).round().astype(np.int64)


def new_stop_flag():
    """The stop flag of a run: uint8 (1,), 0 until the run is to stop."""
    return np.zeros(1, np.uint8)

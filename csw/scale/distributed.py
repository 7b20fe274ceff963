"""Dask clusters for csw: a local one started for a batch, or an existing one by address.

Dask is an optional extra (``pip install 'csw-stereo[dask]'``); only this module and the
executor (csw.scale.executor, given a client) import it.
Each worker is a process with one task thread; Numba's threads are split so that the
workers together use the machine's cores once.
"""

import contextlib
import logging
import os


def _dask():
    try:
        import dask.distributed as distributed
    except ImportError:
        raise ImportError("running on a cluster needs Dask: pip install 'csw-stereo[dask]' "
                          "(from a checkout: '.[dask]')") from None
    return distributed


def local_client(workers):
    """A Client on a cluster of ``workers`` processes on this machine, bound to
    127.0.0.1 (its dashboard too, on a free port), each with cores // workers Numba
    threads.  The scheduler runs in a process of its own too (Dask's SubprocessCluster):
    in this process, as LocalCluster puts it, its bookkeeping grew this process's memory
    by about 0.8 KB a task (15 MB over 20,000 pairs), where a batch must run in flat
    memory."""
    distributed = _dask()
    workers = int(workers)
    if not 1 <= workers <= 256:
        raise ValueError(f"workers must be from 1 to 256, got {workers}")
    threads = max(1, (os.cpu_count() or 1) // workers)
    from distributed.deploy.subprocess import SubprocessCluster

    cluster = SubprocessCluster(
        n_workers=workers, threads_per_worker=1, host="127.0.0.1",
        dashboard_address="127.0.0.1:0",
        worker_kwargs={"env": {"NUMBA_NUM_THREADS": str(threads)}},
        # csw reports failures itself; Dask's warnings (tasks cancelled on Ctrl-C, a
        # restarted worker) would only add lines to the user's terminal.
        silence_logs=logging.ERROR)
    client = distributed.Client(cluster)
    client.wait_for_workers(workers, timeout=120)
    return client


def remote_client(address, timeout=10):
    """A Client on the scheduler at ``address``; ValueError, one line, if unreachable."""
    distributed = _dask()
    try:
        return distributed.Client(address, timeout=f"{timeout}s")
    except Exception as exc:  # noqa: BLE001 (Dask raises many types: TLS settings missing ...)
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ValueError(f"can't reach the Dask scheduler at {address} ({reason[:120]})") \
            from None


def close(client):
    """Close a client and, for a local one, its cluster."""
    cluster = getattr(client, "cluster", None)
    client.close()
    if cluster is not None:
        cluster.close()


@contextlib.contextmanager
def cluster(workers=None, scheduler=None):
    """A Client for the duration of a ``with``: None with neither argument (run here), a
    local cluster of ``workers`` processes, or the scheduler at address ``scheduler``;
    closed (the local cluster with it) at the end.  ValueError for both at once."""
    if workers is not None and scheduler is not None:
        raise ValueError("give workers (a cluster on this machine) or a scheduler address "
                         "(an existing one), not both")
    if workers is None and scheduler is None:
        yield None
        return
    from ..config.params import OptionError

    try:
        client = remote_client(scheduler) if scheduler is not None else local_client(workers)
    except ValueError as exc:
        raise OptionError("scheduler" if scheduler is not None else "workers", str(exc)) \
            from None
    try:
        yield client
    finally:
        close(client)

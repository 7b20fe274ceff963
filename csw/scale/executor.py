"""The one way csw runs many tasks: here one after another or side by side in threads, or
as tasks on a Dask client.
Batches (many pairs) and row stripes (one big pair) both go through :func:`run_tasks`,
so they share cancellation, ordering and progress.
"""

import itertools

# Tasks on a cluster's queue per worker thread: enough that no worker waits for the
# next one, few enough that a million-pair batch holds a few dozen tasks at a time.
IN_FLIGHT_PER_THREAD = 4


def run_tasks(function, tasks, client=None, in_flight=None, side_by_side=1, **kwargs):
    """Yield ``(index, function(task, **kwargs))`` for every task, as each finishes.

    client: None to run here: in order, or ``side_by_side`` tasks at a time in threads
    of this process (tasks whose work releases the GIL: csw's kernels); or a
    ``dask.distributed.Client``, whose workers run the tasks (a worker that dies has its
    tasks rerun elsewhere).  On a cluster at most ``in_flight`` tasks (default:
    IN_FLIGHT_PER_THREAD per worker thread) are submitted at a time, and one more as
    each finishes, so that the client, the scheduler and this process hold a bounded
    number of tasks however many there are.  ``tasks`` may be any iterable.  An error,
    or a Ctrl-C in the caller, cancels the tasks not yet started or not yet finished on
    the cluster (tasks running in threads here finish first).
    """
    if client is None and side_by_side > 1:
        yield from _in_threads(function, tasks, side_by_side, kwargs)
        return
    if client is None:
        for index, task in enumerate(tasks):
            yield index, function(task, **kwargs)
        return
    from dask.distributed import as_completed

    limit = in_flight or IN_FLIGHT_PER_THREAD * max(1, sum(client.nthreads().values()))
    pending = enumerate(tasks)
    futures = {}  # the tasks in flight: future -> index
    running = as_completed()

    def submit(count):
        for index, task in itertools.islice(pending, count):
            future = client.submit(function, task, pure=False, **kwargs)
            futures[future] = index
            running.add(future)

    try:
        submit(limit)
        for future in running:
            index = futures.pop(future)
            result = future.result()
            future.release()
            submit(1)
            yield index, result
    finally:
        client.cancel(list(futures))


def _in_threads(function, tasks, threads, kwargs):
    """run_tasks here, ``threads`` tasks at a time, two waiting per thread at most."""
    from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

    pending = enumerate(tasks)
    running = {}  # future -> index
    pool = ThreadPoolExecutor(threads, thread_name_prefix="csw-pair")

    def submit(count):
        for index, task in itertools.islice(pending, count):
            running[pool.submit(function, task, **kwargs)] = index

    try:
        submit(2 * threads)
        while running:
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            for future in done:
                index = running.pop(future)
                yield index, future.result()
                submit(1)
    finally:
        for future in running:
            future.cancel()
        pool.shutdown(wait=True)

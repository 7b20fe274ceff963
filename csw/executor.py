"""The one way csw runs many tasks: here one after another, or as tasks on a Dask client.
Batches (many pairs) and row stripes (one big pair) both go through :func:`run_tasks`,
so they share cancellation, ordering and progress.
"""

import sys


def run_tasks(function, tasks, client=None, **kwargs):
    """Yield ``(index, function(task, **kwargs))`` for every task, as each finishes.

    client: None to run here, in order; or a ``dask.distributed.Client``, whose workers
    run the tasks (a worker that dies has its tasks rerun elsewhere).  An error, or a
    Ctrl-C in the caller, cancels the tasks not yet finished on the cluster.
    """
    if client is None:
        for index, task in enumerate(tasks):
            yield index, function(task, **kwargs)
        return
    from dask.distributed import as_completed

    futures = {client.submit(function, task, pure=False, **kwargs): index
               for index, task in enumerate(tasks)}
    try:
        for future in as_completed(futures):
            yield futures[future], future.result()
    finally:
        client.cancel(list(futures))


def progress_bar(total, desc, unit, enabled=True, initial=0):
    """A progress bar on stderr (tqdm), or one that does nothing."""
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, desc=desc, unit=unit, file=sys.stderr,
                disable=not enabled)

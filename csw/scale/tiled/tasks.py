"""The stripe tasks: pass 1 matches a stripe's band and keeps its core rows; pass 2 (when
the speckle filter or the median is on) filters the first pass's map over a band.  Each
task reads its inputs itself and writes its rows to zarr stores, one chunk row per
stripe, so tasks never write the same chunk and a task rerun elsewhere rewrites its own.
"""

import time

import numpy as np

from ...matching.pipeline import filter_map, is_row_local, match_rows


def match_stripe(task):
    """Pass 1 for one stripe: read its band from both sources, run the row-local stages
    and write the core rows to the stores (the finished maps when there is no 2-D
    filter).  Returns counters: evaluated, candidates, invalid, seconds, bytes_read."""
    start_time = time.perf_counter()
    (start, stop), first, end = task["stripe"], task["band"][0], task["band"][1]
    left = task["left"].rows(first, end)
    right = task["right"].rows(first, end)
    st = task["stages"]
    rows = np.arange(start - first, stop - first, dtype=np.int64)
    disp, conf, raw = match_rows(left, right, dict(task["kernel_args"], rows=rows), st,
                                 confidence=task["confidence"])
    finished = is_row_local(st)
    if finished:
        disp, conf = filter_map(disp, conf, st)
    _write(task["disparity"], start, disp)
    if task["confidence_store"] is not None:
        _write(task["confidence_store"], start, conf)
    counts = {"evaluated": int(raw.evaluated), "candidates": int(raw.candidates),
              "invalid": int(np.isnan(disp).sum()) if finished else 0,
              "bytes_read": int(left.nbytes + right.nbytes),
              "bytes_written": int(disp.nbytes) * (2 if task["confidence_store"] else 1)}
    del left, right, raw, disp, conf
    _give_back_memory()
    return dict(counts, seconds=time.perf_counter() - start_time)


def filter_stripe(task):
    """Pass 2 for one stripe: read the first pass's map over the band, run the 2-D
    filters and write the core rows.  Returns counters as :func:`match_stripe`."""
    start_time = time.perf_counter()
    (start, stop), (first, end) = task["stripe"], task["band"]
    disp = _array(task["stage"])[first:end]
    conf = None
    if task["stage_confidence"] is not None:
        conf = _array(task["stage_confidence"])[first:end]
    disp, conf = filter_map(disp, conf, task["stages"])
    core = slice(start - first, stop - first)
    _write(task["disparity"], start, disp[core])
    if task["confidence_store"] is not None:
        _write(task["confidence_store"], start, conf[core])
    counts = {"evaluated": 0, "candidates": 0, "invalid": int(np.isnan(disp[core]).sum()),
              "bytes_read": int(disp.nbytes), "bytes_written": int(disp[core].nbytes)}
    del disp, conf
    _give_back_memory()
    return dict(counts, seconds=time.perf_counter() - start_time)


def _give_back_memory():
    """Return freed memory to the system after a stripe (glibc's malloc_trim): glibc keeps
    freed blocks below its mmap threshold, which it raises as large blocks come and go,
    so without this a long run's RSS creeps above what any one stripe needs.  Dask's
    workers do the same (MALLOC_TRIM_THRESHOLD_).  A no-op where there is no glibc."""
    try:
        import ctypes

        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass


def _write(store, start, values):
    _array(store, "r+")[start:start + values.shape[0]] = values


def create_store(path, shape, chunk_rows, compress):
    """A float32 zarr array, one chunk row per stripe (tasks never share a chunk)."""
    import zarr

    chunks = (chunk_rows, min(shape[1], 4096))
    kwargs = {} if compress else {"compressors": None}
    zarr.create_array(str(path), shape=shape, chunks=chunks, dtype="float32",
                      fill_value=np.nan, **kwargs)
    return str(path)


def store_blocks(store):
    """``blocks(rows, bottom_up=False)`` over a store's map, as csw.io.formats' stripe
    writers take it: (start, float32 rows), ``rows`` at a time."""
    def blocks(rows, bottom_up=False):
        array = _array(store)
        starts = range(0, array.shape[0], rows)
        for start in reversed(starts) if bottom_up else starts:
            yield start, array[start:start + rows]
    return blocks


def _array(store, mode="r"):
    """The zarr array at ``store`` (zarr is imported when first needed: it is slow to
    import, and most csw commands never use it)."""
    import zarr

    return zarr.open_array(store, mode=mode)

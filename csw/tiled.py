"""Pairs bigger than memory: ``csw.match_tiled`` matches a pair one row stripe at a time,
so memory follows the stripe, not the image.

Rows are independent in CSW, so a stripe read with the rows above and below that the
windows reach gives exactly the rows of a whole-image match (:func:`csw.pipeline.
row_overlap`).  The speckle filter and the median look across rows: when they are on, a
second pass reads the first pass's map back with the rows they need
(:func:`csw.pipeline.filter_overlap`), which makes them exact too.  Every stripe is a task:
here one after another (each uses all of Numba's threads over its rows), or on a Dask
cluster.

The maps go to zarr stores, one chunk row per stripe, so tasks never write the same chunk;
the output is then written from the store a stripe at a time: a tiled (Big)TIFF, a zarr
store, PFM, NPY or a 16-bit PNG.  A temporary store lives beside the output (so cluster
workers that can write the output can write it) and is removed at the end.
"""

import math
import os
import re
import shutil
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import kernels
from .io import (
    PNG_MAX_DISPARITY,
    TMP_PREFIX,
    atomic_write_all,
    colorize,
    disparity_to_file_float,
    kitti_png_values,
    pfm_header,
    tiff_tiles,
)
from .matching import check_tau_use, kernel_args, options, stages, warm_up
from .pipeline import OFF, filter_map, filter_overlap, is_row_local, match_rows, row_overlap
from .sources import open_source
from .tau import resolve_tau, sample_rows

TILED_SUFFIXES = (".tif", ".tiff", ".zarr", ".pfm", ".npy", ".png")
DEFAULT_MEMORY_LIMIT = 512 * 2**20  # the stripes' working memory, per process
TIFF_TILE = 256

# Bytes each band pixel costs in the first pass (inputs, their padded and census copies,
# the kernels' maps, the checks' masks), from peak RSS measured on 4000-wide pairs with a
# margin; tests/library/test_tiled.py checks a real run against the limit.
PASS1_BYTES = {"base": 48, "census": 24, "right_map": 8, "extras": 32, "xsobel": 24,
               "texture": 32, "colour": 40}
# And in the second pass: the map, the speckle filter's labels, stack and members, the
# median's output, the confidence.
PASS2_BYTES = {"base": 16, "speckle": 26, "median": 4, "confidence": 8}


class MemoryLimitError(ValueError):
    """The memory limit is below what one stripe needs; the message says how much."""


@dataclass
class Plan:
    """How a pair is cut: core stripes of ``stripe_rows`` rows (the last may be shorter),
    each read with ``row_overlap`` input rows and ``filter_overlap`` map rows beyond, and
    at least ``window`` input rows (the kernels' minimum)."""

    height: int
    width: int
    stripe_rows: int
    row_overlap: int
    filter_overlap: int
    bytes_per_stripe: int
    window: int = 1

    @property
    def stripes(self):
        """[(start, stop)] of the core stripes, top to bottom."""
        return [(s, min(s + self.stripe_rows, self.height))
                for s in range(0, self.height, self.stripe_rows)]

    @property
    def overhead(self):
        """Extra rows matched for the overlaps, as a share of the image's rows."""
        band = sum(b1 - b0 for b0, b1 in (input_band(s, self) for s in self.stripes))
        return band / self.height - 1.0


@dataclass
class TiledResult:
    """What :func:`match_tiled` returns (the maps themselves are in the output files).

    tasks: the stripe tasks' counters summed over both passes: ``count``, ``seconds``
    (compute, as the tasks measured it), ``bytes_read`` and ``bytes_written`` (decoded
    pixels and float32 maps moved between the files and the tasks).
    """

    output: Path
    shape: tuple
    plan: Plan
    evaluated: int
    candidates: int
    settings: dict = field(default_factory=dict)
    seconds: float = 0.0
    compile_seconds: float = 0.0
    invalid: int = 0
    confidence: Path | None = None
    tasks: dict = field(default_factory=dict)

    @property
    def invalid_share(self):
        """Share (0..1) of pixels without a disparity."""
        return self.invalid / max(self.shape[0] * self.shape[1], 1)

    @property
    def work_saved(self):
        return 1.0 - self.evaluated / self.candidates if self.candidates else 0.0


def parse_size(text):
    """Bytes from "512MB", "2GiB", "1.5G" or a number of bytes; ValueError otherwise."""
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        return int(text)
    match = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([kKmMgGtT]?)(i?)[bB]?\s*", str(text))
    if not match:
        raise ValueError(f"memory limit must be a size such as 512MB or 2GiB, got {text!r}")
    number, unit, binary = match.groups()
    base = 1024 if binary or not unit else 1000
    power = " KMGT".index(unit.upper()) if unit else 0
    return int(float(number) * base ** power)


def _mb(n):
    return f"{math.ceil(n / 2**20)} MiB"


def stripe_bytes(opts, width, dmin, dmax, threads, colour=False):
    """(bytes per band row in pass 1, bytes per band row in pass 2, fixed bytes): the
    memory model the plan follows.  The fixed part is the fast engine's per-thread cost
    columns, (W + window) x (D + 1) accumulators of up to 8 bytes."""
    st = stages(opts)
    p1 = PASS1_BYTES["base"]
    p1 += PASS1_BYTES["census"] if opts["cost"] == "census" else 0
    p1 += PASS1_BYTES["right_map"] if st["lr_check"] is not None else 0
    p1 += PASS1_BYTES["extras"] if (st["uniqueness_ratio"] is not None
                                    or st["subpixel"] != "none") else 0
    p1 += PASS1_BYTES["xsobel"] if st["prefilter"] == "xsobel" else 0
    p1 += PASS1_BYTES["texture"] if st["texture_threshold"] is not None else 0
    p1 += PASS1_BYTES["colour"] if colour else 0
    p2 = PASS2_BYTES["base"] + PASS2_BYTES["confidence"]
    p2 += PASS2_BYTES["speckle"] if st["speckle_size"] > 0 else 0
    p2 += PASS2_BYTES["median"] if st["median"] else 0
    ndisp = dmax - dmin + 1
    fixed = threads * (width + opts["window"]) * (ndisp + 1) * 8 \
        if opts["engine"] == "fast" else threads * (width + ndisp) * 32
    return p1 * width, p2 * width, fixed


def plan(height, width, opts, memory_limit=DEFAULT_MEMORY_LIMIT, stripe_rows=None,
         threads=None, colour=False, resident=0):
    """The stripes for a pair under a memory limit (bytes for the stripes' working data,
    on top of the process itself), or of ``stripe_rows`` rows when given.  colour: the
    sources convert colour rows; resident: bytes the sources hold throughout.
    MemoryLimitError when one stripe of the smallest useful height does not fit."""
    st = stages(opts)
    over = row_overlap(st, opts["window"], opts["cost"])
    fover = filter_overlap(st)
    threads = threads or kernels.contract.thread_count(opts["threads"]).n
    per_row1, per_row2, fixed = stripe_bytes(opts, width, opts["dmin"], opts["dmax"],
                                             threads, colour)
    fixed += resident

    # Writing the output reads the stores TIFF_TILE rows at a time, with a padded copy
    # and the invalid-value conversion beside them.
    writing = resident + 4 * TIFF_TILE * width * 4

    def need(rows):  # peak bytes of a stripe of ``rows`` core rows
        band1 = min(height, rows + 2 * over)
        band2 = min(height, rows + 2 * fover) if fover else 0
        return max(fixed + per_row1 * band1, resident + per_row2 * band2, writing)

    smallest = min(height, opts["window"])
    if stripe_rows is None:
        if need(smallest) > memory_limit:
            raise MemoryLimitError(
                f"a memory limit of {_mb(memory_limit)} is below what one stripe needs "
                f"({_mb(need(smallest))} for a {width}-pixel-wide pair with these options); "
                f"raise the memory limit to at least that")
        rows, most = smallest, height  # the tallest stripe that fits: need() only grows
        while rows < most:
            middle = (rows + most + 1) // 2
            rows, most = (middle, most) if need(middle) <= memory_limit else (rows, middle - 1)
    else:
        rows = int(stripe_rows)
        if rows < 1:
            raise ValueError(f"stripe_rows must be at least 1, got {rows}")
        rows = min(rows, height)
    return Plan(height, width, rows, over, fover, need(rows), opts["window"])


def too_big_for_whole(left, memory_limit=None, **given):
    """Whether matching the pair whole would need more than ``memory_limit`` (default:
    DEFAULT_MEMORY_LIMIT), by the stripes' memory model for one stripe the image's
    height; reads only the header."""
    memory_limit = DEFAULT_MEMORY_LIMIT if memory_limit is None else memory_limit
    source = open_source(left, "left", probe=False)
    opts = options(**given)
    height, width = source.shape
    whole = plan(height, width, opts, stripe_rows=height, colour=source.colour)
    return whole.bytes_per_stripe > memory_limit


def input_band(stripe, plan):
    """(first, end) input rows that stripe (start, stop) is matched from: the overlap each
    side, within the image, grown to at least one window (the kernels refuse fewer rows;
    rows beyond the overlap change nothing, they are only more context)."""
    start, stop = stripe
    first = max(0, start - plan.row_overlap)
    end = min(plan.height, stop + plan.row_overlap)
    while end - first < min(plan.window, plan.height):
        first, end = max(0, first - 1), min(plan.height, end + 1)
    return first, end


def map_band(stripe, plan):
    """(first, end) rows of the first pass's map that the 2-D filters read for a stripe."""
    start, stop = stripe
    return max(0, start - plan.filter_overlap), min(plan.height, stop + plan.filter_overlap)


# ---------------------------------------------------------------------------- the tasks


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


def _create_store(path, shape, chunk_rows, compress):
    """A float32 zarr array, one chunk row per stripe (tasks never share a chunk)."""
    import zarr

    chunks = (chunk_rows, min(shape[1], 4096))
    kwargs = {} if compress else {"compressors": None}
    zarr.create_array(str(path), shape=shape, chunks=chunks, dtype="float32",
                      fill_value=np.nan, **kwargs)
    return str(path)


# ---------------------------------------------------------------------------- the outputs


def _stripes_of(store, rows=TIFF_TILE, bottom_up=False):
    """(start, float32 rows) of a store, ``rows`` at a time, top to bottom (or bottom to
    top)."""
    array = _array(store)
    starts = range(0, array.shape[0], rows)
    for start in reversed(starts) if bottom_up else starts:
        yield start, array[start:start + rows]


def output_writer(path, store, shape, kind="disparity", dmax=None):
    """A ``write_to(tmp)`` that writes a store's map to ``path`` in the format of its
    suffix, a stripe at a time, with csw.io's conventions: NaN invalid in TIFF/zarr
    (GDAL's nodata tag), inf in PFM/NPY, 0 in PNG (d x 256, KITTI).  kind "preview": an
    8-bit colour PNG of the disparity (csw.io.colorize, up to ``dmax``)."""
    suffix = Path(path).suffix.lower()
    height, width = shape
    if kind == "preview":
        import png

        def write(tmp):
            rows = (row.reshape(-1) for _, block in _stripes_of(store)
                    for row in colorize(block, dmax))
            with open(tmp, "wb") as f:
                png.Writer(width, height, greyscale=False, bitdepth=8).write(f, rows)
        return write
    if suffix in (".tif", ".tiff"):
        import tifffile

        def write(tmp):
            blocks = (block for _, block in _stripes_of(store, TIFF_TILE))
            tifffile.imwrite(tmp, tiff_tiles(blocks, width, np.float32, np.nan, TIFF_TILE),
                             shape=shape, dtype=np.float32, tile=(TIFF_TILE, TIFF_TILE),
                             bigtiff=height * width * 4 > 2**31, photometric="minisblack",
                             extratags=[(42113, "s", 0, "nan", True)])  # GDAL_NODATA
        return write
    if suffix == ".pfm":
        def write(tmp):
            with open(tmp, "wb") as f:
                f.write(pfm_header(width, height))
                for _, block in _stripes_of(store, bottom_up=True):
                    f.write(np.flipud(disparity_to_file_float(block)).astype("<f4").tobytes())
        return write
    if suffix == ".npy":
        def write(tmp):
            out = np.lib.format.open_memmap(tmp, mode="w+", dtype="<f4", shape=shape)
            for start, block in _stripes_of(store):
                out[start:start + block.shape[0]] = disparity_to_file_float(block)
            out.flush()
            del out
        return write
    if suffix == ".png":
        import png

        def write(tmp):
            rows = (row for _, block in _stripes_of(store) for row in kitti_png_values(block))
            with open(tmp, "wb") as f:
                png.Writer(width, height, greyscale=True, bitdepth=16).write(f, rows)
        return write
    raise ValueError(f"unknown output extension {suffix!r}; use {', '.join(TILED_SUFFIXES)}")


def _array(store, mode="r"):
    """The zarr array at ``store`` (zarr is imported when first needed: it is slow to
    import, and most csw commands never use it)."""
    import zarr

    return zarr.open_array(store, mode=mode)


def _replace_dir(tmp, path):
    """Put folder ``tmp`` at ``path``, replacing an earlier zarr store there."""
    path = Path(path)
    old = None
    if path.exists():
        if not (path / "zarr.json").exists():
            raise ValueError(f"{path} exists and is not a zarr store; csw won't replace it")
        old = path.with_name(f"{TMP_PREFIX}{path.name}.old")
        shutil.rmtree(old, ignore_errors=True)
        os.replace(path, old)
    os.replace(tmp, path)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


# ---------------------------------------------------------------------------- the entry


def match_tiled(left, right, output, *, confidence=None, preview=None, memory_limit=None,
                stripe_rows=None, client=None, progress=False, **given):
    """Match a pair stripe by stripe and write the map to ``output``; the result equals
    :func:`csw.match`'s bit for bit, for every preset and stage.

    Parameters
    ----------
    left, right : path or array
        TIFF/BigTIFF, .npy and .zarr are read by rows; other formats are decoded whole.
        Arrays (numpy, memmap, zarr) are sliced.  With a client, give paths that the
        workers can read.
    output : path
        .tif/.tiff (tiled float32, NaN invalid), .zarr, .pfm, .npy or .png.
    confidence : path, optional
        Also write the confidence map (formats as ``output``, save .png).
    preview : path, optional
        Also write an 8-bit colour PNG of the map (invalid black).
    memory_limit : int or str, optional
        The stripes' working memory per process ("512MB", "2GiB"; default 512 MiB); the
        stripe height follows it.  The process itself adds about 200 MB.
    stripe_rows : int, optional
        Cut stripes of this many rows instead.
    client : dask.distributed.Client, optional
        Run the stripes as tasks on this cluster; the output's folder must be one the
        workers can write.
    progress : bool
        A progress bar over the stripes, on stderr.
    **given
        Matching options, as for :func:`csw.match`.

    Returns
    -------
    TiledResult
    """
    opts = options(**given)
    check_tau_use(opts["csw"], opts["tau"])
    output = Path(output)
    for path in (output, confidence):
        if path is not None and Path(path).suffix.lower() not in TILED_SUFFIXES:
            raise ValueError(f"unknown output extension {Path(path).suffix!r}; use "
                             f"{', '.join(TILED_SUFFIXES)}")
    if confidence is not None and Path(confidence).suffix.lower() == ".png":
        raise ValueError("the confidence map is 0..1 floats; write it as .tif, .pfm or .npy")
    if client is not None and not all(isinstance(p, (str, Path)) for p in (left, right)):
        raise ValueError("on a cluster, give left and right as paths the workers can read")
    limit = parse_size(memory_limit if memory_limit is not None else DEFAULT_MEMORY_LIMIT)
    left, right = open_source(left, "left"), open_source(right, "right")
    if left.shape != right.shape:
        raise ValueError(f"left and right images differ in size: {left.shape[1]}x"
                         f"{left.shape[0]} vs {right.shape[1]}x{right.shape[0]}; stereo "
                         "pairs must be rectified to one size")
    if left.dtype != right.dtype:
        raise ValueError(f"left is {left.dtype} but right is {right.dtype}; give both the "
                         "same bit depth")
    height, width = left.shape
    args = kernel_args(opts)
    if opts["engine"] not in kernels.ENGINES:
        raise ValueError(f"engine must be one of {', '.join(kernels.ENGINES)}, "
                         f"got {opts['engine']!r}")
    # The kernels' checks, on a stand-in as wide as the pair and one window tall.
    window = opts["window"] if isinstance(opts["window"], int) else 1
    stand_in = np.zeros((min(height, max(window, 1)), width), left.dtype)
    _, _, setup, _ = kernels.contract.validate(
        stand_in, stand_in, window=opts["window"], dmin=opts["dmin"], dmax=opts["dmax"],
        cost=opts["cost"], csw=False, tau=-1, rule=opts["csw_rule"],
        uniqueness=opts["uniqueness"], census_window=opts["census_window"])
    if height < setup.window:
        raise ValueError(f"window {setup.window} is taller than the image ({height} rows)")
    if output.suffix.lower() == ".png" and opts["dmax"] > PNG_MAX_DISPARITY:
        raise ValueError(f"dmax {opts['dmax']} is too large for a 16-bit PNG; write .tif, "
                         ".pfm or .npy")
    st = stages(opts)
    layout = plan(height, width, opts, limit, stripe_rows,
                  colour=left.colour or right.colour,
                  resident=left.resident_bytes + right.resident_bytes)
    compile_s = warm_up(opts["engine"], opts["cost"], setup.window, left.dtype, st)
    tau, source = -1.0, "off"
    if opts["csw"]:
        tau, source = resolve_tau(opts["tau"], opts["csw_rule"],
                                  plain_min_cost=lambda: _sampled_min_cost(left, right, args,
                                                                           st, layout))
    args = dict(args, csw=opts["csw"], tau=tau)
    settings = dict(opts, tau=tau, tau_source=source,
                    uniqueness=kernels.contract.resolve_uniqueness(opts["cost"],
                                                                   opts["uniqueness"]))
    start_time = time.perf_counter()
    totals = _run_passes(left, right, output, confidence, preview, layout, args, st, client,
                         progress)
    return TiledResult(output, (height, width), layout, totals.pop("evaluated"),
                       totals.pop("candidates"), settings, time.perf_counter() - start_time,
                       compile_s, totals.pop("invalid"),
                       Path(confidence) if confidence is not None else None, totals)


def _sampled_min_cost(left, right, args, st, layout):
    """The min-cost rows tau auto samples (csw.tau.sample_rows), each matched from its own
    band, so they equal the whole image's."""
    shaping = dict(OFF, **{k: st[k] for k in ("prefilter", "prefilter_cap", "census_window")})
    rows = []
    for y in sample_rows(layout.height):
        first, end = input_band((y, y + 1), layout)
        a, b = left.rows(first, end), right.rows(first, end)
        raw = match_rows(a, b, dict(args, rows=np.array([y - first])), shaping)[2]
        rows.append(raw.min_cost)
    return np.vstack(rows)


def _run_passes(left, right, output, confidence, preview, layout, args, st, client,
                progress):
    """Both passes into temporary stores beside the output, then the outputs; the
    temporary stores are removed whatever happens."""
    from tqdm import tqdm

    folder = output.parent if str(output.parent) else Path(".")
    work = Path(tempfile.mkdtemp(prefix=f"{TMP_PREFIX}{output.name}.", suffix=".tmp",
                                 dir=folder))
    try:
        shape = (layout.height, layout.width)
        rows = layout.stripe_rows
        two_pass = not is_row_local(st)
        final = {"disparity": _create_store(work / "disparity.zarr", shape, rows,
                                            output.suffix.lower() == ".zarr")}
        if confidence is not None:
            final["confidence"] = _create_store(work / "confidence.zarr", shape, rows,
                                                Path(confidence).suffix.lower() == ".zarr")
        stage = {}
        if two_pass:
            stage["disparity"] = _create_store(work / "stage.zarr", shape, rows, False)
            if confidence is not None:
                stage["confidence"] = _create_store(work / "stage-confidence.zarr", shape,
                                                    rows, False)
        first_into = stage if two_pass else final
        pass1 = [{"stripe": s, "band": input_band(s, layout),
                  "left": left, "right": right, "kernel_args": args, "stages": st,
                  "confidence": confidence is not None,
                  "disparity": first_into["disparity"],
                  "confidence_store": first_into.get("confidence")} for s in layout.stripes]
        pass2 = [{"stripe": s, "band": map_band(s, layout), "stages": st,
                  "stage": stage["disparity"], "stage_confidence": stage.get("confidence"),
                  "disparity": final["disparity"],
                  "confidence_store": final.get("confidence")}
                 for s in layout.stripes] if two_pass else []
        bar = tqdm(total=len(pass1) + len(pass2), desc="csw match (stripes)", unit="stripe",
                   file=sys.stderr, disable=not progress)
        totals = {"evaluated": 0, "candidates": 0, "invalid": 0, "count": 0, "seconds": 0.0,
                  "bytes_read": 0, "bytes_written": 0}
        try:
            for function, tasks in ((match_stripe, pass1), (filter_stripe, pass2)):
                for counts in _map(function, tasks, client):
                    for key, value in counts.items():
                        totals[key] += value
                    totals["count"] += 1
                    bar.update()
        finally:
            bar.close()
        # Every file is written before any is renamed into place: all of them or none.
        items = [(Path(preview), output_writer(preview, final["disparity"], shape, "preview",
                                               args["dmax"]))] if preview is not None else []
        for path, store, kind in ((output, final["disparity"], "disparity"),
                                  (confidence, final.get("confidence"), "confidence")):
            if path is not None and Path(path).suffix.lower() != ".zarr":
                items.append((Path(path), output_writer(path, store, shape, kind)))
        atomic_write_all(items)
        for path, store in ((output, final["disparity"]), (confidence, final.get("confidence"))):
            if path is not None and Path(path).suffix.lower() == ".zarr":
                _replace_dir(store, path)
        return totals
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _map(function, tasks, client):
    """Run tasks here one after another, or on the cluster; yield their counters as they
    finish.  A Ctrl-C or an error cancels what is left on the cluster."""
    if client is None:
        for task in tasks:
            yield function(task)
        return
    from dask.distributed import as_completed

    futures = client.map(function, tasks, pure=False)
    try:
        for future in as_completed(futures):
            yield future.result()
    finally:
        client.cancel(futures)

"""``csw.match_tiled``: one pair matched stripe by stripe, so memory follows the stripe,
not the image; the maps equal :func:`csw.match`'s bit for bit.

Every stripe is a task (:mod:`.tasks`), run through :func:`csw.scale.executor.run_tasks`: here
one after another (each uses all of Numba's threads over its rows), or on a Dask
cluster.  The maps go to temporary zarr stores beside the output (so cluster workers that
can write the output can write them), and the outputs are then written from the stores a
stripe at a time, in the formats of csw.io.formats, and renamed into place together.
"""

import os
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...io.atomic import make_temporary_dir
from ...io.formats import format_of, preview_stripes, stripe_writer, suffixes
from ...io.outputs import PairOutputs
from ...io.progress import progress_bar
from ...io.sources import open_source
from ...matching import disparity_range
from ...matching.matcher import resolved
from ...matching.pipeline import CandidateCounts, is_row_local, match_rows
from ...matching.setup import set_up
from ..executor import run_tasks
from .plan import Plan, input_band, map_band, parse_size, plan
from .tasks import create_store, filter_stripe, match_stripe, store_blocks


@dataclass
class TiledResult(CandidateCounts):
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
    def stripes(self):
        """How many stripes the pair was cut into."""
        return len(self.plan.stripes)

    @property
    def invalid_share(self):
        """Share (0..1) of pixels without a disparity."""
        return self.invalid / max(self.shape[0] * self.shape[1], 1)


def match_tiled(left, right, output, *, confidence=None, preview=None, memory_limit=None,
                stripe_rows=None, client=None, progress=False, config=None, outputs=None,
                calibration=None, **options):
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
    outputs : csw.io.outputs.PairOutputs, optional
        These paths checked already (csw.match_files); default: checked here.
    calibration : csw.Calibration, optional
        The pair's, whose ndisp sets the range when no dmax was given.
    **options
        Matching options, as for :func:`csw.match`; or ``config``, an option set that
        csw.config.params.resolve made already.

    Returns
    -------
    TiledResult
    """
    config = resolved(config, options, "match_tiled")
    alone = outputs is None
    if alone:  # called alone, not by csw.match_files: its outputs checked here, once
        format_of(output, "stripes")
        if confidence is not None:
            format_of(confidence, "confidence")
        outputs = PairOutputs({"output": output, "confidence": confidence,
                               "preview": preview},
                              allowed={"output": suffixes("stripes")})
        outputs.check_targets()
    output = Path(output)
    # A link is followed: the store and the temporaries go beside what it points to.
    output = Path(os.path.realpath(output)) if output.is_symlink() else output
    if confidence is not None and Path(confidence).is_symlink():
        confidence = Path(os.path.realpath(confidence))
    if client is not None and not all(isinstance(p, (str, Path)) for p in (left, right)):
        raise ValueError("on a cluster, give left and right as paths the workers can read")
    limit = parse_size(memory_limit) if memory_limit is not None else None
    striped = memory_limit is not None or stripe_rows is not None  # the user's word
    left, right = (open_source(image, side, striped=striped, can_stripe=True)
                   for image, side in ((left, "left"), (right, "right")))
    height, width = left.shape
    if alone:
        outputs.check_range(disparity_range.known_range(config, width, calibration))
    layout = []  # the plan, once made: tau auto samples each row from its own band

    def make_plan(decided):
        layout.append(plan(height, width, decided, limit, stripe_rows,
                           colour=left.colour or right.colour,
                           resident=left.resident_bytes + right.resident_bytes))
        return layout[0]

    def shrunk(f):
        from ...matching.disparity_range import shrink

        def small(source):  # whole blocks of f rows, a band at a time
            band = f * max(1, 2**20 // (f * width))
            rows = [shrink(source.rows(r, min(r + band, height // f * f)), f)
                    for r in range(0, height // f * f, band)]
            return np.vstack(rows)

        return small(left), small(right)

    def sample_min_cost(args, stages, rows):
        found = []
        for y in rows:
            first, end = input_band((y, y + 1), layout[0])
            a, b = left.rows(first, end), right.rows(first, end)
            found.append(match_rows(a, b, dict(args, rows=np.array([y - first])),
                                    stages)[2].min_cost)
        return np.vstack(found)

    ready = set_up(config, (height, width), left.dtype, right=(right.shape, right.dtype),
                   sample_min_cost=sample_min_cost, make_plan=make_plan,
                   confidence=confidence is not None, shrunk=shrunk,
                   calibration=calibration)
    layout = ready.plan
    start_time = time.perf_counter()
    totals = _run_passes(left, right, output, confidence, outputs, layout, ready.args,
                         ready.config.stages, client, progress)
    return TiledResult(output, (height, width), layout, totals.pop("evaluated"),
                       totals.pop("candidates"), ready.settings,
                       time.perf_counter() - start_time, ready.compile_seconds,
                       totals.pop("invalid"),
                       Path(confidence) if confidence is not None else None, totals)


def _run_passes(left, right, output, confidence, outputs, layout, args, st, client,
                progress):
    """Both passes into temporary stores beside the output, then the outputs; the
    temporary stores are removed whatever happens."""
    folder = output.parent if str(output.parent) else Path(".")
    work = make_temporary_dir(folder, output.name)
    try:
        shape = (layout.height, layout.width)
        rows = layout.stripe_rows
        two_pass = not is_row_local(st)
        final = {"disparity": create_store(work / "disparity.zarr", shape, rows,
                                           output.suffix.lower() == ".zarr")}
        if confidence is not None:
            final["confidence"] = create_store(work / "confidence.zarr", shape, rows,
                                               Path(confidence).suffix.lower() == ".zarr")
        stage = {}
        if two_pass:
            stage["disparity"] = create_store(work / "stage.zarr", shape, rows, False)
            if confidence is not None:
                stage["confidence"] = create_store(work / "stage-confidence.zarr", shape,
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
        totals = {"evaluated": 0, "candidates": 0, "invalid": 0, "count": 0, "seconds": 0.0,
                  "bytes_read": 0, "bytes_written": 0}
        with progress_bar(len(pass1) + len(pass2), "csw match (stripes)", "stripe",
                          progress) as bar:
            for function, tasks in ((match_stripe, pass1), (filter_stripe, pass2)):
                for _, counts in run_tasks(function, tasks, client):
                    for key, value in counts.items():
                        totals[key] += value
                    totals["count"] += 1
                    bar.update()
        # Every file is written before any is renamed into place: all of them or none.
        if "preview" in outputs:
            outputs.add("preview", preview_stripes(
                shape, store_blocks(final["disparity"]), args["dmax"], args["dmin"]))
        stores = (("output", output, final["disparity"]),
                  ("confidence", confidence, final.get("confidence")))
        for role, path, store in stores:
            if path is not None and Path(path).suffix.lower() != ".zarr":
                outputs.add(role, stripe_writer(path, shape, store_blocks(store)))
        outputs.write()
        for role, path, store in stores:
            if path is not None and Path(path).suffix.lower() == ".zarr":
                outputs.place_store(role, store)
        return totals
    finally:
        shutil.rmtree(work, ignore_errors=True)


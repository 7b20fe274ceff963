"""Many pairs at once: a manifest or two folders in, one map per pair and a JSON summary
out.  A pair that fails is reported in the summary and the others go on.
"""

import os
import time
from pathlib import Path

from ..camera import calibration as calib_module
from ..camera.geometry import check_max_depth
from ..config.params import OptionError
from ..io import safety
from ..io.atomic import remove_temporaries
from ..io.formats import suffixes
from ..io.images import ImageError
from ..io.outputs import check_range_of, role_suffixes
from ..io.progress import progress_bar
from ..matching import disparity_range
from ..matching.matcher import Matcher, resolved
from .executor import run_tasks
from .files import match_files
from .jobs import check_names
from .summary import PairLog, signals_held, write_summary

# Each pair's 3-D outputs are NAME + this + their format: NAME.depth.pfm, NAME.ply ...
PER_PAIR_INFIX = {"preview": ".preview", "confidence": ".confidence", "depth": ".depth",
                  "cloud": "", "depth_preview": ".depth"}


def _inside(path, folder):
    """Whether ``path``, its links resolved, lies in ``folder`` (resolved)."""
    real, base = os.path.realpath(path), os.path.realpath(folder)
    return os.path.dirname(real) == base


def check_batch_outputs(jobs, outputs, out_dir, summary, calib=None):
    """Before any work: every output (per job, a dict of role -> path) resolves, links
    followed, to a regular file (or nothing yet) directly in ``out_dir``; no two outputs,
    of one pair or of two, are one file; and neither an output nor the summary is an
    input of the batch (a pair's image, the calibration, a file the run has read, such
    as the manifest).  ValueError (one line) naming the first offender."""
    inputs = {}
    for job in jobs:
        for side in (job.left, job.right):
            if side is not None:
                inputs.setdefault(os.path.realpath(side), job.where or str(job.left))
    if isinstance(calib, (str, Path)):
        inputs[os.path.realpath(calib)] = "the calibration"
    written = {}
    for job, paths in zip(jobs, outputs, strict=True):
        for role, path in paths.items():
            where = job.where or job.left
            if not _inside(path, out_dir):
                raise ValueError(f"{where}: {path} resolves to {os.path.realpath(path)}, "
                                 f"outside the output folder {out_dir}; csw won't write "
                                 "there")
            real = os.path.realpath(path).casefold()  # as check_names: one on macOS
            owner = inputs.get(os.path.realpath(path))
            if owner is not None:
                raise ValueError(f"{where}: the output {path} is an input ({owner}); an "
                                 "output must not overwrite an input")
            if real in written:
                raise ValueError(f"{where}: its {role.replace('_', ' ')} {path} is also "
                                 f"{written[real]}; give the pairs names whose outputs "
                                 "differ")
            written[real] = f"the {role.replace('_', ' ')} of {job.name!r}"
            safety.check_target(path)
    real = os.path.realpath(summary)
    if real.casefold() in written:
        raise OptionError("summary", f"the summary {summary} is {written[real.casefold()]}")
    if real in inputs:
        raise OptionError("summary", f"the summary {summary} is an input ({inputs[real]})")
    safety.check_target(summary, "summary")
    folder = Path(summary).parent
    if folder != Path(out_dir) and not folder.is_dir():
        raise OptionError("summary", f"folder {str(folder)!r} does not exist; create it "
                                     "first")


def run_job(task, config, calib=None, three_d=None, rig=None, matcher=None):
    """Match one pair, a (Job, outputs) task (outputs: role -> path, "map" first), and
    write its map and the 3-D outputs asked for, all or none, through the one path from
    a pair to files (csw.match_files: a pair too big for memory is matched in stripes);
    returns a summary entry (never raises for a bad pair: the error is in the entry).
    calib: the batch's Calibration, else the pair's calib.txt (beside its left image) is
    used; its ndisp sets the range when the options give no dmax.  config: the batch's
    csw.config.params.Config, resolved once.  three_d: max_depth and units.  rig: the
    batch's csw.Rectifier when the pairs are raw (its maps built once, for every pair).
    matcher: the batch's csw.Matcher (made once with ``config``, so that pairs of one
    size reuse its set-up), or None (a cluster's task: one made for the pair)."""
    job, outputs = task
    entry = {"name": job.name, "left": str(job.left),
             "right": str(job.right) if job.right else None,
             "output": str(outputs["map"])}
    start = time.perf_counter()
    try:
        if job.problem:
            raise ValueError(job.problem)
        calibration = None if rig is not None else calib_module.resolve(calib, job.left)
        result = match_files(job.left, job.right, outputs["map"], calib=calibration, rig=rig,
                             preview=outputs.get("preview"),
                             confidence=outputs.get("confidence"),
                             depth=outputs.get("depth"), cloud=outputs.get("cloud"),
                             depth_preview=outputs.get("depth_preview"), keep_scratch=True,
                             config=config, matcher=matcher, **(three_d or {}))
    except Exception as exc:  # noqa: BLE001 (any error of one pair is that pair's, reported)
        return dict(entry, status="failed", error=failure_message(exc))
    s = result.settings
    return dict(entry, status="ok", seconds=time.perf_counter() - start,
                match_seconds=result.seconds, invalid=100.0 * result.invalid_share,
                work_saved=100.0 * result.work_saved, range=[s["dmin"], s["dmax"]],
                range_source=s["range_source"], stripes=result.stripes,
                notes=list(getattr(result, "notes", [])),
                calibration=calibration.as_dict() if calibration else None,
                **{role: str(path) for role, path in outputs.items() if role != "map"})


def failure_message(exc):
    """One line for a pair's error: the message of csw's own errors, the reason and the
    file of a system error, else the error's type and first line (a decoder's zlib
    error, an overflow in a calibration ...)."""
    if isinstance(exc, OSError) and exc.strerror:
        return f"{exc.filename}: {exc.strerror}" if exc.filename else exc.strerror
    text = str(exc).splitlines()[0] if str(exc) else ""
    if isinstance(exc, (ImageError, ValueError)) and text:
        return text
    return f"{type(exc).__name__}: {text}"[:300] if text else type(exc).__name__


def match_many(jobs, out_dir, *, suffix=".pfm", overwrite=False, progress=True,
               summary=None, client=None, calib=None, depth=None, cloud=None,
               depth_preview=None, max_depth=None, units=None, preview=None,
               confidence=None, config=None, rig=None, alpha=0.0, **match_options):
    """Match every job into ``out_dir/<name><suffix>``.

    Parameters
    ----------
    jobs : list of Job
        From :func:`jobs_from_folders` or :func:`jobs_from_manifest`.
    out_dir : path
        The folder for the maps, created with its parents if missing (on a cluster: one
        every worker can write).  Every output must resolve into it, and no output may
        be an input of the batch: both are checked before any work.
    suffix : {".pfm", ".png", ".npy"}
    overwrite : bool
        Redo pairs whose output exists (default: skip them, so a rerun resumes).
    progress : bool or callable
        A progress bar on stderr; or ``progress(done, total)``, called as each pair
        finishes (no bar).
    summary : path, optional
        Where to write the JSON summary (default ``out_dir/summary.json``).
    client : dask.distributed.Client, optional
        Run each pair as a task on this cluster: the workers read the images and write
        the maps; a worker that dies has its tasks rerun elsewhere (writes are atomic, so
        a rerun never leaves a partial map).  See :func:`csw.scale.distributed.local_client`.
    calib : path or csw.Calibration, optional
        One calibration for every pair; default: each pair's calib.txt beside its left
        image (Middlebury 2014's layout), whose ndisp also sets its range when the
        options give no dmax.
    preview, confidence : str, optional
        Also write each pair's colour picture of its map (".png": NAME.preview.png) and
        its confidence map (a float format, e.g. ".pfm": NAME.confidence.pfm).
    depth, cloud, depth_preview : str, optional
        Also write each pair's depth map (the format, e.g. ".pfm": NAME.depth.pfm), point
        cloud (".ply": NAME.ply) and depth picture (".png": NAME.depth.png).
    max_depth, units : optional
        As for :func:`csw.match_files`.
    rig, alpha : optional
        The pairs are raw, from this rig (a csw.Rig or csw.Rectifier): each is rectified
        with maps built once for all, and the rig gives the calibration (see
        :func:`csw.match_files`).
    **match_options
        As for :func:`csw.match`; or ``config``, a csw.config.params.Config resolved
        already.  Every pair runs with the one config resolved here.

    Returns
    -------
    dict
        The summary: ``counts`` (ok, skipped, failed), ``pairs`` (one entry each, in the
        jobs' order, with ``status`` and, for failures, ``error``; read from the summary
        file as they are asked for, so that a long batch keeps none in memory),
        ``failed`` (the failed pairs' entries) and ``options``.
    """
    if suffix not in suffixes("whole"):
        raise ValueError(f"suffix must be one of {', '.join(suffixes('whole'))}, got "
                         f"{suffix!r}")
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise OptionError("output_dir", f"{out_dir} exists and is not a folder")
    # Once for every pair, and bad options fail before any work.
    config = resolved(config, match_options, "match_many")
    check_range_of(f"map{suffix}", config.dmin, config.dmax)
    check_names(jobs)
    check_max_depth(max_depth)
    summary = Path(summary) if summary else out_dir / "summary.json"
    extras = {}  # role -> the file name pattern of each pair's output
    for role, value in (("preview", preview), ("confidence", confidence), ("depth", depth),
                        ("cloud", cloud), ("depth_preview", depth_preview)):
        if value is not None:
            extra = str(value) if str(value).startswith(".") else Path(value).suffix
            if extra.lower() not in role_suffixes(role):
                raise OptionError(role, f"many pairs take the {role.replace('_', ' ')}'s "
                                        f"format, one of {', '.join(role_suffixes(role))}; "
                                        f"got {value!r}")
            extras[role] = "{name}" + PER_PAIR_INFIX[role] + extra
    calib_path = calib if isinstance(calib, (str, Path)) else None
    if calib_path is not None:
        calib = calib_module.read_calibration(calib)  # once, and a bad one fails first
    rectifier = None
    if rig is not None:  # raw pairs: the maps built once, for every pair
        from ..camera.rectify import Rectifier

        if calib is not None:
            raise OptionError("calib", "a rig gives the rectified pairs' calibration: "
                                       "drop --calib (or --rig)")
        rectifier = rig if isinstance(rig, Rectifier) else Rectifier(rig, alpha,
                                                                      config.threads)
    outputs = [{"map": out_dir / f"{job.name}{suffix}",
                **{role: out_dir / pattern.format(name=job.name)
                   for role, pattern in extras.items()}} for job in jobs]
    check_batch_outputs(jobs, outputs, out_dir, summary, calib_path)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OptionError("output_dir", f"can't create the folder {out_dir} "
                                        f"({exc.strerror or exc})") from None
    log = PairLog(summary.parent, len(jobs))
    todo = []
    for i, (job, paths) in enumerate(zip(jobs, outputs, strict=True)):
        if paths["map"].exists() and not overwrite:
            log.add(i, {"name": job.name, "left": str(job.left), "right": str(job.right),
                        "output": str(paths["map"]), "status": "skipped"})
        else:
            todo.append(i)
    bar = progress_bar(len(jobs), "csw match", "pair", progress is True,
                       initial=len(jobs) - len(todo))
    try:
        tasks = ((jobs[i], outputs[i]) for i in todo)
        three_d = dict(max_depth=max_depth, units=units)
        side_by_side, pair_config, matcher = 1, config, None
        if client is None and todo:
            # Small pairs, as a stream's frames: one per thread, side by side.
            side_by_side, threads = _side_by_side(config, jobs[todo[0]])
            pair_config = config.replace(threads=threads)
            # One Matcher for every pair (its set-ups kept from pair to pair, shared by
            # the threads); each pair finds its own range.  A cluster's tasks make their
            # own: a Matcher's kept set-ups are not worth shipping to the workers.
            matcher = Matcher(pixels=None, config=pair_config, keep_range=False)
        for k, entry in run_tasks(run_job, tasks, client, side_by_side=side_by_side,
                                  config=pair_config, calib=calib, three_d=three_d,
                                  rig=rectifier, matcher=matcher):
            log.add(todo[k], entry)
            bar.update()
            if callable(progress):
                progress(log.done, len(jobs))
        # Every task has finished: a temporary file still beside an output was left by a
        # worker killed mid-write (its task was rerun elsewhere), so it can go.
        remove_temporaries(path for i in todo for path in outputs[i].values())
        return write_summary(summary, log, config.as_dict())
    except KeyboardInterrupt:
        # What finished is complete on disk: say so, marked as interrupted, and stop (a
        # second Ctrl-C waits until the summary is written).
        with signals_held():
            write_summary(summary, log, config.as_dict(), interrupted=True)
        raise
    finally:
        bar.close()
        log.close()


def _side_by_side(config, job):
    """(pairs at once, threads per pair) for a batch on this machine, from its first
    pair's size as its header gives it (csw.matching.matcher.stream_concurrency), one at a time
    when that can't be read (the pair's own error comes when it is matched).  A range
    found from each pair (or its calib.txt) is planned with csw's one stand-in
    (csw.matching.disparity_range.assumed_range)."""
    from ..io.images import image_header
    from ..matching.matcher import stream_concurrency

    try:
        height, width = image_header(job.left)[2]
    except (ValueError, OSError, TypeError):
        return 1, config.threads
    return stream_concurrency(disparity_range.assumed_range(config, width), (height, width))



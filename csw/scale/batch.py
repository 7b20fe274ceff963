"""Many pairs at once: a manifest or two folders in, one map per pair and a JSON summary
out.  A pair that fails is reported in the summary and the others go on.
"""

import csv
import itertools
import json
import os
import tempfile
import time
from array import array
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from ..camera import calibration as calib_module
from ..camera.geometry import check_max_depth
from ..config.params import OptionError
from ..io import safety
from ..io.atomic import atomic_write, remove_temporaries
from ..io.formats import suffixes
from ..io.images import ImageError
from ..io.outputs import check_range_of, role_suffixes
from ..io.progress import progress_bar
from ..matching import disparity_range
from ..matching.matcher import Matcher, resolved
from .executor import run_tasks
from .files import match_files

# A name's outputs add a suffix (".depth.tiff") to it, and a file name holds 255 bytes.
MAX_NAME_BYTES = 200

# Each pair's 3-D outputs are NAME + this + their format: NAME.depth.pfm, NAME.ply ...
PER_PAIR_INFIX = {"preview": ".preview", "confidence": ".confidence", "depth": ".depth",
                  "cloud": "", "depth_preview": ".depth"}


@dataclass(frozen=True)
class Job:
    """One pair to match; ``problem`` is set when the pair can't even be formed.
    ``where``: where the pair came from, for messages (a manifest's line, a file)."""

    name: str
    left: Path
    right: Path | None
    problem: str | None = None
    where: str = ""


def check_name(name, where):
    """A name must be a plain file name: ValueError, saying where it came from, for one
    that is empty, absolute, holds a path separator or '..', or a control character (a
    NUL among them).  Manifests are shared files, and a name must never be a path."""
    problem = None
    if not name:
        problem = "is empty"
    elif any(ord(c) < 32 or ord(c) == 127 for c in name):
        problem = "holds a control character"
    elif "/" in name or "\\" in name or os.sep in name or (os.altsep and os.altsep in name):
        problem = "holds a path separator"
    elif ".." in name:
        problem = "holds '..'"
    elif len(name) >= 2 and name[1] == ":" and name[0].isalpha():
        problem = "starts with a drive letter"
    elif len(name.encode(errors="replace")) > MAX_NAME_BYTES:
        problem = f"is longer than {MAX_NAME_BYTES} bytes"
    if problem:
        shown = repr(name) if len(name) <= 60 else repr(name[:60]) + "..."  # one line
        raise ValueError(f"{where}: the name {shown} {problem}; a pair's name must be a "
                         "plain file name (letters, digits, '-', '_', '.')")


def jobs_from_folders(left_dir, right_dir):
    """Pairs by file name: every image in ``left_dir`` with the same name in ``right_dir``.
    A left image with no partner becomes a failed job, reported like any other."""
    left_dir, right_dir = Path(left_dir), Path(right_dir)
    jobs = []
    images = suffixes("decoded")
    for left in sorted(p for p in left_dir.iterdir() if p.suffix.lower() in images):
        right = right_dir / left.name
        problem = None if right.is_file() else f"no {left.name} in {right_dir}"
        check_name(left.stem, str(left))
        jobs.append(Job(left.stem, left, right if problem is None else None, problem,
                        str(left)))
    if not jobs:
        raise ValueError(f"{left_dir} holds no images ({', '.join(images)})")
    return jobs


HEADER = (["left", "right"], ["left", "right", "name"])


def jobs_from_manifest(path):
    """Pairs from a CSV manifest: ``left,right[,name]`` per record, paths relative to the
    manifest's folder.  CSV quoting, a UTF-8 byte-order mark, blank lines, lines starting
    with '#' and a header line ``left,right,name`` are allowed.  The name (default: the
    left file's stem) names the outputs and must be a plain file name.  ValueError,
    naming the line, on a malformed record or a bad name."""
    path = Path(path)
    safety.protect(path)
    safety.check_input(path, "a manifest file")
    try:
        with open(path, newline="", encoding="utf-8-sig") as handle:
            reader = csv.reader(handle)
            records, start = [], 1
            for fields in reader:  # each record with the line it starts on
                records.append((start, fields))
                start = reader.line_num + 1
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
        raise ValueError(f"{path}: can't read the manifest ({reason})") from None
    jobs = []
    for number, fields in records:
        fields = [f.strip() for f in fields]
        where = f"{path}, line {number}"
        if not any(fields) or fields[0].startswith("#"):
            continue
        if not jobs and [f.lower() for f in fields] in HEADER:
            continue
        if len(fields) not in (2, 3) or not (fields[0] and fields[1]):
            raise ValueError(f"{where}: expected left,right or left,right,name, got "
                             f"{','.join(fields)!r}")
        left, right = (path.parent / f for f in fields[:2])
        name = fields[2] if len(fields) == 3 else left.stem
        check_name(name, where)
        jobs.append(Job(name, left, right, where=where))
    if not jobs:
        raise ValueError(f"{path}: the manifest lists no pairs")
    return jobs


def check_names(jobs):
    """Two pairs must not write the same outputs, nor ones whose names differ only in
    case (they collide on macOS and Windows): ValueError naming the first clash."""
    seen = {}
    for job in jobs:
        key = job.name.casefold()
        if key in seen:
            first = seen[key]
            raise ValueError(f"pairs {first.where or first.left} and {job.where or job.left} "
                             f"would both write {job.name!r}"
                             + ("" if first.name == job.name else
                                f" (as {first.name!r}: names that differ only in case "
                                "collide on macOS and Windows)")
                             + "; give them distinct names in a manifest")
        seen[key] = job


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
    pair's size as its header gives it (csw.matching.matcher.stream_plan), one at a time
    when that can't be read (the pair's own error comes when it is matched).  A range
    found from each pair (or its calib.txt) is planned with csw's one stand-in
    (csw.matching.disparity_range.assumed_range)."""
    from ..io.images import image_header
    from ..matching.matcher import stream_plan

    try:
        height, width = image_header(job.left)[2]
    except (ValueError, OSError, TypeError):
        return 1, config.threads
    return stream_plan(disparity_range.assumed_range(config, width), (height, width))


def first_size(jobs):
    """(width, height) of the first pair whose left image's header can be read, or None:
    the size a batch's rig is for.  A pair that can't be read (a pipe, a damaged file)
    is passed over here and fails alone when its turn comes."""
    from ..io.images import image_header

    for job in jobs:
        if job.problem is None:
            try:
                height, width = image_header(job.left)[2]
                return width, height
            except ValueError:
                continue
    return None


NOTED_KEPT = 20  # notes on pairs (a range cut short...) a batch's report repeats


class PairLog:
    """A batch's summary entries as they come, kept on disk (a temporary file beside the
    summary) with only their offsets, counts and failures in memory: a million-pair
    batch's summary takes a few bytes a pair in this process, not its entries."""

    def __init__(self, folder, total):
        self.handle = tempfile.TemporaryFile(dir=folder if folder.is_dir() else None)
        # Each entry's offset, -1 until it comes; grown as entries come past ``total``
        # (a video's frames, whose count is not known ahead).
        self.offsets = array("q", [-1]) * total
        self.counts = {"ok": 0, "skipped": 0, "failed": 0}
        self.failed = []
        self.noted = []  # (name, note) of the first NOTED_KEPT notes; all are in the summary
        self.notes = 0

    @property
    def done(self):
        return sum(self.counts.values())

    def add(self, index, entry):
        if index >= len(self.offsets):
            self.offsets.extend([-1] * (index + 1 - len(self.offsets)))
        self.offsets[index] = self.handle.seek(0, os.SEEK_END)
        self.handle.write(json.dumps(entry, sort_keys=True, default=str).encode() + b"\n")
        self.counts[entry["status"]] += 1
        if entry["status"] == "failed":
            self.failed.append(entry)
        for note in entry.get("notes", ()):
            self.notes += 1
            if len(self.noted) < NOTED_KEPT:
                self.noted.append((entry["name"], note))

    def lines(self):
        """Each entry's JSON line, in the jobs' order."""
        for offset in self.offsets:
            if offset >= 0:
                self.handle.seek(offset)
                yield self.handle.readline().rstrip(b"\n")

    def close(self):
        self.handle.close()


class SummaryPairs(Sequence):
    """The entries of a summary file, in the jobs' order, read from the file when asked
    for (a batch's report holds no list of them)."""

    def __init__(self, path, count):
        self.path, self.count = Path(path), count

    def __len__(self):
        return self.count

    def __iter__(self):
        with open(self.path, "rb") as handle:
            inside = False
            for line in handle:
                if inside and line.startswith(b"{"):
                    yield json.loads(line.rstrip(b",\n"))
                inside = inside or line.rstrip().endswith(b'"pairs": [')

    def __getitem__(self, index):
        if isinstance(index, slice):
            return list(self)[index]
        index = range(self.count)[index]
        return next(itertools.islice(iter(self), index, None))


def write_summary(path, log, options, interrupted=False, extra=None):
    """Write the JSON summary atomically, one pair a line in the jobs' order, and return
    the report: counts, options, interrupted, failed (the failed pairs' entries), noted
    ((name, note) of the first NOTED_KEPT notes on pairs) and notes (how many), and
    pairs (every entry, read from the summary when asked for); ``extra``: more fields
    for the summary's head (a video's frames a second ...)."""
    head = {"counts": log.counts, "interrupted": interrupted, "options": options,
            **(extra or {})}

    def write(tmp):
        with open(tmp, "wb") as out:
            text = json.dumps(head, indent=2, sort_keys=True, default=str)
            out.write(text[:-2].encode() + b',\n  "pairs": [\n')
            for i, line in enumerate(log.lines()):
                out.write((b",\n" if i else b"") + line)
            out.write(b"\n  ]\n}\n")
    atomic_write(path, write)
    return dict(head, failed=list(log.failed), noted=list(log.noted), notes=log.notes,
                pairs=SummaryPairs(path, log.done))


class signals_held:
    """Within the ``with``, Ctrl-C, SIGTERM and SIGHUP wait: one that comes is acted on
    (by the handler that was in place) when the block ends, so that a frame's outputs
    and its summary entry are written together or not at all.  Outside the main thread,
    where no handler can be set, it does nothing."""

    NAMES = ("SIGINT", "SIGTERM", "SIGHUP")

    def __enter__(self):
        import signal
        import threading

        self.saved, self.caught = {}, []
        if threading.current_thread() is not threading.main_thread():
            return self
        for name in self.NAMES:
            number = getattr(signal, name, None)
            if number is not None:
                self.saved[number] = signal.signal(
                    number, lambda signum, frame: self.caught.append((signum, frame)))
        return self

    def __exit__(self, *exc):
        import signal

        for number, handler in self.saved.items():
            signal.signal(number, handler)
        if self.caught and exc[0] is None:
            signum, frame = self.caught[0]
            handler = self.saved.get(signum)
            if callable(handler):
                handler(signum, frame)  # raises KeyboardInterrupt, or csw's Stopped
            elif handler == signal.SIG_DFL:
                signal.raise_signal(signum)
        return False

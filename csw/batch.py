"""Many pairs at once: a manifest or two folders in, one map per pair and a JSON summary
out.  A pair that fails is reported in the summary and the others go on.
"""

import csv
import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

from .executor import progress_bar, run_tasks
from .io.atomic import atomic_write, remove_temporaries
from .io.formats import check_range, suffixes, write_disparity
from .io.images import ImageError, read_image
from .params import OptionError, resolve
from .whole import match


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
    if problem:
        raise ValueError(f"{where}: the name {name!r} {problem}; a pair's name must be a "
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


def check_outputs(jobs, outputs, out_dir, summary):
    """Before any work: every output (per job, a dict of role -> path) resolves, links
    followed, to a file directly in ``out_dir``, and neither an output nor the summary is
    an input of the batch.  ValueError (one line) naming the first offender."""
    inputs = {}
    for job in jobs:
        for side in (job.left, job.right):
            if side is not None:
                inputs.setdefault(os.path.realpath(side), job)
    for job, paths in zip(jobs, outputs, strict=True):
        for path in paths.values():
            if not _inside(path, out_dir):
                raise ValueError(f"{job.where or job.left}: {path} resolves to "
                                 f"{os.path.realpath(path)}, outside the output folder "
                                 f"{out_dir}; csw won't write there")
            owner = inputs.get(os.path.realpath(path))
            if owner is not None:
                raise ValueError(f"{job.where or job.left}: the output {path} is an input "
                                 f"of {owner.where or owner.left}; an output must not "
                                 "overwrite an input")
    owner = inputs.get(os.path.realpath(summary))
    if owner is not None:
        raise OptionError("summary", f"the summary {summary} is an input of "
                                     f"{owner.where or owner.left}")


def run_job(task, **match_options):
    """Match one pair, a (Job, output path) task, and write its map; returns a summary
    entry (never raises for a bad pair: the error is in the entry)."""
    job, output = task
    entry = {"name": job.name, "left": str(job.left),
             "right": str(job.right) if job.right else None, "output": str(output)}
    start = time.perf_counter()
    try:
        if job.problem:
            raise ValueError(job.problem)
        left, right = read_image(job.left), read_image(job.right)
        result = match(left, right, **match_options)
        write_disparity(output, result.disparity)
    except (ImageError, ValueError, OSError) as exc:
        message = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        return dict(entry, status="failed", error=message)
    return dict(entry, status="ok", seconds=time.perf_counter() - start,
                match_seconds=result.seconds, invalid=100.0 * result.invalid_share,
                work_saved=100.0 * result.work_saved)


def match_many(jobs, out_dir, *, suffix=".pfm", overwrite=False, progress=True,
               summary=None, client=None, **match_options):
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
    progress : bool
        A progress bar on stderr.
    summary : path, optional
        Where to write the JSON summary (default ``out_dir/summary.json``).
    client : dask.distributed.Client, optional
        Run each pair as a task on this cluster: the workers read the images and write
        the maps; a worker that dies has its tasks rerun elsewhere (writes are atomic, so
        a rerun never leaves a partial map).  See :func:`csw.distributed.local_client`.
    **match_options
        As for :func:`csw.match`.

    Returns
    -------
    dict
        The summary: ``counts`` (ok, skipped, failed), ``pairs`` (one entry each, in the
        jobs' order, with ``status`` and, for failures, ``error``) and ``options``.
    """
    if suffix not in suffixes("whole"):
        raise ValueError(f"suffix must be one of {', '.join(suffixes('whole'))}, got "
                         f"{suffix!r}")
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise OptionError("output_dir", f"{out_dir} exists and is not a folder")
    resolved = resolve(**match_options)  # bad options fail before any work
    try:
        check_range(f"map{suffix}", resolved["dmax"], resolved["dmin"])
    except ValueError as exc:
        raise OptionError("dmax", str(exc)) from None
    check_names(jobs)
    summary = Path(summary) if summary else out_dir / "summary.json"
    outputs = [{"map": out_dir / f"{job.name}{suffix}"} for job in jobs]
    check_outputs(jobs, outputs, out_dir, summary)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OptionError("output_dir", f"can't create the folder {out_dir} "
                                        f"({exc.strerror or exc})") from None
    entries = {}
    todo = []
    for i, (job, paths) in enumerate(zip(jobs, outputs, strict=True)):
        output = paths["map"]
        if output.exists() and not overwrite:
            entries[i] = {"name": job.name, "left": str(job.left), "right": str(job.right),
                          "output": str(output), "status": "skipped"}
        else:
            todo.append((i, job, output))
    bar = progress_bar(len(jobs), "csw match", "pair", progress, initial=len(entries))
    try:
        tasks = [(job, output) for _, job, output in todo]
        for k, entry in run_tasks(run_job, tasks, client, **match_options):
            entries[todo[k][0]] = entry
            bar.update()
    except KeyboardInterrupt:
        # What finished is complete on disk: say so, marked as interrupted, and stop.
        write_summary(summary, [entries[i] for i in sorted(entries)], resolved,
                      interrupted=True)
        raise
    finally:
        bar.close()
    # Every task has finished: a temporary file still beside an output was left by a
    # worker killed mid-write (its task was rerun elsewhere), so it can go.
    for _, _, output in todo:
        remove_temporaries(output)
    return write_summary(summary, [entries[i] for i in sorted(entries)], resolved)


def write_summary(path, entries, resolved, interrupted=False):
    """Write the JSON summary atomically and return it."""
    counts = {status: sum(e["status"] == status for e in entries)
              for status in ("ok", "skipped", "failed")}
    report = {"counts": counts, "options": resolved, "pairs": entries,
              "interrupted": interrupted}
    text = json.dumps(report, indent=2, sort_keys=True, default=str)
    atomic_write(path, lambda tmp: Path(tmp).write_text(text + "\n"))
    return report

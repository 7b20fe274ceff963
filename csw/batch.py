"""Many pairs at once: a manifest or two folders in, one map per pair and a JSON summary
out.  A pair that fails is reported in the summary and the others go on.
"""

import csv
import json
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
    """One pair to match; ``problem`` is set when the pair can't even be formed."""

    name: str
    left: Path
    right: Path | None
    problem: str | None = None


def jobs_from_folders(left_dir, right_dir):
    """Pairs by file name: every image in ``left_dir`` with the same name in ``right_dir``.
    A left image with no partner becomes a failed job, reported like any other."""
    left_dir, right_dir = Path(left_dir), Path(right_dir)
    jobs = []
    images = suffixes("decoded")
    for left in sorted(p for p in left_dir.iterdir() if p.suffix.lower() in images):
        right = right_dir / left.name
        problem = None if right.is_file() else f"no {left.name} in {right_dir}"
        jobs.append(Job(left.stem, left, right if problem is None else None, problem))
    if not jobs:
        raise ValueError(f"{left_dir} holds no images ({', '.join(images)})")
    return jobs


def jobs_from_manifest(path):
    """Pairs from a CSV manifest: ``left,right[,name]`` per line, paths relative to the
    manifest's folder, '#' lines and blank lines ignored.  The name (default: the left
    file's stem) names the output.  ValueError, naming the line, on a malformed one."""
    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: can't read the manifest ({exc})") from None
    jobs = []
    for number, fields in enumerate(csv.reader(text.splitlines()), start=1):
        fields = [f.strip() for f in fields]
        if not fields or not fields[0] or fields[0].startswith("#"):
            continue
        if len(fields) not in (2, 3) or not all(fields):
            raise ValueError(f"{path}, line {number}: expected left,right or "
                             f"left,right,name, got {','.join(fields)!r}")
        left, right = (path.parent / f for f in fields[:2])
        jobs.append(Job(fields[2] if len(fields) == 3 else left.stem, left, right))
    if not jobs:
        raise ValueError(f"{path}: the manifest lists no pairs")
    return jobs


def check_names(jobs):
    """Two pairs must not write the same output: ValueError naming the first clash."""
    seen = {}
    for job in jobs:
        if job.name in seen:
            raise ValueError(f"pairs {seen[job.name]} and {job.left} would both write "
                             f"{job.name!r}; give them names in a manifest")
        seen[job.name] = job.left


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
        An existing folder (on a cluster: one every worker can write).
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
    if not out_dir.is_dir():
        raise ValueError(f"{out_dir} is not a folder; create it first")
    check_names(jobs)
    resolved = resolve(**match_options)  # bad options fail before any work
    try:
        check_range(f"map{suffix}", resolved["dmax"])
    except ValueError as exc:
        raise OptionError("dmax", str(exc)) from None
    summary = Path(summary) if summary else out_dir / "summary.json"
    entries = {}
    todo = []
    for i, job in enumerate(jobs):
        output = out_dir / f"{job.name}{suffix}"
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

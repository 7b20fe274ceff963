"""The pairs of a batch: :class:`Job`, from two folders (pairs by file name) or a
manifest (CSV: left, right[, name]), each name checked as a file name its outputs can
take."""

import csv
import os
from dataclasses import dataclass
from pathlib import Path

from ..io import safety
from ..io.formats import suffixes

# A name's outputs add a suffix (".depth.tiff") to it, and a file name holds 255 bytes.
MAX_NAME_BYTES = 200


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

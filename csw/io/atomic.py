"""Atomic writes: every file csw writes goes to a temporary file beside its target and is
renamed into place, so a failure or an interrupt never leaves a partial file behind."""

import os
import tempfile
from pathlib import Path

TMP_PREFIX = ".csw-tmp."  # temporary files: .csw-tmp.<name>.<random>.tmp beside the target
STALE_SECONDS = 24 * 3600  # a temporary file this old was left by a killed process


def _mode_for(path):
    """The mode a plain open() would give ``path``: an existing file keeps its own, a new
    one gets 0666 less the umask (mkstemp's files are 0600 whatever the umask)."""
    try:
        return os.stat(path).st_mode & 0o7777
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def _clean_stale(directory, name):
    """Remove this target's temporary files that a killed process left behind (older
    than a day, so that a concurrent writer's file is never touched)."""
    import time

    now = time.time()
    for old in Path(directory).glob(f"{TMP_PREFIX}{name}.*.tmp"):
        try:
            if now - old.stat().st_mtime > STALE_SECONDS:
                old.unlink()
        except OSError:
            pass


def remove_temporaries(path):
    """Remove every temporary file of target ``path``, whatever its age: for a caller that
    knows no writer of it is still running (a batch whose tasks have all finished, after
    a killed worker left one behind)."""
    path = Path(path)
    for tmp in path.parent.glob(f"{TMP_PREFIX}{path.name}.*.tmp"):
        try:
            tmp.unlink()
        except OSError:
            pass


def atomic_write(path, write_to):
    """Write ``path`` by calling ``write_to(tmp_path)`` then renaming, so a failure or an
    interrupt never leaves a partial file at ``path``.

    The file gets the mode a normal write gives (an existing file's, else 0666 less the
    umask); a symlink is followed, and its target written (atomically) in place.
    """
    atomic_write_all([(path, write_to)])


def atomic_write_all(items):
    """Several files as one: every ``(path, write_to)`` is written to its temporary file
    first, and only when all succeeded are they renamed into place, so an error or a
    Ctrl-C leaves either all of them or none (save for the instant of the renames)."""
    staged = []
    try:
        for path, write_to in items:
            path = Path(os.path.realpath(path)) if os.path.islink(path) else Path(path)
            directory = path.parent if str(path.parent) else Path(".")
            _clean_stale(directory, path.name)
            fd, tmp = tempfile.mkstemp(prefix=f"{TMP_PREFIX}{path.name}.", suffix=".tmp",
                                       dir=directory)
            os.close(fd)
            staged.append((tmp, path))
            write_to(tmp)
            os.chmod(tmp, _mode_for(path))
        for tmp, path in staged:
            os.replace(tmp, path)
    except BaseException:
        for tmp, _ in staged:
            if os.path.exists(tmp):
                os.unlink(tmp)
        raise



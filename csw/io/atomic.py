"""Atomic writes: every file csw writes goes to a temporary file beside its target and is
renamed into place, so a failure, an interrupt or a signal never leaves a partial file
behind; and every target passes :func:`csw.io.safety.check_target` first, so a write
never replaces an input, a device or anything but a regular file.

Temporary files and folders are named ``.csw-tmp.<name>.<host>-<pid>-<random>.tmp``:
the writer's host and process, so that the next csw run that writes into the folder
removes what a killed process (``kill -9``, a crash) left there, at once; one whose
writer can't be known (another host's, an older csw's) goes once it is a day old.
"""

import hashlib
import os
import re
import shutil
import socket
import tempfile
import time
from pathlib import Path

from . import safety

TMP_PREFIX = ".csw-tmp."
STALE_SECONDS = 24 * 3600  # a temporary file this old was left by a killed process
NAME_BYTES = 96  # of the target's name kept in a temporary's: the whole must fit 255
HOST = hashlib.sha256(socket.gethostname().encode()).hexdigest()[:8]
_TEMPORARY = re.compile(r"^\.csw-tmp\.(?P<name>.*)\.(?P<host>[0-9a-f]{8})-(?P<pid>\d+)-"
                        r"[A-Za-z0-9_]+\.tmp$", re.DOTALL)
_SWEPT = set()  # (pid, folder): swept once per process, not once per file written


def mode_for(path):
    """The mode a plain open() would give ``path``: an existing file keeps its own, a new
    one gets 0666 less the umask (mkstemp's files are 0600 whatever the umask)."""
    try:
        return os.stat(path).st_mode & 0o7777
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def _short(name):
    """The target's name as a temporary's name holds it: at most NAME_BYTES bytes (the
    file system's bytes: a name that is not UTF-8 comes from Python as surrogates)."""
    return os.fsencode(name)[:NAME_BYTES].decode(errors="ignore")


def temporary_prefix(name):
    """The prefix of a temporary file or folder for target ``name``, by this process."""
    return f"{TMP_PREFIX}{_short(name)}.{HOST}-{os.getpid()}-"


def make_temporary_dir(folder, name):
    """A new temporary folder beside target ``name`` in ``folder`` (removed by the next
    run if this process dies before it does)."""
    sweep(folder)
    return Path(tempfile.mkdtemp(prefix=temporary_prefix(name), suffix=".tmp", dir=folder))


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # someone else's process: alive
        return True
    return True


def _leftover(entry, now):
    """Whether directory entry ``entry`` is a temporary whose writer is gone."""
    found = _TEMPORARY.match(entry.name)
    if found and found["host"] == HOST and int(found["pid"]) != os.getpid():
        return not _alive(int(found["pid"]))
    if found and found["host"] == HOST:
        return False  # this process's own, in use
    try:
        return now - entry.stat(follow_symlinks=False).st_mtime > STALE_SECONDS
    except OSError:
        return False


def _remove(entry):
    try:
        if entry.is_dir(follow_symlinks=False):
            shutil.rmtree(entry.path, ignore_errors=True)
        else:
            os.unlink(entry.path)
    except OSError:
        pass


def sweep(folder):
    """Remove the temporaries in ``folder`` that killed writers left behind (see the
    module's docstring); once per process and folder."""
    folder = Path(folder) if str(folder) else Path(".")
    key = (os.getpid(), os.path.realpath(folder))
    if key in _SWEPT:
        return
    _SWEPT.add(key)
    now = time.time()
    try:
        with os.scandir(folder) as entries:
            for entry in entries:
                if entry.name.startswith(TMP_PREFIX) and _leftover(entry, now):
                    _remove(entry)
    except OSError:
        pass


def remove_temporaries(paths):
    """Remove every temporary of the target ``paths`` (one path, or many), whatever their
    writers: for a caller that knows no writer of them is still running (a batch whose
    tasks have all finished, after a killed worker left one behind).  Names are
    compared, never globbed, and each folder is listed once."""
    folders = {}
    for path in [paths] if isinstance(paths, (str, os.PathLike)) else paths:
        path = Path(path)
        folders.setdefault(path.parent, set()).add(_short(path.name))
    for folder, names in folders.items():
        try:
            with os.scandir(folder if str(folder) else ".") as entries:
                for entry in entries:
                    found = _TEMPORARY.match(entry.name)
                    if found and found["name"] in names:
                        _remove(entry)
        except OSError:
            pass


def atomic_write(path, write_to):
    """Write ``path`` by calling ``write_to(tmp_path)`` then renaming, so a failure or an
    interrupt never leaves a partial file at ``path``.

    The file gets the mode a normal write gives (an existing file's, else 0666 less the
    umask); a symlink to a regular file is followed, and its target written
    (atomically) in place.
    """
    atomic_write_all([(path, write_to)])


def atomic_write_all(items):
    """Several files as one: every ``(path, write_to)`` is written to its temporary file
    first, and only when all succeeded are they renamed into place, so an error or a
    Ctrl-C leaves either all of them or none (save for the instant of the renames).
    OSError naming the file when a write fails; ValueError (before anything is
    written) for a target that is not to be written (csw.io.safety.check_target)."""
    targets = []
    for path, _ in items:
        safety.check_target(path)
        targets.append(Path(os.path.realpath(path)) if os.path.islink(path) else Path(path))
    staged = []
    try:
        for path, (_, write_to) in zip(targets, items, strict=True):
            directory = path.parent if str(path.parent) else Path(".")
            sweep(directory)
            fd, tmp = tempfile.mkstemp(prefix=temporary_prefix(path.name), suffix=".tmp",
                                       dir=directory)
            os.close(fd)
            staged.append((tmp, path))
            try:
                write_to(tmp)
            except OSError as exc:  # named as the user knows it, not as the temporary
                if exc.errno is not None and exc.filename in (None, tmp):
                    raise OSError(exc.errno, exc.strerror, str(path)) from None
                raise
            os.chmod(tmp, mode_for(path))
        for tmp, path in staged:
            os.replace(tmp, path)
    except BaseException:
        for tmp, _ in staged:
            if os.path.exists(tmp):
                os.unlink(tmp)
        raise

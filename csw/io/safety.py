"""What csw may write: the one check every output passes.

A run names its outputs; everything else it touches is an input, and csw never writes
over an input, a device, a pipe or anything but a regular file (a zarr store: a folder
csw wrote).  Two layers hold this:

- :func:`check_outputs`, before any work: each output's suffix fits its role, its folder
  exists and can be written, it is not an input of the run nor another output, and it
  is a regular file (or not there yet);
- :func:`check_target`, at every write (csw.io.atomic): the same last two rules, against
  every file the run has read so far.  Readers :func:`protect` what they read (images,
  maps, calibrations, manifests, dataset files) while a run is :func:`guarding`, as
  every ``csw`` command is, so a plot, a depth map or a summary can't land on one.
"""

import contextlib
import os
import stat
from pathlib import Path

_GUARDED = []  # one set of input paths (realpaths) per active guarding() scope


@contextlib.contextmanager
def guarding():
    """Within the ``with``, every path given to :func:`protect` is an input that no write
    may replace (the csw command group runs each command inside one)."""
    _GUARDED.append(set())
    try:
        yield
    finally:
        _GUARDED.pop()


def protect(path):
    """Count ``path`` (a file the run reads) as an input, if a run is guarding."""
    if _GUARDED and isinstance(path, (str, os.PathLike)):
        _GUARDED[-1].add(os.path.realpath(path))


def option_error(message, option=None):
    from ..config.params import OptionError

    return OptionError(option, message)


def kind_of(path):
    """What is at ``path``, links followed: None (nothing), "file", "folder", or the
    special kind ("device", "pipe", "socket") that csw never writes."""
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError:
        return "file"  # unreadable metadata: the write itself will say why
    if stat.S_ISREG(mode):
        return "file"
    if stat.S_ISDIR(mode):
        return "folder"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "device"
    return "pipe" if stat.S_ISFIFO(mode) else "socket"


def check_input(path, what, error=ValueError):
    """``error`` ("... is a pipe, not WHAT") when ``path`` is a pipe, a device or a
    socket: reading one would wait for ever, or never end (/dev/zero)."""
    kind = kind_of(path)
    if kind not in (None, "file", "folder"):
        raise error(f"{path} is a {kind}, not {what}")


# A calibration, a rig, a calib.txt: a few lines.  A larger file is not one, and reading
# it whole (/dev/zero has no end) must not be what finds that out.
SMALL_FILE_BYTES = 1 << 20


def check_small(path, what, error=ValueError, limit=SMALL_FILE_BYTES):
    """``error`` naming ``path`` unless it is a regular file of at most ``limit`` bytes:
    judged by os.stat, before anything opens it, so a pipe or a device is refused
    rather than waited on or read without end."""
    protect(path)
    kind = kind_of(path)
    if kind is None:
        raise error(f"{path}: no such file")
    if kind != "file":
        raise error(f"{path} is a {kind}, not {what}")
    try:
        size = os.stat(path).st_size
    except OSError as exc:
        raise error(f"{path}: can't read it ({exc.strerror or exc})") from None
    if size > limit:
        raise error(f"{path}: {size} bytes is too large for {what} (at most {limit})")


def read_small(path, what, error=ValueError, limit=SMALL_FILE_BYTES):
    """The bytes of a small input (a calibration, a rig file), after :func:`check_small`.
    Opened without blocking and read to at most ``limit`` bytes, so that a file swapped
    for a pipe or grown since the check can't hang the run or fill its memory."""
    check_small(path, what, error, limit)
    try:
        handle = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
        with os.fdopen(handle, "rb") as f:
            regular = stat.S_ISREG(os.fstat(f.fileno()).st_mode)
            data = f.read(limit + 1) if regular else b""
    except OSError as exc:
        raise error(f"{path}: can't read it ({exc.strerror or exc})") from None
    if not regular or len(data) > limit:
        raise error(f"{path} changed while it was read; not {what}")
    return data


def check_target(path, option=None, folder_ok=False):
    """ValueError (an OptionError naming ``option``) unless ``path`` may be written: not
    an input of a guarding run, and a regular file or nothing yet (a folder only with
    ``folder_ok``: a zarr store).  A symlink is judged by what it points to."""
    kind = kind_of(path)
    if kind not in (None, "file") and not (kind == "folder" and folder_ok):
        link = f" (a link to {os.path.realpath(path)})" if os.path.islink(path) else ""
        raise option_error(f"{path}{link} is a {kind}, not a regular file; csw writes only "
                     "regular files", option)
    real = os.path.realpath(path)
    if any(real in inputs for inputs in _GUARDED):
        raise option_error(f"{path} is an input of this run; an output must not overwrite an "
                     "input", option)


def check_outputs(inputs, outputs, allowed):
    """Before any work: every output (name -> path or None) has a suffix its role allows
    (``allowed``: name -> suffixes), lies in a folder that exists and can be written, is
    a regular file or nothing yet (a zarr store may be a folder), and overwrites neither
    an input (name -> path or None) nor another output.  OptionError naming the
    output."""
    seen = {}
    for name, path in inputs.items():
        if path is not None:
            protect(path)
            seen[os.path.realpath(path)] = name
    for name, path in outputs.items():
        if path is None:
            continue
        path = Path(path)
        suffix = path.suffix.lower()
        if path.is_dir() and suffix != ".zarr":  # said first: a folder has no extension
            raise option_error(f"{str(path)!r} is a folder; give a file name", name)
        if suffix not in allowed[name]:
            raise option_error(f"unknown extension {path.suffix or '(none)'!r}; use "
                         f"{', '.join(allowed[name])}", name)
        folder = path.parent if str(path.parent) else Path(".")
        if not folder.is_dir():
            raise option_error(f"folder {str(folder)!r} does not exist; create it first", name)
        if not os.access(folder, os.W_OK):
            raise option_error(f"folder {str(folder)!r} is not writable", name)
        store = suffix == ".zarr" and (path / "zarr.json").is_file()
        if path.is_dir() and not store:
            raise option_error(f"{str(path)!r} is a directory", name)
        check_target(path, name, folder_ok=store)
        key = os.path.realpath(path)
        if key in seen:
            raise option_error(f"{path} is also given as {seen[key]}; an output must not "
                         "overwrite an input or another output", name)
        seen[key] = name


def check_space(needs):
    """Before any work: ValueError when the outputs would not fit their disks.  needs:
    (path, bytes) pairs, an upper bound of each output's size (the temporary files a
    run keeps beside its outputs counted in)."""
    import shutil

    by_disk = {}
    for path, size in needs:
        folder = Path(path).resolve().parent
        while not folder.is_dir() and folder != folder.parent:  # a folder to be made
            folder = folder.parent
        try:
            disk = os.stat(folder).st_dev
        except OSError:
            continue  # check_outputs has said what is wrong with the folder
        by_disk.setdefault(disk, [folder, 0])[1] += int(size)
    for folder, size in by_disk.values():
        free = shutil.disk_usage(folder).free
        if size > free:
            raise option_error(f"the outputs need up to {_mb(size)} on the disk of {folder}, "
                         f"which has {_mb(free)} free; free some space or write them "
                         "elsewhere")


def _mb(size):
    return f"{size / 2**20:.1f} MiB" if size < 2**30 else f"{size / 2**30:.1f} GiB"

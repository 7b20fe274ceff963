"""The ``csw`` command group: a thin group, one module per command in commands/, each
imported only when it runs (a command's imports are what its start-up costs)."""

import functools
import importlib
import os
import signal
import sys
import threading

import click

# Command name -> (module in commands/, function), with its one-line help: `csw --help`
# lists them without importing any.
COMMANDS = {
    # What a newcomer needs first ...
    "match": ("match", "match", "Compute disparity maps for rectified pairs."),
    "depth": ("depth", "depth", "Turn a disparity map into depth, with a calibration."),
    "cloud": ("depth", "cloud", "Turn a disparity map into a point cloud (PLY)."),
    "rectify": ("rectify", "rectify", "Undistort and rectify a raw pair from a calibrated "
                                      "rig."),
    "calibrate": ("calibrate", "calibrate", "Calibrate a stereo rig from chessboard pairs."),
    "info": ("info", "info", "List a robot log's image topics (ROS bags, MCAP, KITTI)."),
    "synth": ("synth", "synth", "Write a synthetic stereo pair with exact ground truth."),
    "score": ("score", "score", "Score a disparity map against ground truth."),
    # ... then benchmarks, experiments and set-up.
    "bench": ("bench", "bench", "Score and time plain vs CSW matching (the paper's TABLE II)."),
    "datasets": ("datasets", "datasets", "List the registered datasets."),
    "sweep": ("sweep", "sweep", "Sweep tau and CSW rules: work saved against bad-1."),
    "hist": ("hist", "hist", "Histogram of the minimum-cost map m (the paper's Fig. 9)."),
    "compile": ("compile", "compile_", "Compile every documented option's kernels ahead (CI, "
                                       "Docker)."),
}
# Listed as "Commands"; the rest after them.
FIRST = ["match", "depth", "cloud", "rectify", "calibrate", "info", "synth", "score"]


class LazyGroup(click.Group):
    """A group whose commands are imported when they are run or asked for help."""

    def list_commands(self, ctx):
        return list(COMMANDS)

    def get_command(self, ctx, name):
        if name not in COMMANDS:
            return None
        module, function, short_help = COMMANDS[name]
        command = getattr(importlib.import_module(f".commands.{module}", __package__),
                          function)
        command.short_help = short_help
        return command

    def invoke(self, ctx):
        # Every file a command reads is an input that none of its writes may replace
        # (csw.io.safety), whatever the command.
        from csw.io.safety import guarding

        try:
            with guarding():
                return super().invoke(ctx)
        except Stopped as exc:
            if exc.signum == signal.SIGINT:
                raise  # Click closes the terminal's ^C echo with a blank line
            raise _Ended(exc.signum) from None  # past Click, which would print one too

    def format_commands(self, ctx, formatter):
        for title, names in (("Commands", FIRST),
                             ("Benchmarks, experiments and set-up",
                              [n for n in COMMANDS if n not in FIRST])):
            with formatter.section(title):
                formatter.write_dl([(name, COMMANDS[name][2]) for name in names])


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="csw-stereo", prog_name="csw")
def cli():
    """Stereo matching with the Constrained Sliding Window (CSW) algorithm.

    \b
    Examples:
      csw synth out/scene
      csw match out/scene/left.png out/scene/right.png -o out/disp.pfm --preview out/disp.png
      csw match left.png right.png -o disp.pfm --depth depth.pfm --calib calib.txt
    """



class _Ended(BaseException):
    """A run stopped by SIGTERM or SIGHUP, its clean-up done: carried past Click's
    handlers (which print a blank line for a KeyboardInterrupt) to main's one line."""

    def __init__(self, signum):
        super().__init__(signum)
        self.signum = signum


class Stopped(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised in the main thread as Ctrl-C is, so that every path that
    cleans up after a Ctrl-C (temporary files, a batch's summary, a cluster's tasks)
    does so for them too."""

    def __init__(self, signum):
        super().__init__(signum)
        self.signum = signum


SIGNALS = ("SIGINT", "SIGTERM", "SIGHUP")
_ARMED = set()  # the signals stop_on_signals handles (the others stay ignored)


def _stop(signum, frame):
    if _under_llvmlite(frame):
        # Inside compiled code's callback (llvmlite's object cache, Numba's hooks under
        # it), an exception would cut the hook short and be dropped: deliver the signal
        # again a moment later, outside it.
        threading.Timer(0.05, os.kill, (os.getpid(), signum)).start()
        return
    _hold_through_clean_up()
    raise Stopped(signum)


def _under_llvmlite(frame):
    while frame is not None:
        if "llvmlite" in frame.f_code.co_filename:
            return True
        frame = frame.f_back
    return False


def _dropped(unraisable, previous):
    """sys.unraisablehook while the handlers are armed.  A Stopped raised where Python
    drops exceptions (a __del__, a weakref or ctypes callback) stopped nothing, yet the
    handlers now ignore every signal: arm them again and deliver the signal once more, a
    moment later, so the run stops, and no traceback is printed.  Anything else goes to
    the hook that was there before."""
    stopped = unraisable.exc_value
    if not isinstance(stopped, Stopped) or \
            threading.current_thread() is not threading.main_thread():
        return previous(unraisable)
    for number in _ARMED:
        signal.signal(number, _stop)
    threading.Timer(0.05, os.kill, (os.getpid(), stopped.signum)).start()


def _hold_through_clean_up():
    """From the first signal on, the run is cleaning up (temporaries removed, a summary
    written): a second Ctrl-C or SIGTERM must not cut that short nor change the exit
    code, so the rest are ignored.  Ignored, not handled: an ignored signal stays so
    while the interpreter shuts down, where a handler is reset to the default (death
    by the signal)."""
    for name in SIGNALS:
        number = getattr(signal, name, None)
        if number is not None:
            signal.signal(number, signal.SIG_IGN)


def stop_on_signals():
    """Ctrl-C, SIGTERM (a scheduler ending a job) and SIGHUP (a closed terminal) stop the
    work: nothing partial stays, and the exit code is 128 + the first signal's number
    (see _hold_through_clean_up).  A signal the process was started with ignored stays
    ignored, as Python leaves SIGINT: ``nohup csw ...`` must outlive its terminal, and
    a job started in the background is not stopped by the terminal's Ctrl-C."""
    for name in SIGNALS:
        number = getattr(signal, name, None)
        if number is not None and signal.getsignal(number) != signal.SIG_IGN:
            signal.signal(number, _stop)
            _ARMED.add(number)
    if _ARMED and getattr(sys.unraisablehook, "func", None) is not _dropped:
        sys.unraisablehook = functools.partial(_dropped, previous=sys.unraisablehook)


def _quiet_stdout():
    """Point standard output at /dev/null, so that the interpreter's last flush of what
    could not be written raises nothing more."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def _standard_streams():
    """/dev/null in place of a standard stream the caller closed (``>&-``, ``2>&-``):
    else the first file csw opens takes its descriptor, and what is written to the
    stream (an error on stderr) goes into that file, or Python, which sets the stream to
    None, fails where it flushes it."""
    for fd, name, mode in ((0, "stdin", os.O_RDONLY), (1, "stdout", os.O_WRONLY),
                           (2, "stderr", os.O_WRONLY)):
        try:
            os.fstat(fd)
            continue
        except OSError:
            pass
        try:
            devnull = os.open(os.devnull, mode)
            if devnull != fd:
                os.dup2(devnull, fd)
                os.close(devnull)
        except OSError:
            continue
        if getattr(sys, name) is None:
            setattr(sys, name, os.fdopen(fd, "r" if fd == 0 else "w", closefd=False))


def main(args=None):
    """The ``csw`` entry point: the group, with Ctrl-C, SIGTERM and SIGHUP reported as an
    interrupt (exit 128 + the signal, one line) instead of Click's "Aborted!" and exit
    1.  Outputs are written through temporary files, so an interrupted run leaves none
    behind."""
    _standard_streams()
    stop_on_signals()
    try:
        code = cli.main(args=args, prog_name="csw", standalone_mode=False)
        sys.stdout.flush()  # here, where a full disk or a closed pipe can be reported
    except OSError as exc:
        _quiet_stdout()
        where = "can't write standard output" if exc.filename is None else exc.filename
        click.echo(f"Error: {where}: {exc.strerror or exc}", err=True)
        sys.exit(1)
    except click.exceptions.Abort as exc:
        if isinstance(exc.__context__, EOFError):  # Click's Abort for an EOFError: a file
            click.echo("Error: a file ended before its data did "  # ended, not a Ctrl-C
                       f"({exc.__context__ or 'unexpected end of file'})", err=True)
            sys.exit(1)
        _interrupted(getattr(exc.__context__, "signum", signal.SIGINT))
    except (KeyboardInterrupt, _Ended) as exc:
        _interrupted(getattr(exc, "signum", signal.SIGINT))
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.ClickException as exc:
        exc.show()
        sys.exit(exc.exit_code)
    sys.exit(code if isinstance(code, int) else 0)


def _interrupted(signum):
    """Say how the run ended, and exit 128 + the signal's number."""
    _hold_through_clean_up()  # the clean-up is done: go quietly
    what = "interrupted" if signum == signal.SIGINT else \
        f"stopped by {signal.Signals(signum).name}"
    click.echo(f"csw: {what}; no partial file was left", err=True)
    sys.exit(128 + signum)

"""Children that a test interrupts with a signal.

A suite started in the background (``make test &``, ``nohup make test``, many CI
wrappers) runs with SIGINT ignored, and under nohup SIGHUP too, and a child inherits
that. csw keeps a signal ignored that it was started with ignored, as Unix programs do
(``nohup csw ...`` must survive a closed terminal), so a test that means to interrupt
its child gives it the default handlers back first."""

import signal
import subprocess

SIGNALS = ("SIGINT", "SIGTERM", "SIGHUP")


def default_signals():
    """Run in the child before it execs: every signal a test sends, at its default."""
    for name in SIGNALS:
        signal.signal(getattr(signal, name), signal.SIG_DFL)


def interruptible(command, **kwargs):
    """``subprocess.Popen(command, **kwargs)`` whose child acts on SIGINT, SIGTERM and
    SIGHUP however this suite was started."""
    return subprocess.Popen(command, preexec_fn=default_signals, **kwargs)

"""What the report scripts in scripts/ share: the date, the CPU, number formatting, and
the csw command line that reruns a library call (printed in the reports)."""

import datetime
import platform
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path


def now_utc():
    return datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")


def cpu_name():
    """The CPU's model name from /proc/cpuinfo, or what platform knows."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def spread(values, digits=2, sep=" / "):
    """min / median / max of a list of figures, for a Markdown table."""
    return sep.join(f"{v:.{digits}f}" for v in (min(values), statistics.median(values),
                                                  max(values)))


TEMPLATES = Path(__file__).resolve().parent / "templates"


def template_blocks(name):
    """The blocks of scripts/templates/NAME.md, by name: each starts after a line
    ``<!-- block -->`` and is a str.format template, its fields the report's figures."""
    parts = re.split(r"^<!-- (\w+) -->\n", (TEMPLATES / f"{name}.md").read_text(),
                     flags=re.MULTILINE)
    return dict(zip(parts[1::2], parts[2::2], strict=True))


def fill_template(name, blocks):
    """The report from template NAME: each (block, fields) of ``blocks`` in turn, its
    fields filled in; a report leaves out the blocks it has no figures for."""
    text = template_blocks(name)
    return "".join(text[block].format(**fields) for block, fields in blocks)


def fmt(value, digits=2):
    """A number for a Markdown table; blank for None."""
    return "" if value is None else f"{value:.{digits}f}"


# Library keyword -> the csw flag that sets it, where the names differ.
FLAGS = {"costs": "--cost", "engines": "--engine", "rules": "--csw-rule"}


def command(name, datasets, options):
    """The csw command that does what a library call with these options did."""
    words = ["csw", name] + [w for d in datasets for w in ("-d", d)]
    for key, value in options.items():
        if value is None or value is False:
            continue
        flag = FLAGS.get(key, "--" + key.replace("_", "-"))
        if value is True:
            words.append(flag)
        else:
            words += [flag, ",".join(map(str, value)) if isinstance(value, (list, tuple))
                      else str(value)]
    return " ".join(words)


PEAK_PROBE = """
import resource, subprocess, sys
subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
"""


def peak_memory_mb(options=()):
    """Peak resident memory (MB) of `csw match OPTIONS` on the 1080p synthetic pair,
    d 0..255, all threads, in a process of its own."""
    from csw.data.synth import render
    from csw.io import write_png

    left, right, _, _ = render(1920, 1080, dmax=255, seed=0)
    with tempfile.TemporaryDirectory() as tmp:
        write_png(f"{tmp}/l.png", left)
        write_png(f"{tmp}/r.png", right)
        cmd = ["csw", "match", f"{tmp}/l.png", f"{tmp}/r.png", "-o", f"{tmp}/d.pfm",
               "--dmax", "255", *options]
        out = subprocess.run([sys.executable, "-c", PEAK_PROBE, *cmd], check=True,
                             capture_output=True, text=True)
    return int(out.stdout.strip()) / 1024  # ru_maxrss is in KiB on Linux


def outside_kernels(call, count):
    """Milliseconds of each of ``count`` calls of ``call()`` spent outside the compiled
    kernel entries' own calls (csw.kernels.native.Bound: the marshalling of their
    arguments counts outside), and inside them: two lists.  One timing split in two, so
    that the outside figure can't come out negative as a difference of two runs can."""
    import time

    from csw.kernels import native

    inside = [0.0]
    bound_call = native.Bound.__call__

    def timed(self):
        start = time.perf_counter()
        try:
            return bound_call(self)
        finally:
            inside[0] += time.perf_counter() - start

    outside, kernels = [], []
    native.Bound.__call__ = timed
    try:
        for _ in range(count):
            inside[0] = 0.0
            start = time.perf_counter()
            call()
            wall = time.perf_counter() - start
            outside.append((wall - inside[0]) * 1e3)
            kernels.append(inside[0] * 1e3)
    finally:
        native.Bound.__call__ = bound_call
    return outside, kernels


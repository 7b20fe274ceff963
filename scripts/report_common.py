"""What the report scripts in scripts/ share: the date, the CPU, number formatting, and
running a csw command that prints JSON."""

import datetime
import json
import platform
import subprocess
import sys
from pathlib import Path


def now_utc():
    return datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")


def cpu_name():
    """The CPU's model name from /proc/cpuinfo, or what platform knows."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def fmt(value, digits=2):
    """A number for a Markdown table; blank for None."""
    return "" if value is None else f"{value:.{digits}f}"


def run_json(cmd):
    """Run a csw command (echoed to stderr) and parse what it prints on stdout."""
    print("+", " ".join(cmd), file=sys.stderr, flush=True)
    out = subprocess.run(cmd, check=True, capture_output=True, text=True)
    return json.loads(out.stdout)

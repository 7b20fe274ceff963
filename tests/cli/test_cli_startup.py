"""What a user meets on a fresh machine: a first run compiles once and says so, later runs
load the kernels and say nothing, ``csw compile`` pays ahead, processes that start
together compile once, and a compile killed half-way leaves a cache that still works."""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

NOTICE = "compiling csw's kernels"


@pytest.fixture
def scene(lr_pngs):
    return lr_pngs


def csw_command(folder, cache, output, *extra):
    env = dict(os.environ, CSW_KERNEL_CACHE=str(cache))
    args = [sys.executable, "-m", "csw_cli", "match", str(folder / "l.png"),
            str(folder / "r.png"), "-o", str(output), "--dmax", "10", "--preset", "raw",
            "--window", "5", *extra]
    return args, env


def cache_entries(cache):
    """Every file in the kernel cache, with its size and modification time."""
    return {str(p.relative_to(cache)): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in sorted(cache.rglob("*")) if p.is_file() and p.name != "lock"}


def kernel_entries(entries):
    """The compiled kernels among a cache's files (not the loader's GIL helpers)."""
    from csw.kernels.loader import GIL_HELPERS

    return {name: stat for name, stat in entries.items()
            if not os.path.basename(name).startswith(GIL_HELPERS)}


def run(folder, cache, output, *extra):
    args, env = csw_command(folder, cache, output, *extra)
    return subprocess.run(args, env=env, capture_output=True, text=True, timeout=600)


@pytest.mark.slow
def test_the_first_run_says_it_compiles_and_later_runs_are_quiet(scene):
    first = run(scene, scene / "cache", scene / "a.pfm")
    assert first.returncode == 0, first.stderr
    assert first.stderr.count(NOTICE) == 1
    entries = cache_entries(scene / "cache")
    second = run(scene, scene / "cache", scene / "b.pfm")
    assert second.returncode == 0 and NOTICE not in second.stderr
    # Loading, not compiling: the kernels' entries are read, none written.  (Its time,
    # about 0.05 s here, is no test's business: "compile 0.0x" failed when the machine
    # was busy, or when this run, the first to load without Numba, also emitted the
    # loader's GIL helpers, which it keeps in the cache beside the entries.)
    assert kernel_entries(cache_entries(scene / "cache")) == kernel_entries(entries)
    assert (scene / "a.pfm").read_bytes() == (scene / "b.pfm").read_bytes()


@pytest.mark.slow
def test_csw_compile_fills_the_cache_for_every_preset(scene):
    env = dict(os.environ, CSW_KERNEL_CACHE=str(scene / "cache"))
    ahead = subprocess.run([sys.executable, "-m", "csw_cli", "compile", "--preset", "raw"],
                           env=env, capture_output=True, text=True, timeout=900)
    assert ahead.returncode == 0, ahead.stderr
    assert "already in the cache" in ahead.stderr
    after = run(scene, scene / "cache", scene / "a.pfm", "--csw")
    assert after.returncode == 0 and NOTICE not in after.stderr, after.stderr
    again = subprocess.run([sys.executable, "-m", "csw_cli", "compile", "--preset", "raw"],
                           env=env, capture_output=True, text=True, timeout=900)
    assert again.stderr.splitlines()[-1].startswith("0 kernel(s) compiled")


@pytest.mark.slow
def test_processes_that_start_together_compile_once(scene):
    started = []
    for i in range(3):
        args, env = csw_command(scene, scene / "cache", scene / f"d{i}.pfm", "--cost", "ssd")
        started.append(subprocess.Popen(args, env=env, stderr=subprocess.PIPE, text=True))
    errors = [p.communicate(timeout=600)[1] for p in started]
    assert [p.returncode for p in started] == [0, 0, 0], errors
    assert sum(e.count(NOTICE) for e in errors) == 1, errors
    maps = {(scene / f"d{i}.pfm").read_bytes() for i in range(3)}
    assert len(maps) == 1


@pytest.mark.slow
def test_a_compile_killed_half_way_leaves_a_cache_that_works(scene):
    args, env = csw_command(scene, scene / "cache", scene / "killed.pfm", "--cost", "shd")
    victim = subprocess.Popen(args, env=env, stderr=subprocess.PIPE, text=True)
    told = victim.stderr.readline()  # the notice: it is compiling now
    time.sleep(0.5)
    victim.send_signal(signal.SIGKILL)
    victim.wait(timeout=60)
    assert NOTICE in told
    assert not (scene / "killed.pfm").exists()
    after = run(scene, scene / "cache", scene / "after.pfm", "--cost", "shd")
    assert after.returncode == 0, after.stderr
    reference = run(scene, scene / "fresh-cache", scene / "reference.pfm", "--cost", "shd")
    assert (scene / "after.pfm").read_bytes() == (scene / "reference.pfm").read_bytes()
    assert reference.returncode == 0
    leftovers = [p.name for p in (scene / "cache").rglob("*.tmp")]
    assert leftovers == []


def test_a_warm_library_call_adds_little_to_the_kernels(scene):
    """csw.match on an array, once warm, does what kernels.match does plus the pipeline's
    bookkeeping: no compile, no load (the timing itself is in reports/startup.md)."""
    import csw
    from csw.kernels import native

    left = np.zeros((40, 60), np.uint8)
    csw.match(left, left, dmax=8)
    before = dict(native.STATS)
    result = csw.match(left, left, dmax=8)
    assert native.STATS == before and result.compile_seconds < 0.01

"""Kernels are compiled once per CPU and stored; later processes load them without
compiling and without importing Numba (kernels/native.py), and processes that start
together on an empty cache compile each entry once."""

import json
import os
import subprocess
import sys

import pytest

from csw.kernels import store

PROBE = """
import json, sys, numpy as np
from csw import kernels
img = np.zeros((4, 6), np.uint8)
kernels.match(img, img, engine="window", window=3, dmin=0, dmax=2, cost="sad", csw=True, tau=0)
print(json.dumps(dict(kernels.native.STATS, numba="numba" in sys.modules)))
"""


def probe(cache):
    env = dict(os.environ, CSW_KERNEL_CACHE=str(cache))
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True,
                         timeout=600, check=True, env=env)
    return json.loads(out.stdout.strip().splitlines()[-1]), out.stderr


@pytest.mark.slow
def test_a_second_process_loads_without_compiling_or_numba(tmp_path):
    first, told = probe(tmp_path)
    # One entry: compiled here, or by a worker where csw compiles with features of its
    # own (kernels/compiler.py), and this process never imports Numba.
    assert first["compiled"] == 1
    assert first["numba"] == (store.compile_features() is None)
    assert told.count("compiling csw's kernels") == 1
    second, quiet = probe(tmp_path)
    assert second["compiled"] == 0 and second["loaded"] == 1, second
    assert not second["numba"] and "compiling" not in quiet


TWO_ENTRIES = """
import json, sys, numpy as np
from csw import kernels
if sys.argv[1] == "broken":  # every compile worker fails at once
    kernels.compiler._WORKER = "import sys; sys.exit(3)"
rng = np.random.default_rng(5)
left, right = (rng.integers(0, 256, (12, 20), dtype=np.uint8) for _ in range(2))
wanted = [e for cost in ("sad", "census") for e in kernels.catalogue.engine_entries(
    "window", cost, np.dtype(np.uint8), 3, 5, False, False, False, census_pattern="dense")]
kernels.native.ensure(wanted)  # three entries, missing together
maps = [kernels.match(left, right, engine="window", window=3, dmin=0, dmax=4, cost=cost,
                      census_window=5, census_pattern="dense").disparity.tolist()
        for cost in ("sad", "census")]
print(json.dumps(dict(kernels.native.STATS, numba="numba" in sys.modules, maps=maps)))
"""


def two_entries(cache, mode):
    env = dict(os.environ, CSW_KERNEL_CACHE=str(cache))
    out = subprocess.run([sys.executable, "-c", TWO_ENTRIES, mode], capture_output=True,
                         text=True, timeout=600, check=True, env=env)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_missing_entries_compile_in_worker_processes_or_here_if_they_fail(tmp_path):
    """With two cores or more, or csw's own CPU features, missing entries compile in
    worker processes (this one never imports Numba); when the workers fail, this process
    compiles them itself, and the maps are the same either way."""
    from csw.kernels.runtime import cores

    workers = two_entries(tmp_path / "workers", "workers")
    broken = two_entries(tmp_path / "broken", "broken")
    assert workers["compiled"] == 3 and broken["compiled"] == 3
    assert broken["numba"]  # compiled here, after the workers failed
    if cores() > 1 or store.compile_features() is not None:
        assert not workers["numba"]
    assert workers["maps"] == broken["maps"]
    for cache in ("workers", "broken"):
        assert [p.name for p in (tmp_path / cache).rglob("*.tmp")] == []
        stored = [p.stem for p in (tmp_path / cache).rglob("*.json")]
        # the three entries (and, where Numba is not loaded, the GIL helpers their error
        # path links to: kernels/loader.py)
        assert len([name for name in stored if name != "gil-helpers"]) == 3


@pytest.mark.slow
def test_compile_workers_ignore_a_package_of_the_same_name_in_the_current_folder(tmp_path):
    """A source checkout's csw/ in the current folder must not reach the compile workers:
    they would compile its kernels into this process's cache."""
    from csw.kernels.runtime import cores

    if cores() < 2:
        pytest.skip("entries compile in worker processes only with two cores or more")
    decoy = tmp_path / "checkout" / "csw"
    decoy.mkdir(parents=True)
    marker = tmp_path / "decoy-imported"
    (decoy / "__init__.py").write_text(f"open({str(marker)!r}, 'w').close()\n")
    env = dict(os.environ, CSW_KERNEL_CACHE=str(tmp_path / "cache"))
    out = subprocess.run([sys.executable, "-P", "-c", TWO_ENTRIES, "workers"],
                         capture_output=True, text=True, timeout=600, check=True, env=env,
                         cwd=decoy.parent)
    stats = json.loads(out.stdout.strip().splitlines()[-1])
    assert stats["compiled"] == 3 and not stats["numba"]  # the workers compiled them all
    assert not marker.exists()


MAP_PROBE = PROBE.replace("print(json.dumps(dict(kernels.native.STATS,",
                          "out = kernels.match(img + np.arange(6, dtype=np.uint8), img, "
                          "engine='window', window=3, dmin=0, dmax=2, cost='sad')\n"
                          "print(json.dumps(dict(kernels.native.STATS, "
                          "map=out.disparity.tolist(),")


def map_probe(cache, umask=None):
    env = dict(os.environ, CSW_KERNEL_CACHE=str(cache))
    out = subprocess.run([sys.executable, "-c", MAP_PROBE], capture_output=True, text=True,
                         timeout=600, env=env,
                         preexec_fn=None if umask is None else lambda: os.umask(umask))
    assert out.returncode == 0, out.stderr  # never a segfault (-11) nor an abort
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.slow
@pytest.mark.parametrize("damage", ["truncated code", "flipped byte", "truncated json",
                                    "foreign json"])
def test_a_damaged_cache_entry_is_found_and_rebuilt(tmp_path, damage):
    clean = map_probe(tmp_path)
    assert clean["compiled"] >= 1
    code = next(tmp_path.rglob("window-*.o"))
    meta = code.with_suffix(".json")
    if damage == "truncated code":
        code.write_bytes(code.read_bytes()[:1000])
    elif damage == "flipped byte":
        data = bytearray(code.read_bytes())
        data[len(data) // 2] ^= 0xFF
        code.write_bytes(bytes(data))
    elif damage == "truncated json":
        meta.write_text(meta.read_text()[:11])
    else:
        meta.write_text(json.dumps({"symbol": "x", "arrays": [], "scalars": 0,
                                    "imports": []}))
    again = map_probe(tmp_path)
    assert again["compiled"] == 1 and again["map"] == clean["map"]
    assert map_probe(tmp_path)["compiled"] == 0  # and it stays rebuilt


@pytest.mark.slow
def test_cache_files_are_never_writable_by_others_whatever_the_umask(tmp_path):
    map_probe(tmp_path / "cache", umask=0)
    paths = [tmp_path / "cache", *(tmp_path / "cache").rglob("*")]
    assert len(paths) > 3
    loose = [str(p) for p in paths if p.stat().st_mode & 0o022]
    assert loose == []


@pytest.mark.slow
def test_an_entry_writable_by_others_is_not_loaded(tmp_path):
    map_probe(tmp_path)
    code = next(tmp_path.rglob("window-*.o"))
    os.chmod(code, 0o666)
    assert map_probe(tmp_path)["compiled"] == 1
    assert not next(tmp_path.rglob("window-*.o")).stat().st_mode & 0o022


def test_numba_s_private_attributes_are_read_in_one_place_that_fails_in_one_line():
    """The cache needs Numba internals that have no public API: they are read in
    jit/build.py's numba_internals alone, which works with this Numba and, with one that
    changed them, raises one line naming the version."""
    from pathlib import Path

    from csw.kernels.jit import build

    _, compiled = build._compiled("filters", ("fill",))
    code, imports, _ = build.numba_internals(compiled)
    assert isinstance(code, bytes) and code and all(isinstance(n, str) for n in imports)

    class Changed:  # a cfunc of a Numba without _library
        native_name = "entry"

    with pytest.raises(RuntimeError, match=r"can't read Numba .*'s compiled code") as info:
        build.numba_internals(Changed())
    assert "\n" not in str(info.value)
    root = Path(build.__file__).parents[1]
    readers = sorted(p.relative_to(root).as_posix() for p in root.rglob("*.py")
                     if "._library" in p.read_text() or "_final_module" in p.read_text())
    assert readers == ["jit/build.py"]


PROBE_WORKER = """
import sys
import numpy as np
from numba import njit
from csw.kernels import store
from csw.kernels.jit import build
from csw.kernels.signature import Signature, Spec, arg

@njit
def worker(a, sc):
    if sc[0] == 1:
        BUG
    a[0] += 7
    return 0

spec = Spec(worker, Signature((arg("a", np.int64, 1),), ("go",)))
compiled = build.compile_spec(spec, "probe")
try:
    store.store(__import__("pathlib").Path(sys.argv[1]), "probe", compiled.native_name,
                build.stored_form(spec, compiled, "probe"))
except RuntimeError as exc:
    print(exc)
"""
PROBE_CALL = """
import sys
import numpy as np
from pathlib import Path
from csw.kernels import loader, native, store
from csw.kernels.signature import Signature

folder, found = Path(sys.argv[1]), {}
assert store.verified(folder, "probe", found)
entry = native.Entry("probe", Signature.from_description(found["probe"]),
                     loader.load(folder, "probe", found["probe"]))
a = np.zeros(1, np.int64)
entry(a=a, go=0)
try:
    entry(a=a, go=1)
except RuntimeError as exc:
    print("numba" in sys.modules, a[0], exc)
"""


@pytest.mark.slow
def test_a_worker_that_raises_is_an_error_not_an_abort(tmp_path):
    """Loaded without Numba, an entry that reaches Numba's raise path returns, and the
    call raises a RuntimeError saying so (its helpers once pointed at abort())."""
    run = [sys.executable, "-c"]
    raises = PROBE_WORKER.replace("BUG", "raise ValueError(\"a worker's bug\")")
    subprocess.run([*run, raises, str(tmp_path)], check=True)
    called = subprocess.run([*run, PROBE_CALL, str(tmp_path)], capture_output=True,
                            text=True, timeout=60)
    assert called.returncode == 0, called.stderr
    assert called.stdout.startswith("False 7 csw's kernel probe failed: it reached Numba's")


@pytest.mark.slow
def test_a_worker_that_allocates_is_refused_when_it_compiles(tmp_path):
    """No Numba runtime is loaded with the entries, so none may allocate: the compile
    refuses one that does, in one line."""
    script = PROBE_WORKER.replace("BUG", "a[0] = np.empty(sc[0]).size")
    done = subprocess.run([sys.executable, "-c", script, str(tmp_path)],
                          capture_output=True, text=True, check=True)
    assert "csw's kernel probe allocates (NRT_MemInfo_alloc" in done.stdout
    assert not list(tmp_path.iterdir())


@pytest.mark.slow
def test_a_worker_that_needs_a_numba_helper_on_its_way_is_refused(tmp_path):
    """A kernel loaded without Numba has only the GIL's helpers and its error path's
    stand-ins: a worker that calls another Numba helper on its normal path (reshape's
    numba_attempt_nocopy_reshape did) would fail on every call, so the compile refuses
    it, in one line, and stores nothing."""
    script = PROBE_WORKER.replace("BUG", "a[0] = a.reshape(1, 1)[0, 0]")
    done = subprocess.run([sys.executable, "-c", script, str(tmp_path)],
                          capture_output=True, text=True, check=True)
    assert done.stdout.startswith("csw's kernel probe calls Numba's "
                                  "numba_attempt_nocopy_reshape")
    assert "\n" not in done.stdout.strip()
    assert not list(tmp_path.iterdir())


def test_the_target_cpu_is_numbas_setting_when_named(monkeypatch):
    import llvmlite.binding as llvm

    from csw.kernels.store import target_cpu

    monkeypatch.setenv("NUMBA_CPU_NAME", "generic")
    assert target_cpu() == "generic"
    for unnamed in ("host", ""):
        monkeypatch.setenv("NUMBA_CPU_NAME", unnamed)
        assert target_cpu() == llvm.get_host_cpu_name()

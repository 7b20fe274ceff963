"""The kernel entries the test suite loads, compiled before its first test.

A test that meets a missing entry compiles it alone, in the test's process, on one core.
On an empty cache (a fresh clone, as CI runs) those compiles, one after the other, were
about half of the suite's time. So a session started by scripts/test.sh (``make test``,
``make test-quick``: CSW_SUITE_PRECOMPILE=1) starts by compiling the entries listed in
suite_kernels.txt that the cache lacks, in one process per core, as ``csw compile``
does (kernels/compiler.py); with a full cache it only checks them. A plain ``pytest``
of a few tests does not: it would wait for every entry after a kernel change.

The list saves time and nothing else: an entry it lacks is compiled when a test asks
for it, as before, and one the catalogue no longer has is skipped here and fails
tests/kernels/test_catalogue.py. ``make suite-kernels`` writes it again: the suite on
an empty cache without this step, then the entries it left,
via ``python tests/suite_kernels.py``.
"""

import os
import sys
import time
from pathlib import Path

LIST = Path(__file__).with_name("suite_kernels.txt")


def listed():
    """The cache names (kernels.store.entry_key) in the list, in its order."""
    return [line.strip() for line in LIST.read_text().splitlines()
            if line.strip() and not line.startswith("#")]


def catalogued():
    """{cache name: (kernel, variant)} for every entry the catalogue has."""
    from csw.kernels.catalogue import every_entry
    from csw.kernels.store import entry_key

    return {entry_key(kernel, variant): (kernel, variant) for kernel, variant in every_entry()}


def precompile():
    """Compile the listed entries the cache lacks (see above); say so on stderr first.
    A failure is reported and left to the tests that load the entry."""
    from csw.kernels import native
    from csw.kernels.compiler import compile_missing
    from csw.kernels.runtime import cores
    from csw.kernels.store import cache_dir, entry_key, lock, verified

    if native.JIT_DISABLED or os.environ.get("CSW_SUITE_PRECOMPILE") != "1":
        return
    known = catalogued()
    wanted = [known[key] for key in listed() if key in known]
    folder, found = cache_dir(), {}
    try:
        with lock(folder):
            missing = [(kernel, variant) for kernel, variant in wanted
                       if not verified(folder, entry_key(kernel, variant), found,
                                       discard=True)]
            if not missing:
                return
            print(f"tests: compiling {len(missing)} kernel entries the suite loads, "
                  f"{min(len(missing), cores())} at a time, into {folder}",
                  file=sys.stderr, flush=True)
            start = time.perf_counter()
            compile_missing(folder, missing, notice=False)
            print(f"tests: compiled in {time.perf_counter() - start:.0f} s",
                  file=sys.stderr, flush=True)
    except Exception as exc:  # noqa: BLE001 - the tests that load it will show it
        print(f"tests: compiling ahead failed ({exc}); each test compiles what it "
              "loads", file=sys.stderr, flush=True)


def write_list(folder):
    """Write suite_kernels.txt: the catalogued entries stored in the cache ``folder``."""
    known = catalogued()
    names = sorted(path.stem for path in Path(folder).glob("*.json") if path.stem in known)
    LIST.write_text("# Written by `make suite-kernels`; see tests/suite_kernels.py.\n"
                    + "".join(f"{name}\n" for name in names))
    return len(names)


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from csw.kernels.store import cache_dir

    print(f"{write_list(cache_dir())} entries written to {LIST}")

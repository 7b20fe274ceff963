import os

import pytest
from hypothesis import settings

from csw.data.synth import render
from csw.io import write_png

# Property tests: a fixed example sequence in CI (CI=true), so a run is repeatable;
# fresh examples on developers' machines; CSW_HYPOTHESIS_PROFILE=thorough for a long hunt.
settings.register_profile("dev", max_examples=60)
settings.register_profile("ci", max_examples=60, derandomize=True, database=None)
settings.register_profile("thorough", max_examples=2000)
settings.load_profile(os.environ.get("CSW_HYPOTHESIS_PROFILE",
                                     "ci" if os.environ.get("CI") else "dev"))


def pytest_collection_finish(session):
    """The kernel entries the suite loads, compiled before the first test on every core
    where the cache lacks them (tests/suite_kernels.py); within the session's time."""
    from suite_kernels import precompile

    # Not for a collection that failed or selected nothing: its report comes first.
    if session.items and not session.testsfailed and not session.config.option.collectonly:
        precompile()


def pytest_collection_modifyitems(config, items):
    """Tests marked two_cores ask csw for two threads, which it refuses where the process
    may run on one core (a one-core machine, taskset): skipped there, not failed."""
    from csw.kernels import runtime

    if runtime.max_threads() >= 2:
        return
    skip = pytest.mark.skip(reason="asks for two threads; this process may use one core")
    for item in items:
        if "two_cores" in item.keywords:
            item.add_marker(skip)


@pytest.fixture(scope="session")
def small_scene():
    """A small synthetic pair: (left, right, gt, nonocc)."""
    return render(96, 64, dmax=16, seed=1)


@pytest.fixture
def pair_files(tmp_path, small_scene):
    """left.png and right.png of the small scene in a fresh folder."""
    left, right, _, _ = small_scene
    write_png(tmp_path / "left.png", left)
    write_png(tmp_path / "right.png", right)
    return tmp_path / "left.png", tmp_path / "right.png"


@pytest.fixture
def lr_pngs(tmp_path):
    """l.png and r.png of a small synthetic scene (80x48, d up to 10) in a fresh folder,
    which is returned."""
    left, right, _, _ = render(80, 48, dmax=10, seed=3)
    write_png(tmp_path / "l.png", left)
    write_png(tmp_path / "r.png", right)
    return tmp_path


@pytest.fixture(scope="session")
def data_dir():
    """The Middlebury data folder from CSW_DATA_DIR.

    Missing data skips the test with the reason, except where CSW_REQUIRE_DATA=1 (CI),
    where it fails: CI must never pass by skipping the real-data checks.
    """
    import os
    from pathlib import Path

    value = os.environ.get("CSW_DATA_DIR")
    folder = Path(value) if value else None
    if folder is None or not (folder / "tsukuba").is_dir():
        reason = (f"Middlebury data not found (CSW_DATA_DIR={value!r}); point CSW_DATA_DIR "
                  "at a folder holding the registered datasets (tsukuba/, cones/ ...: "
                  "see docs/datasets.md)")
        if os.environ.get("CSW_REQUIRE_DATA") == "1":
            pytest.fail(reason)
        pytest.skip(reason)
    return folder

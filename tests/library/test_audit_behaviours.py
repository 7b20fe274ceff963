"""Behaviours that one-line mutants of the code changed without a test noticing (the
hostile audit, issue 25): each is held here, and none needs the Middlebury data."""

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import csw
from csw.camera.calibration import read_calibration
from csw.io import atomic
from csw.matching import disparity_range as autorange
from csw.scale import jobs as batch_jobs


def test_middlebury_doffs_from_cam1_and_cam0(tmp_path):
    """Without a doffs= line, doffs is cam1's cx less cam0's: depth at d = 200 with
    f 4000, B 200 mm, cx 1000 and 1130 is 4000 * 200 / (200 + 130) mm."""
    (tmp_path / "calib.txt").write_text("cam0=[4000 0 1000; 0 4000 500; 0 0 1]\n"
                                        "cam1=[4000 0 1130; 0 4000 500; 0 0 1]\n"
                                        "baseline=200\n")
    calib = read_calibration(tmp_path / "calib.txt")
    assert calib.doffs == 130
    z = csw.depth(np.full((2, 2), 200.0, np.float32), calib, units="m")
    np.testing.assert_allclose(z, 4000 * 0.2 / 330, rtol=1e-6)


def test_kitti_doffs_when_the_principal_points_differ(tmp_path):
    """doffs is P3's cx less P2's: Z = f B / (d + doffs)."""
    p2 = "700 0 600 0 0 700 170 0 0 0 1 0"
    p3 = f"700 0 610 {-700 * 0.5} 0 700 170 0 0 0 1 0"
    (tmp_path / "k.txt").write_text(f"P2: {p2}\nP3: {p3}\n")
    calib = read_calibration(tmp_path / "k.txt")
    assert calib.doffs == 10 and calib.baseline == 0.5
    z = csw.depth(np.full((2, 2), 40.0, np.float32), calib)
    np.testing.assert_allclose(z, 700 * 0.5 / 50, rtol=1e-6)


def test_cloud_points_follow_the_units_as_depth_does():
    calib = csw.Calibration(focal=100.0, baseline=50.0, cx=1.0, cy=1.0, units="mm")
    disparity = np.full((3, 3), 10.0, np.float32)
    points, _ = csw.point_cloud(disparity, calib, units="m")
    z = csw.depth(disparity, calib, units="m")
    np.testing.assert_allclose(points[:, 2], z.ravel(), rtol=1e-6)
    np.testing.assert_allclose(points[:, 2], 0.5, rtol=1e-6)
    np.testing.assert_allclose(points[0, :2], [-1 * 5 / 1000, -1 * 5 / 1000], rtol=1e-6)


def shrunk_map(monkeypatch, found):
    """autorange.estimate with the small pair's match replaced by ``found``."""
    monkeypatch.setattr("csw.matching.disparity_range.run_pipeline",
                        lambda *a, **k: (found, None, None))


@pytest.mark.parametrize("share, refused", [(0.009, True), (0.011, False)])
def test_the_auto_range_needs_one_percent_confident_pixels(monkeypatch, share, refused):
    found = np.full((100, 100), np.nan, np.float32)
    found.flat[:round(share * found.size)] = 10.0
    shrunk_map(monkeypatch, found)
    small = np.zeros((100, 100), np.uint8)
    if refused:
        with pytest.raises(ValueError, match="too few confident"):
            autorange.estimate(small, small, 2, 200)
    else:
        assert autorange.estimate(small, small, 2, 200)[1] >= 20


def test_the_auto_range_ignores_a_few_outliers(monkeypatch):
    """The robust extremes: 0.3% of wild matches at d 90 don't stretch the range, and the
    bulk (up to 30 on the small pair) is covered."""
    rng = np.random.default_rng(0)
    found = rng.uniform(0, 30, (100, 100)).astype(np.float32)
    found.flat[:30] = 90.0
    shrunk_map(monkeypatch, found)
    small = np.zeros((100, 100), np.uint8)
    low, high = autorange.estimate(small, small, 2, 400)
    assert 2 * 29.5 <= high < 2 * 40 and low <= 0


def test_a_name_with_del_is_refused():
    with pytest.raises(ValueError, match="control character"):
        batch_jobs.check_name("a\x7fb", "test")


def test_an_output_linked_into_a_sibling_folder_is_refused(tmp_path):
    """out/p.pfm -> out-old/p.pfm: the sibling's path starts with the output folder's."""
    (tmp_path / "out").mkdir()
    (tmp_path / "out-old").mkdir()
    (tmp_path / "out" / "p.pfm").symlink_to(tmp_path / "out-old" / "p.pfm")
    job = batch_jobs.Job("p", tmp_path / "l.png", tmp_path / "r.png")
    with pytest.raises(ValueError, match="outside the output folder"):
        csw.match_many([job], tmp_path / "out", dmax=6, progress=False)
    assert not (tmp_path / "out-old" / "p.pfm").exists()


@pytest.mark.parametrize("umask", [0o077, 0o002])
def test_new_files_get_the_mode_a_plain_write_gives(tmp_path, umask):
    old = os.umask(umask)
    try:
        atomic.atomic_write(tmp_path / "f.pfm", lambda tmp: Path(tmp).write_bytes(b"x"))
    finally:
        os.umask(old)
    assert (tmp_path / "f.pfm").stat().st_mode & 0o777 == 0o666 & ~umask


@pytest.mark.parametrize("source", ["jit/fast.py", "contract.py", "jit/options.py",
                                    "signature.py"])
def test_the_cache_fingerprint_follows_every_source_the_workers_use(tmp_path, monkeypatch,
                                                                      source):
    """A change to a worker's source, or to a module the workers import, gives another
    cache folder, even when no file name changes."""
    from csw.kernels import store

    copy = tmp_path / "kernels"
    shutil.copytree(store.KERNEL_SOURCES, copy,
                    ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(store, "KERNEL_SOURCES", copy)
    monkeypatch.setattr(store, "_FINGERPRINT", {})
    before = store._fingerprint()
    with open(copy / source, "a") as f:
        f.write("\n# changed\n")
    monkeypatch.setattr(store, "_FINGERPRINT", {})
    assert store._fingerprint() != before


def test_the_cache_fingerprint_follows_numbas_version_without_importing_it(monkeypatch):
    """Two Numba releases on one llvmlite generate different code: each has its own cache
    folder.  The version comes from its dist-info folder (the metadata's), so a warm run
    still doesn't import Numba."""
    import importlib.metadata

    from csw.kernels import store

    assert store.numba_version() == importlib.metadata.version("numba")
    monkeypatch.setattr(store, "_FINGERPRINT", {})
    before = store._fingerprint()
    monkeypatch.setattr(store, "numba_version", lambda: "0.0.1")
    monkeypatch.setattr(store, "_FINGERPRINT", {})
    assert store._fingerprint() != before

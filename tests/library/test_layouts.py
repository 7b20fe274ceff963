"""Benchmark folders in their published layouts, built on the fly (nothing downloaded)."""

import numpy as np
import pytest
from layout_fixtures import kitti, middlebury2014

import csw
from csw.data import layouts
from csw.data.datasets import DataError


def test_middlebury2014_scene(tmp_path):
    left, right, gt = middlebury2014(tmp_path / "Scene", ndisp=24)
    (scene,) = csw.scan_folder(tmp_path / "Scene")
    pair = scene.load()
    assert (pair.layout, pair.name, pair.dmax) == ("middlebury2014", "Scene", 23)
    np.testing.assert_array_equal(pair.left, left)  # RGB -> gray by luma
    np.testing.assert_array_equal(pair.gt, gt)  # PFM as stored, inf -> unknown
    assert not pair.masks["all"][:4, :4].any()
    assert pair.masks["nonocc"].sum() < pair.masks["all"].sum()


def test_a_folder_of_middlebury_scenes_and_calib_without_mask(tmp_path):
    middlebury2014(tmp_path / "B", seed=2, mask=False, ndisp=500)
    middlebury2014(tmp_path / "A", seed=1)
    scenes = layouts.scan(tmp_path)
    assert [s.name for s in scenes] == ["A", "B"]
    b = scenes[1].load()
    assert set(b.masks) == {"all"} and b.dmax == 95  # ndisp capped by the width


@pytest.mark.parametrize("year", [2015, 2012])
def test_kitti_training_folder(tmp_path, year):
    truth = kitti(tmp_path / "training", frames=2, year=year)
    scenes = layouts.scan(tmp_path)  # the folder holding training/ works too
    assert [s.name for s in scenes] == ["000000_10", "000001_10"]
    pair = scenes[0].load()
    left, _, gt, nonocc = truth["000000_10"]
    np.testing.assert_array_equal(pair.left, left)
    np.testing.assert_allclose(pair.gt, gt.astype(np.float32))  # value / 256, 0 unknown
    np.testing.assert_array_equal(pair.masks["nonocc"], nonocc)
    assert pair.dmax == 95  # KITTI's 0..255, within the width


def test_unknown_folder_says_what_it_expects(tmp_path):
    (tmp_path / "x.txt").write_text("hi")
    with pytest.raises(DataError, match="Middlebury scene folder"):
        layouts.scan(tmp_path)


def test_mismatched_sizes_are_a_data_error(tmp_path):
    middlebury2014(tmp_path / "S")
    csw.io.write_png(tmp_path / "S" / "im1.png", np.zeros((10, 10), np.uint8))
    with pytest.raises(DataError, match="differ in size"):
        layouts.scan(tmp_path / "S")[0].load()

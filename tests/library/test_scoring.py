"""Scoring on examples small enough to check by hand."""

import numpy as np
import pytest

from csw.eval.scoring import metric_for, score, summary


def test_bad_thresholds_invalid_mae_rms_by_hand():
    gt = np.array([[10.0, 10.0, 10.0, np.nan],
                   [20.0, 20.0, 20.0, 20.0]])
    # errors:        0.0   0.75  1.5   (unknown)
    #                3.0   invalid 5.0 0.25
    disp = np.array([[10.0, 10.75, 11.5, 3.0],
                     [23.0, np.inf, 15.0, 20.25]])
    region = np.ones(gt.shape, bool)
    m = score(disp, gt, {"all": region})["all"]
    assert m["pixels"] == 7  # the unknown ground-truth pixel is left out
    # bad-0.5: 0.75, 1.5, 3, 5 and the invalid one -> 5 of 7.
    assert m["bad"][0.5] == pytest.approx(100 * 5 / 7)
    # bad-1: 1.5, 3, 5, invalid -> 4 of 7.  bad-2: 3, 5, invalid.  bad-4: 5, invalid.
    assert m["bad"][1.0] == pytest.approx(100 * 4 / 7)
    assert m["bad"][2.0] == pytest.approx(100 * 3 / 7)
    assert m["bad"][4.0] == pytest.approx(100 * 2 / 7)
    assert m["invalid"] == pytest.approx(100 / 7)
    errors = np.array([0, 0.75, 1.5, 3, 5, 0.25])
    assert m["mae"] == pytest.approx(errors.mean())
    assert m["rms"] == pytest.approx(np.sqrt((errors ** 2).mean()))


def test_integer_maps_with_minus_one_are_invalid_and_regions_apply():
    gt = np.full((2, 3), 4.0)
    disp = np.array([[4, -1, 6], [4, 4, 4]], np.int32)
    nonocc = np.array([[True, True, False], [False, False, False]])
    m = score(disp, gt, {"all": np.ones((2, 3), bool), "nonocc": nonocc})
    assert m["all"]["bad"][1.0] == pytest.approx(100 * 2 / 6)
    assert m["nonocc"]["pixels"] == 2 and m["nonocc"]["bad"][1.0] == pytest.approx(50.0)
    assert m["nonocc"]["invalid"] == pytest.approx(50.0)


def test_shape_mismatch_is_reported():
    with pytest.raises(ValueError, match="ground truth"):
        score(np.zeros((2, 2)), np.zeros((3, 2)), {"all": np.ones((3, 2), bool)})


def test_kitti_d1_and_bad_3_differ_by_hand():
    """D1 needs both: an error over 3 px and over 5% of the truth."""
    gt = np.array([[10.0, 100.0, 100.0, 50.0],
                   [np.nan, 20.0, 20.0, 20.0]])
    # errors:        4 (40%)  4 (4%)  6 (6%)  invalid
    #                unknown  0       3.5 (17.5%)  0.5
    disp = np.array([[14.0, 104.0, 106.0, np.nan],
                     [5.0, 20.0, 23.5, 20.5]])
    region = np.ones(gt.shape, bool)
    d1, bad3 = summary(disp, gt, region, "D1"), summary(disp, gt, region, "bad-3")
    assert d1["density"] == bad3["density"] == pytest.approx(100 * 6 / 7)
    # bad-3: 4, 4, 6 and 3.5 over 6 valid; D1 spares the 4 px error on 100 (4%).
    assert bad3["bad_valid"] == pytest.approx(100 * 4 / 6)
    assert d1["bad_valid"] == pytest.approx(100 * 3 / 6)
    assert d1["bad_all"] == pytest.approx(100 * 4 / 7)  # the invalid pixel counts as bad
    # Filled: the hole at the row's end takes its one valid neighbour, 106 (error 56).
    assert d1["filled"] == pytest.approx(100 * 4 / 7)
    assert bad3["filled"] == pytest.approx(100 * 5 / 7)
    assert summary(disp, gt, region)["bad_valid"] == pytest.approx(100 * 4 / 6)  # bad-2
    assert (metric_for("kitti2015"), metric_for("kitti2012"),
            metric_for("middlebury2014"), metric_for("registry")) == \
        ("D1", "D1", "bad-2", "bad-2")
    with pytest.raises(ValueError, match="unknown metric"):
        summary(disp, gt, region, "D2")

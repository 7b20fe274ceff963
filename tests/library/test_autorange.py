"""dmax="auto": a range found from the pair covers its disparities and matches as well as
the dataset's own range."""

import numpy as np
import pytest

import csw
from csw.eval.scoring import score


def test_a_synthetic_pair_gets_a_range_that_covers_it():
    left, right, gt, _ = csw.synthetic_pair(320, 200, dmax=40, seed=2)
    result = csw.match(left, right, dmax="auto")
    assert result.settings["range_source"] == "auto"
    assert np.nanmax(gt) <= result.settings["dmax"] <= 1.3 * np.nanmax(gt) + 4
    both = csw.match(left, right, dmin="auto", dmax="auto")
    assert both.settings["dmin"] <= np.nanmin(gt)


def test_a_negative_range_is_found_too():
    left, right, gt, _ = csw.synthetic_pair(320, 200, dmax=30, seed=4)
    moved = np.pad(right, ((0, 0), (12, 0)), mode="edge")[:, :-12]  # d - 12, some < 0
    result = csw.match(left, moved, dmin="auto", dmax="auto")
    assert result.settings["dmin"] <= np.nanpercentile(gt - 12, 1)
    assert result.settings["dmax"] >= np.nanpercentile(gt - 12, 99)


def test_a_featureless_pair_is_a_clear_error():
    flat = np.full((60, 80), 128, np.uint8)
    with pytest.raises(ValueError, match="give --dmin and --dmax"):
        csw.match(flat, flat, dmax="auto")


@pytest.mark.data
@pytest.mark.parametrize("name", csw.dataset_names()[1:])
def test_every_dataset_covered_and_as_accurate(data_dir, name):
    pair = csw.load_dataset(name, data_dir)
    auto = csw.match(pair.left, pair.right, dmax="auto")
    own = csw.match(pair.left, pair.right, dmax=pair.dmax)
    assert auto.settings["dmax"] >= np.nanpercentile(pair.gt, 99)
    region = {"all": pair.masks["all"]}
    a, o = (score(r.disparity, pair.gt, region, (2.0,))["all"] for r in (auto, own))
    assert abs(a["density"] - o["density"]) <= 0.5
    assert abs(a["bad_valid"][2.0] - o["bad_valid"][2.0]) <= 0.5

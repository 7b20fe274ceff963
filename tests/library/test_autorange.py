"""The range found from the pair (csw's default, dmax="auto", and dmin="auto" when asked)
covers its disparities, not much more, and matches as well as the dataset's own range."""

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


@pytest.mark.slow
@pytest.mark.data
@pytest.mark.parametrize("name", csw.dataset_names())
def test_every_dataset_covered_and_as_accurate_with_no_range_given(data_dir, name):
    pair = csw.load_dataset(name, data_dir)
    auto = csw.match(pair.left, pair.right)
    own = csw.match(pair.left, pair.right, dmax=pair.dmax)
    assert auto.settings["dmax"] >= np.nanpercentile(pair.gt, 99)
    region = {"all": pair.masks["all"]}
    a, o = (score(r.disparity, pair.gt, region, (2.0,))["all"] for r in (auto, own))
    assert abs(a["density"] - o["density"]) <= 0.5
    assert abs(a["bad_valid"][2.0] - o["bad_valid"][2.0]) <= 0.5


@pytest.mark.slow
def test_no_range_given_means_found_from_the_pair_but_the_paper_keeps_its_own():
    left, right, gt, _ = csw.synthetic_pair(320, 200, dmax=40, seed=2)
    found = csw.match(left, right)
    assert found.settings["range_source"] == "auto"
    assert np.nanmax(gt) <= found.settings["dmax"] < 64
    assert found.notes == []
    paper = csw.match(left, right, preset="paper")
    assert (paper.settings["dmin"], paper.settings["dmax"]) == (0, 64)
    assert paper.settings["range_source"] == "default"


def test_a_range_cut_short_says_so():
    left, right, gt, _ = csw.synthetic_pair(320, 200, dmax=40, seed=2)
    short = csw.match(left, right, dmax=30)  # the nearest object is at d 36
    assert len(short.notes) == 1 and "dmax 30" in short.notes[0]
    assert csw.match(left, right, dmax=48).notes == []


def _dmin_bound_holds(chosen, disparities, dmin, dmax):
    """--dmin auto's promise: the range holds the scene (dmin at most the ground truth's
    1st percentile, to a disparity) and not much more (at most 8 disparities, or 5% of the
    range, below it)."""
    first = np.percentile(disparities[np.isfinite(disparities)], 1)
    slack = max(8, 0.05 * (dmax - dmin))
    return first - slack <= chosen <= first + 1


@pytest.mark.slow
@pytest.mark.parametrize("width, height, top, seed", [(200, 150, 20, 4), (320, 240, 40, 1),
                                                      (450, 375, 64, 0), (640, 480, 64, 2),
                                                      (1024, 768, 120, 3)])
def test_dmin_auto_fits_synthetic_scenes(width, height, top, seed):
    left, right, gt, _ = csw.synthetic_pair(width, height, dmax=top, seed=seed)
    s = csw.match(left, right, dmin="auto", dmax="auto").settings
    assert _dmin_bound_holds(s["dmin"], gt, s["dmin"], s["dmax"]), s


@pytest.mark.slow
@pytest.mark.data
@pytest.mark.parametrize("name", csw.dataset_names())
def test_dmin_auto_fits_every_dataset(data_dir, name):
    pair = csw.load_dataset(name, data_dir)
    s = csw.match(pair.left, pair.right, dmin="auto", dmax="auto").settings
    gt = np.where(pair.gt > 0, pair.gt, np.nan)  # 0 is "unknown" in the older sets
    assert _dmin_bound_holds(s["dmin"], gt, s["dmin"], s["dmax"]), s


@pytest.mark.parametrize("dtype, f, shape", [
    (np.uint8, 2, (241, 323)), (np.uint8, 4, (480, 640)), (np.uint8, 32, (70, 5000)),
    (np.uint16, 8, (375, 1242)), (np.uint16, 2, (9, 7))])
def test_shrink_is_the_rounded_box_average(dtype, f, shape):
    from csw.matching.disparity_range import shrink

    rng = np.random.default_rng(f)
    image = rng.integers(0, np.iinfo(dtype).max + 1, shape, dtype=dtype)
    image[:f, :f] = [[1, 2] * (f // 2)] * f  # a block whose mean is a half: to even, 2
    h, w = shape[0] // f * f, shape[1] // f * f
    mean = image[:h, :w].reshape(h // f, f, w // f, f).mean(axis=(1, 3))
    small = shrink(image, f)
    assert small.dtype == dtype and small[0, 0] == 2
    assert np.array_equal(small, np.round(mean).astype(dtype))

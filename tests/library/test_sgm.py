"""Semi-global matching as a stage of csw.match: every path a pair takes gives the
kernels' map (tests/kernels/test_sgm_oracle.py ties those to the oracle), the options
are checked at the door, and the preset is denser and more precise than accurate on a
scene with ground truth."""

import numpy as np
import pytest

import csw
from csw.config import params
from csw.data.synth import render
from csw.eval.scoring import score
from csw.kernels import sgm
from oracle import sgm_match


def test_a_bare_sgm_stage_gives_the_oracles_map():
    left, right, _, _ = render(40, 24, dmax=6, seed=2)
    result = csw.match(left, right, preset="raw", cost="sad", window=3, dmin=0, dmax=7,
                       aggregate="sgm", sgm_p1=30, sgm_p2=200, threads=1)
    disp, _, _ = sgm_match(left, right, 3, 0, 7, "sad", 4, 30, 200)
    expected = np.where(disp >= 0, disp, np.nan).astype(np.float32)
    np.testing.assert_array_equal(result.disparity, expected)
    assert result.settings["aggregate"] == "sgm"
    assert (result.settings["sgm_p1"], result.settings["sgm_p2"]) == (30, 200)


def test_default_penalties_are_reported_resolved():
    left, right, _, _ = render(64, 40, dmax=8, seed=1)
    s = csw.match(left, right, preset="sgm", dmax=10).settings
    bits = 32  # the sparse 9x9 census
    assert (s["sgm_p1"], s["sgm_p2"]) == (bits * 25 // 4, bits * 25)
    # A P1 given above the default P2 lifts the P2 left to default with it.
    s = csw.match(left, right, preset="sgm", dmax=10, sgm_p1=5000).settings
    assert (s["sgm_p1"], s["sgm_p2"]) == (5000, 5000)


def test_sgm_preset_is_more_precise_than_accurate():
    left, right, gt, _ = render(320, 240, dmax=40, seed=4)
    known = {"all": np.isfinite(gt)}
    scores = {}
    for preset in ("accurate", "sgm"):
        disp = csw.match(left, right, preset=preset, dmax=48).disparity
        scores[preset] = score(disp, gt, known, (2.0,))["all"]
    assert scores["sgm"]["bad_valid"][2.0] < scores["accurate"]["bad_valid"][2.0]
    assert scores["sgm"]["bad"][2.0] < scores["accurate"]["bad"][2.0]


def test_sgm_preset_fills_a_road_scene_that_accurate_leaves_holes_in(data_dir):
    """KITTI 2015's first frame: denser than accurate, and lower in filled bad-3."""
    from csw.data import layouts
    from csw.eval.scoring import filled_bad

    folder = data_dir / "kitti2015"
    if not folder.is_dir():
        pytest.skip(f"no KITTI 2015 pairs in {data_dir}")
    pair = layouts.find_scene(folder, "000000_10").load()
    known = np.isfinite(pair.gt)
    results = {}
    for preset in ("accurate", "sgm"):
        disp = csw.match(pair.left, pair.right, preset=preset, dmin=0, dmax=191).disparity
        density = np.isfinite(disp[known]).mean()
        results[preset] = density, filled_bad(disp, pair.gt, known, 3.0)
    assert results["sgm"][0] > results["accurate"][0] + 0.05
    assert results["sgm"][1] < results["accurate"][1]


def test_stream_equals_match_with_sgm():
    pairs = [render(96, 64, 15, 3, phase=i / 5)[:2] for i in range(5)]
    results = list(csw.Matcher(preset="sgm", dmax=15).stream(pairs, in_flight=2))
    for (left, right), result in zip(pairs, results, strict=True):
        expected = csw.match(left, right, preset="sgm", dmax=15)
        np.testing.assert_array_equal(result.disparity, expected.disparity)


def test_threads_and_bands_change_nothing_in_the_pipeline(monkeypatch):
    left, right, _, _ = render(120, 80, dmax=12, seed=5)
    whole = csw.match(left, right, preset="sgm", dmax=14, threads=1)
    monkeypatch.setattr(sgm, "BAND_BYTES", 120 * 15 * 4 * 7)  # bands of 7 rows
    banded = csw.match(left, right, preset="sgm", dmax=14, threads=2)
    np.testing.assert_array_equal(whole.disparity, banded.disparity)


@pytest.mark.parametrize("given,message", [
    (dict(aggregate="sgm", csw=True), "CSW skips candidates"),
    (dict(sgm_p1=4), "applies only with aggregate='sgm'"),
    (dict(aggregate="sgm", sgm_p1=9, sgm_p2=3), "must not exceed"),
    (dict(aggregate="sgm", engine="window"), "computes its own costs"),
    (dict(aggregate="sgm", sgm_paths=5), "sgm_paths must be one of 4, 8"),
])
def test_bad_sgm_options_fail_at_the_door(given, message):
    with pytest.raises(params.OptionError, match=message):
        params.resolve(**given)
    with pytest.raises(ValueError, match=message):
        csw.Matcher(**given)

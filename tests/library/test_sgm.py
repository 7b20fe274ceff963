"""Semi-global matching as a stage of csw.match: every path a pair takes gives the
kernels' map (tests/kernels/test_sgm_oracle.py ties those to the oracle), the options
are checked at the door, and the preset is denser and more precise than accurate on a
scene with ground truth."""

import numpy as np
import pytest

import csw
import oracle
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
    assert (s["sgm_p1"], s["sgm_p2"]) == (bits * 9 // 4, bits * 9)  # its 3x3 window
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


@pytest.mark.two_cores
def test_threads_and_bands_change_nothing_in_the_pipeline(monkeypatch):
    left, right, _, _ = render(120, 80, dmax=12, seed=5)
    whole = csw.match(left, right, preset="sgm", dmax=14, threads=1)
    monkeypatch.setattr(sgm, "BAND_BYTES", 120 * 15 * 4 * 7)  # bands of 7 rows
    banded = csw.match(left, right, preset="sgm", dmax=14, threads=2)
    np.testing.assert_array_equal(whole.disparity, banded.disparity)


@pytest.mark.parametrize("given,message", [
    (dict(aggregate="sgm", csw=True), "CSW skips candidates"),
    (dict(preset="accurate", sgm_p1=4), "applies only with aggregate='sgm'"),
    (dict(aggregate="sgm", sgm_p1=9, sgm_p2=3), "must not exceed"),
    (dict(aggregate="sgm", engine="window"), "computes its own costs"),
    (dict(aggregate="sgm", sgm_paths=6), "sgm_paths must be one of 4, 5, 8"),
    (dict(preset="accurate", sgm_narrow=24), "applies only with aggregate='sgm'"),
    (dict(aggregate="sgm", sgm_narrow=-1), "sgm_narrow"),
])
def test_bad_sgm_options_fail_at_the_door(given, message):
    with pytest.raises(params.OptionError, match=message):
        params.resolve(**given)
    with pytest.raises(ValueError, match=message):
        csw.Matcher(**given)


def test_a_narrowed_search_is_the_kernels_over_the_half_size_passes_starts():
    """The pipeline's narrowed search is kernels.sgm.match_sgm over csw.matching.narrow's
    starts (test_sgm_oracle.py ties those kernels to the oracle)."""
    from csw.matching import narrow

    left, right, _, _ = render(96, 64, dmax=30, seed=6)
    result = csw.match(left, right, preset="raw", cost="sad", window=3, dmin=0, dmax=31,
                       aggregate="sgm", sgm_p1=30, sgm_p2=200, sgm_narrow=8, threads=1)
    kw = dict(window=3, cost="sad", paths=4, p1=30, p2=200)
    starts = narrow.starts(left, right, dmin=0, dmax=31, slots=8, **kw)
    assert starts.shape == left.shape and 0 <= starts.min() <= starts.max() <= 32 - 8
    raw = sgm.match_sgm(left, right, dmin=0, dmax=31, starts=starts, slots=8, **kw)
    expected = np.where(raw.disparity >= 0, raw.disparity, np.nan).astype(np.float32)
    np.testing.assert_array_equal(result.disparity, expected)


def test_a_narrowed_search_as_wide_as_the_range_is_the_whole_search():
    left, right, _, _ = render(64, 40, dmax=8, seed=1)
    whole = csw.match(left, right, preset="sgm", dmax=15)
    wide = csw.match(left, right, preset="sgm", dmax=15, sgm_narrow=16)
    np.testing.assert_array_equal(whole.disparity, wide.disparity)
    assert wide.settings["sgm_narrow"] == 16


def test_the_half_size_pass_puts_the_true_disparity_in_the_slots():
    """On a scene with ground truth, the slots hold the true disparity wherever the
    whole search finds it, nearly, and the narrowed map is within a point of bad-2 of
    the whole search's.  (The slots miss it most near depth edges, where a span wider
    than the slots is centred on the pixel's own half-size match.)"""
    from csw.matching import narrow

    left, right, gt, _ = render(320, 240, dmax=60, seed=4)
    p1, p2 = sgm.default_penalties("census", 5, 32)
    starts = narrow.starts(left, right, dmin=0, dmax=63, slots=24, window=5,
                           cost="census", paths=4, p1=p1, p2=p2, census_window=9,
                           census_pattern="sparse")
    known = np.isfinite(gt)
    maps = {narrowed: csw.match(left, right, preset="sgm", dmax=63,
                                sgm_narrow=narrowed).disparity for narrowed in (0, 24)}
    found = known & (np.abs(maps[0] - gt) <= 2)
    truth = np.rint(gt[found])
    inside = (starts[found] <= truth) & (truth < starts[found] + 24)
    assert inside.mean() > 0.98
    bad = {k: score(disp, gt, {"all": known}, (2.0,))["all"]["bad"][2.0]
           for k, disp in maps.items()}
    assert bad[24] <= bad[0] + 1.0  # measured: 9.8 against 9.1


@pytest.mark.parametrize("shape", [(4, 4), (5, 7), (8, 3), (9, 12), (40, 33)])
@pytest.mark.parametrize("dmin", [0, -7, 5])
@pytest.mark.parametrize("threads", [1, pytest.param(2, marks=pytest.mark.two_cores)])
def test_the_starts_kernel_equals_the_oracle(shape, dmin, threads, monkeypatch):
    """kernels.filters.narrow_starts equals tests/oracle.py's narrow_starts: half-size
    matches with some, most and no pixels valid, rows without a match, spans narrower
    and wider than the slots, odd and even sizes; in stripes of rows too."""
    from csw.kernels import filters, runtime
    from csw.matching import narrow

    monkeypatch.setattr(runtime, "DIRECT_WORK", 0 if threads > 1 else runtime.DIRECT_WORK)
    height, width = shape
    h, w = height // 2, width // 2
    rng = np.random.default_rng(height * 100 + width - dmin)
    for ndisp, slots, share in ((48, 8, 0.7), (48, 40, 0.1), (20, 4, 0.97), (64, 16, 0.0)):
        half_d = ndisp // 2 + 1
        disp = (rng.integers(0, half_d, (h, w)) + dmin // 2).astype(np.int32)
        disp[rng.random((h, w)) < 0.3] = dmin // 2 - 1  # no candidate: the maps' invalid
        valid = rng.random((h, w)) < share
        valid[rng.integers(0, h)] = False  # a row without a match
        valid &= disp >= dmin // 2
        expected = oracle.narrow_starts(disp, valid, shape, dmin, ndisp, slots,
                                        narrow.MARGIN)
        got = filters.narrow_starts(disp, valid, shape, dmin // 2, ndisp, slots,
                                    2 * (dmin // 2) - dmin, narrow.MARGIN, threads)
        assert got.dtype == np.int32
        np.testing.assert_array_equal(got, expected)


def test_row_spans_take_the_nearest_matches_either_side():
    disp = np.array([[5, 0, 0, 9, 0], [0, 0, 0, 0, 0], [0, 0, 4, 0, 0]])
    valid = np.array([[1, 0, 0, 1, 0], [0, 0, 0, 0, 0], [0, 0, 1, 0, 0]], bool)
    low, high = oracle.row_spans(disp, valid)
    np.testing.assert_array_equal(low, [[5, 5, 5, 9, 9], [-1] * 5, [4] * 5])
    np.testing.assert_array_equal(high, [[5, 9, 9, 9, 9], [-1] * 5, [4] * 5])


def test_half_size_images_are_block_means():
    from csw.matching import narrow

    image = np.array([[0, 2, 9, 9, 7], [1, 1, 9, 8, 7], [5, 5, 5, 5, 5]], np.uint8)
    np.testing.assert_array_equal(narrow.half(image), [[1, 9]])


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_half_size_images_round_each_block_and_keep_their_type(dtype):
    """Every 2 x 2 block's mean, rounded half up, at the type's top too (four of its
    largest values sum beyond it)."""
    from csw.matching import narrow

    top = np.iinfo(dtype).max
    rng = np.random.default_rng(3)
    image = rng.integers(top - 3, top + 1, (7, 9)).astype(dtype)
    image[:2, :4] = rng.integers(0, top + 1, (2, 4))
    got = narrow.half(image)
    assert got.dtype == dtype and got.shape == (3, 4)
    for y, x in np.ndindex(got.shape):
        block = image[2 * y:2 * y + 2, 2 * x:2 * x + 2].astype(int)
        assert got[y, x] == (block.sum() + 2) // 4


@pytest.mark.parametrize("shape", [(1, 1), (1, 6), (5, 1), (7, 9)])
def test_the_narrowing_neighbourhood_is_each_pixels_3x3_window(shape):
    values = np.random.default_rng(sum(shape)).integers(-50, 50, shape)
    height, width = shape
    for reduce, plain in ((np.minimum, min), (np.maximum, max)):
        got = oracle.neighbourhood(values, reduce)
        for y in range(height):
            for x in range(width):
                window = [values[min(max(y + a, 0), height - 1), min(max(x + b, 0), width - 1)]
                          for a in (-1, 0, 1) for b in (-1, 0, 1)]
                assert got[y, x] == plain(window)

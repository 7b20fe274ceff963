"""Every pipeline stage equals its brute-force form in tests/oracle.py, and the pipeline
keeps its promises (checks only remove pixels, fill leaves none invalid, subpixel stays
within half a pixel of the integer winner)."""

import itertools
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import csw
import oracle
from csw import kernels
from csw.config import params
from csw.kernels import filters, runtime
from csw.matching import pipeline, stages


def random_map(rng, shape, levels=5, holes=0.2):
    disp = rng.integers(0, levels, shape).astype(np.float32)
    disp[rng.random(shape) < holes] = np.nan
    return disp


@settings(deadline=None)
@given(seed=st.integers(0, 2**31), cap=st.sampled_from([1, 7, 31, 63]),
       shape=st.tuples(st.integers(1, 7), st.integers(1, 10)),
       dtype=st.sampled_from([np.uint8, np.uint16]))
def test_xsobel_and_texture(seed, cap, shape, dtype):
    """The compiled prefilter (kernels/prefilter.py) on any shape, one row or one column
    included, and 16-bit pixels, whose responses overflow 16 bits."""
    rng = np.random.default_rng(seed)
    image = rng.integers(0, np.iinfo(dtype).max + 1, shape).astype(dtype)
    np.testing.assert_array_equal(stages.xsobel(image, cap), oracle.xsobel(image, cap))
    np.testing.assert_array_equal(stages.textured(image, 3, cap, 40),
                                  oracle.textured(image, 3, cap, 40))


@settings(deadline=None)
@given(seed=st.integers(0, 2**31), size=st.integers(1, 12), step=st.sampled_from([0.5, 1, 2]))
def test_speckle_median_fill(seed, size, step):
    rng = np.random.default_rng(seed)
    disp = random_map(rng, (7, 11))
    np.testing.assert_array_equal(filters.speckle_mask(disp, size, step),
                                  oracle.speckles(disp, size, step))
    for k in (3, 5, 7):
        np.testing.assert_array_equal(filters.median_valid(disp, k), oracle.median_valid(disp, k))
    filled = filters.fill_background(disp)
    np.testing.assert_array_equal(filled, oracle.fill_background(disp))
    assert np.isfinite(filled).all()


def test_the_3x3_medians_network_sorts_every_input():
    """By the 0-1 principle, a network that sorts all 512 inputs of 0s and 1s sorts
    every input of 9 (its Python form: the same code the kernel compiles)."""
    from csw.kernels.jit.filters import sort_nine

    for bits in itertools.product((0, 1), repeat=9):
        assert list(sort_nine.py_func(*bits)) == sorted(bits)


def test_a_3x3_median_with_infinities_and_edges_equals_the_oracle():
    disp = random_map(np.random.default_rng(11), (9, 13))
    disp[0, 3] = disp[4, 4] = np.inf
    disp[8, 12] = -np.inf
    np.testing.assert_array_equal(filters.median_valid(disp, 3),
                                  oracle.median_valid(disp, 3))


@pytest.mark.parametrize("holes", [0.0, 0.3, 0.9])
def test_a_3x3_median_of_every_small_shape_equals_the_oracle(holes):
    """The inner columns' vectorised pass (median_nine) and the edges' own, down to maps
    with no inner column or row."""
    rng = np.random.default_rng(5)
    for shape in itertools.product(range(1, 6), range(1, 7)):
        disp = random_map(rng, shape, levels=50, holes=holes)
        np.testing.assert_array_equal(filters.median_valid(disp, 3),
                                      oracle.median_valid(disp, 3))


def test_the_5x5_medians_network_puts_every_rank_it_keeps_in_place():
    """By the 0-1 principle, over all 2^25 inputs of 0s and 1s (bit-sliced: wire i holds
    bit i of every input m, 8 inputs a byte): a network puts rank r in place for every
    input if it does for every 0-1 input, where rank r is 1 exactly when the input has
    more than 24 - r ones."""
    network = filters.median_network(5)
    chunk = np.arange(1 << 20, dtype=np.uint32)
    for high in range(1 << 5):
        inputs = chunk | np.uint32(high << 20)
        wires = [np.packbits((inputs >> np.uint32(i)) & np.uint32(1)) for i in range(25)]
        for a, b in network:
            wires[a], wires[b] = wires[a] & wires[b], wires[a] | wires[b]
        ones = np.bitwise_count(inputs)
        for rank in range(13):
            np.testing.assert_array_equal(wires[rank], np.packbits(ones > 24 - rank))


@pytest.mark.parametrize("size", [5, 7, 9])
@pytest.mark.parametrize("holes", [0.0, 0.3, 0.9])
def test_a_larger_median_equals_the_oracle_across_blocks_and_edges(size, holes):
    """The network's blocks of columns (filters.MEDIAN_BLOCK; the last one short), the
    rows above and below the map none of the window's, equal values, infinities, and
    maps narrower than the window (no inner column: the edges' insertion sort alone)."""
    rng = np.random.default_rng(size)
    shapes = [(1, 3), (3, size - 1), (4, 2 * size - 2), (size + 2, size),
              (6, 2 * filters.MEDIAN_BLOCK + 13)]
    for shape in shapes:
        disp = random_map(rng, shape, levels=12, holes=holes)
        disp[rng.random(shape) < 0.03] = np.inf
        disp[rng.random(shape) < 0.03] = -np.inf
        np.testing.assert_array_equal(filters.median_valid(disp, size),
                                      oracle.median_valid(disp, size))
    with pytest.raises(ValueError, match="odd"):  # the kernel's scratch is sized for odd
        filters.median_valid(disp, size - 1)


@pytest.mark.two_cores
def test_median_of_a_frame_splits_its_rows_and_changes_nothing(monkeypatch):
    """A KITTI-size median is worth both threads: its stripes give the one-thread map."""
    disp = random_map(np.random.default_rng(5), (400, 800))
    one = filters.median_valid(disp, 3, threads=1)
    counts = []
    real = runtime.run_stripes
    monkeypatch.setattr(runtime, "run_stripes",
                        lambda stripe, count, *a: counts.append(count) or
                        real(stripe, count, *a))
    np.testing.assert_array_equal(filters.median_valid(disp, 3, threads=2), one)
    assert counts == [2]


@settings(deadline=None, max_examples=40)
@given(seed=st.integers(0, 2**31), size=st.integers(1, 40), step=st.sampled_from([0.5, 1]),
       height=st.integers(2, 30))
def test_speckle_in_stripes_equals_the_oracle(seed, size, step, height, monkeypatch_work):
    """Maps big enough for stripes (here: all of them) find their regions in parallel
    stripes joined across the edges; regions that span the edges, in any shape, come out
    as the whole map's."""
    if runtime.max_threads() < 2:
        pytest.skip("one core: no stripes to join")
    rng = np.random.default_rng(seed)
    disp = random_map(rng, (height, 13), levels=3, holes=0.15)
    np.testing.assert_array_equal(filters.speckle_mask(disp, size, step, threads=2),
                                  oracle.speckles(disp, size, step))


@settings(deadline=None)
@given(seed=st.integers(0, 2**31), dmin=st.sampled_from([0, -3]), limit=st.integers(0, 2),
       height=st.integers(1, 6), width=st.integers(1, 12))
def test_winner_check_equals_the_oracle(seed, dmin, limit, height, width):
    """StereoBM's left-right check on any map: ties in cost, every disparity a right
    pixel inside the image (as the kernels' are), a negative range's invalid value."""
    rng = np.random.default_rng(seed)
    invalid = kernels.invalid(dmin)
    x = np.arange(width)
    # d in [dmin, dmin + 5] with 0 <= x - d < width, else invalid; few costs: ties.
    disp = rng.integers(dmin, dmin + 6, (height, width))
    disp = np.where((x - disp >= 0) & (x - disp < width) & (rng.random(disp.shape) < 0.85),
                    disp, invalid).astype(np.int32)
    cost = rng.integers(0, 4, (height, width)).astype(np.int64)
    got = filters.winners_consistent(disp, cost, limit, invalid)
    np.testing.assert_array_equal(got, oracle.winners_consistent(disp, cost, limit, invalid))


@pytest.mark.parametrize("engine", kernels.ENGINE_NAMES)
def test_winner_check_in_the_pipeline(small_scene, engine):
    """The one-pass float map and the general path (the confidence asks for the second
    costs) give the raw map with the oracle's check applied, on either engine."""
    left, right = small_scene[0][:40, :60], small_scene[1][:40, :60]
    options = dict(preset="raw", engine=engine, prefilter="xsobel", window=5, dmax=12)
    raw = csw.match(left, right, **options)
    winner = np.where(np.isfinite(raw.disparity), raw.disparity, -1).astype(np.int32)
    want = np.where(oracle.winners_consistent(winner, raw.min_cost, 1), raw.disparity,
                    np.nan)
    for confidence in (False, True):
        got = csw.match(left, right, winner_check=1, want_confidence=confidence, **options)
        np.testing.assert_array_equal(got.disparity, want)
    assert 0 < np.isnan(want).mean() < 0.5


@pytest.fixture(scope="module")
def monkeypatch_work():
    """Every speckle mask runs in stripes (one per thread): its work counts as huge."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(filters, "SPECKLE_WORK", 10**9)
        yield


@pytest.mark.slow
@settings(deadline=None)
@given(seed=st.integers(0, 2**31), engine=st.sampled_from(list(kernels.ENGINE_NAMES)),
       cost=st.sampled_from(["sad", "census", "ssd"]), fit=st.sampled_from(["parabola", "linear"]),
       lr=st.integers(0, 2), ratio=st.sampled_from([0, 10, 40]), csw_on=st.booleans())
def test_checks_and_subpixel_equal_the_oracle(seed, engine, cost, fit, lr, ratio, csw_on):
    rng = np.random.default_rng(seed)
    left = rng.integers(0, 8, (8, 16)).astype(np.uint8)
    right = np.roll(left, -2, axis=1)
    right[rng.random(right.shape) < 0.2] = 3
    args = dict(engine=engine, window=3, dmin=0, dmax=6, cost=cost, csw=csw_on,
                tau=10**9 if csw_on else -1, rule="unique",
                csw_margin=params.csw_margin_for(cost))
    stages = replace(params.OFF_STAGES, lr_check=lr, uniqueness_ratio=ratio, subpixel=fit)
    disp, confidence, raw = pipeline.run(left, right, args, stages)
    want_disp, mins, _, more = oracle.oracle_match(
        left, right, 3, 0, 6, cost, csw_on, args["tau"], rule="unique", extras=True)
    valid = oracle.lr_consistent(want_disp, more["right_disparity"], lr)
    second = more["second_cost"]
    valid &= (second < 0) | (second * 100 > mins * (100 + ratio))
    want = oracle.subpixel(want_disp, mins, more["prev_cost"], more["next_cost"], fit)
    want = np.where(valid, want, np.nan).astype(np.float32)
    np.testing.assert_array_equal(disp, want)
    # The checks only remove pixels; subpixel stays within half a pixel of the winner.
    winner = kernels.match(left, right, census_window=5, census_pattern="dense",
                           **args).disparity
    np.testing.assert_array_equal(raw.min_cost, mins)
    assert not (np.isfinite(disp) & (winner < 0)).any()
    ok = np.isfinite(disp)
    assert (np.abs(disp[ok] - winner[ok]) <= 0.5).all()
    assert ((confidence >= 0) & (confidence <= 1)).all() and (confidence[~ok] == 0).all()


def test_confidence_is_each_valid_pixels_second_best_margin():
    rng = np.random.default_rng(5)
    best = rng.integers(-1, 50, (6, 7))
    second = np.where(rng.random(best.shape) < 0.3, -1, best + rng.integers(0, 9, best.shape))
    second[0, :3] = 0  # no margin to divide by
    valid = rng.random(best.shape) < 0.8
    got = pipeline.confidence_map(best, second, valid)
    assert got.dtype == np.float32
    for y, x in np.ndindex(best.shape):
        ok = valid[y, x] and second[y, x] > 0
        want = (second[y, x] - best[y, x]) / second[y, x] if ok else 0.0
        assert got[y, x] == np.float32(want)


def test_fill_leaves_nothing_invalid_and_presets(small_scene):
    left, right, _, _ = small_scene
    filled = csw.match(left, right, dmax=16, preset="accurate", fill="background")
    assert np.isfinite(filled.disparity).all()
    sparse = csw.match(left, right, dmax=16, preset="accurate")
    assert 0 < np.isnan(sparse.disparity).mean() < 0.5
    assert sparse.settings["cost"] == "census"
    raw = csw.match(left, right, dmax=16, preset="raw")
    assert np.isfinite(raw.disparity).all()


@pytest.mark.parametrize("kwargs, message", [
    (dict(preset="paper", fill="background"), "paper preset"),
    (dict(preset="nice"), "preset must be one of"),
    (dict(subpixel="cubic"), "subpixel must be one of"),
    (dict(median=4), "median must be"),
    (dict(cost="census", census_window=9, census_pattern="dense"), "more than 64"),
    (dict(census_window=17), "more than 64"),  # the accurate preset's sparse census
    (dict(census_pattern="checker"), "census_pattern must be one of"),
    (dict(prefilter_cap=0, prefilter="xsobel"), "prefilter_cap"),
])
def test_bad_stage_options(small_scene, kwargs, message):
    with pytest.raises(ValueError, match=message):
        csw.match(small_scene[0], small_scene[1], dmax=16, **kwargs)


def test_each_stage_option_belongs_to_exactly_one_stage_record():
    """A stage lives in one record: its options, margins, bytes, entries and step."""
    owned = [name for stage in stages.STAGES for name in stage.options]
    assert sorted(owned) == sorted(params.STAGE_NAMES)
    assert len(set(owned)) == len(owned)
    for stage in stages.STAGES:
        assert stage.kind in ("images", "costs", "check", "disparity", "filter")
        assert (stage.step is None) == (stage.kind == "costs"), stage.name
        assert not stage.on(params.OFF_STAGES, "sad"), stage.name  # off in the contract


def test_margins_and_entries_come_from_the_stage_records():
    accurate = params.resolve(preset="accurate").stages
    assert pipeline.row_overlap(accurate, 9, "census") == 4 + 4  # window, census 9x9
    assert pipeline.row_overlap(accurate, 9, "sad") == 4
    both = replace(params.OFF_STAGES, prefilter="xsobel", texture_threshold=10)
    assert pipeline.row_overlap(both, 9, "sad") == 5  # one x-Sobel row, shared
    assert pipeline.filter_overlap(replace(accurate, median=5)) == 99 + 2
    loaded = pipeline.entries(dict(engine="fast", cost="census", window=9, dmin=0),
                              replace(accurate, median=3, fill="background"),
                              np.dtype(np.uint8))
    assert [e for e in loaded if e[0] == "filters"] == [
        ("filters", ("speckle",)), ("filters", ("median",)), ("filters", ("fill",)),
        ("filters", ("float",))]  # the float map, which every run may make


def test_sgm_makes_the_second_best_only_where_something_reads_it(small_scene):
    """Subpixel reads the neighbours' costs alone: the sgm preset's map is the same with
    and without a confidence, which is made only when asked for or when the uniqueness
    check needs the second best."""
    left, right = small_scene[:2]
    plain = csw.match(left, right, dmax=12, preset="sgm")
    asked = csw.match(left, right, dmax=12, preset="sgm", want_confidence=True)
    np.testing.assert_array_equal(plain.disparity, asked.disparity)
    assert not plain.confidence.any() and asked.confidence.max() > 0
    unique = csw.match(left, right, dmax=12, preset="sgm", uniqueness_ratio=10)
    assert unique.confidence.max() > 0
    assert np.isnan(unique.disparity).sum() >= np.isnan(plain.disparity).sum()

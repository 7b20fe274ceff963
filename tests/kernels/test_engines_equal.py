"""The fast engine equals the window engine bit for bit on every registered dataset.

(Both are also compared to the oracle on random inputs in test_kernels_oracle.py; the
oracle is too slow for full-size real images, so here the window engine stands in.)
"""

import numpy as np
import pytest

import oracle
from csw import kernels
from csw.config.tau import paper_tau
from csw.data import datasets as D
from csw.kernels import fast as fast_engine


def assert_engines_equal(left, right, **options):
    window = kernels.match(left, right, engine="window", **options)
    fast = kernels.match(left, right, engine="fast", **options)
    np.testing.assert_array_equal(fast.disparity, window.disparity)
    np.testing.assert_array_equal(fast.min_cost, window.min_cost)
    assert fast.evaluated == window.evaluated
    return window


def check_pair(pair, cost, window=9):
    options = dict(window=window, dmin=0, dmax=pair.dmax, cost=cost)
    plain = assert_engines_equal(pair.left, pair.right, **options)
    tau = paper_tau(plain.min_cost)
    csw = assert_engines_equal(pair.left, pair.right, csw=True, tau=tau, **options)
    assert 0 < csw.work_saved < 1  # the CSW run really skipped work


@pytest.mark.slow
@pytest.mark.data
@pytest.mark.parametrize("name", sorted(D.DATASETS))
def test_engines_equal_on_every_dataset(name, data_dir):
    pair = D.load(name, data_dir, allow_download=False)
    check_pair(pair, "sad")


@pytest.mark.slow
@pytest.mark.data
@pytest.mark.parametrize("cost", ["ssd", "shd"])
def test_engines_equal_on_tsukuba_other_costs(cost, data_dir):
    check_pair(D.load("tsukuba", data_dir, allow_download=False), cost)


@pytest.mark.slow
def test_engines_equal_on_synthetic_16_bit_with_dmin():
    pair = D.load("synthetic")
    left, right = pair.left.astype(np.uint16) * 257, pair.right.astype(np.uint16) * 251
    for cost in ("sad", "ssd", "shd"):
        options = dict(window=5, dmin=7, dmax=40, cost=cost)
        plain = assert_engines_equal(left, right, **options)
        assert_engines_equal(left, right, csw=True, tau=paper_tau(plain.min_cost), **options)


@pytest.mark.parametrize("cost, dtype, window, expected", [
    ("sad", np.uint8, 9, np.uint16),     # 81 * 255 fits 16 bits
    ("sad", np.uint8, 17, np.int32),     # 289 * 255 does not
    ("ssd", np.uint8, 9, np.int32),
    ("ssd", np.uint16, 9, np.int64),
    ("shd", np.uint16, 9, np.uint16),
])
def test_accumulator_width(cost, dtype, window, expected):
    from csw.kernels.contract import COSTS
    from csw.kernels.fast import accumulator_dtype

    assert accumulator_dtype(np.dtype(dtype), COSTS[cost], window) == expected


def test_wrapping_uint16_sums_stay_exact_at_the_limit():
    # SAD 9x9 on 0/255 checkerboards: window costs reach 81 * 255 = 20655 and column
    # sums go up and down by 255 per row, so any wrap mistake would show.
    rng = np.random.default_rng(5)
    left = (rng.integers(0, 2, (40, 60)) * 255).astype(np.uint8)
    right = (rng.integers(0, 2, (40, 60)) * 255).astype(np.uint8)
    result = assert_engines_equal(left, right, window=9, dmin=0, dmax=30, cost="sad")
    assert result.min_cost.max() > 10000


@pytest.mark.parametrize("keyed_range", [0, fast_engine.KEYED_RANGE])
@pytest.mark.parametrize("ndisp", [40, 100, 200])
@pytest.mark.parametrize("cost", ["sad", "census"])
def test_every_map_equal_across_the_selection_paths(ndisp, cost, keyed_range, monkeypatch):
    """The fast engine picks the minimum in one of two ways (packed keys up to a range
    that depends on the CPU, else two passes, the right map beside either: see
    KEYED_RANGE in kernels/fast.py); every map of each equals the window engine's on
    ranges that take each way, with and without CSW, whichever way this CPU prefers."""
    monkeypatch.setattr(fast_engine, "keyed_range", lambda: keyed_range)
    rng = np.random.default_rng(ndisp)
    left = rng.integers(0, 4, (12, ndisp + 60)).astype(np.uint8)  # few levels: ties
    right = np.roll(left, -ndisp // 3, axis=1) ^ (rng.random(left.shape) < 0.1)
    right = right.astype(np.uint8)
    for mode in ({}, {"csw": True, "tau": 60},
                 {"csw": True, "tau": 60, "rule": "unique", "csw_margin": 12}):
        options = dict(window=3, dmin=0, dmax=ndisp - 1, cost=cost, census_window=3,
                       census_pattern="dense",
                       right_map=True, extras=True, **mode)
        window = kernels.match(left, right, engine="window", **options)
        fast = kernels.match(left, right, engine="fast", **options)
        for name in ("disparity", "min_cost", "second_cost", "prev_cost", "next_cost",
                     "right_disparity"):
            np.testing.assert_array_equal(getattr(fast, name), getattr(window, name),
                                          err_msg=f"{name} {mode}")
        no_maps = dict(options, right_map=False, extras=False)
        np.testing.assert_array_equal(
            kernels.match(left, right, engine="fast", **no_maps).disparity, window.disparity)


@pytest.mark.parametrize("dmin, dmax", [(0, 39), (0, 99), (0, 199), (-7, 20)])
@pytest.mark.parametrize("cost", ["sad", "census"])
def test_the_left_right_check_made_in_the_rows_equals_the_oracle(dmin, dmax, cost):
    """The fast engine checks each row as it ends, from the right image's best matches as
    they stand then; the window engine checks its two finished maps.  Both equal the
    oracle's check on the window engine's maps, on every selection path, with and
    without CSW, on negative ranges and on sampled rows."""
    ndisp = dmax - dmin + 1
    rng = np.random.default_rng(ndisp)
    left = rng.integers(0, 4, (12, ndisp + 60)).astype(np.uint8)
    right = np.roll(left, -ndisp // 3 - dmin, axis=1) ^ (rng.random(left.shape) < 0.1)
    right = right.astype(np.uint8)
    right[:, 5:15] = rng.integers(0, 4, (12, 10))  # a band the left image does not see
    for mode in ({}, {"csw": True, "tau": 60},
                 {"csw": True, "tau": 60, "rule": "unique", "csw_margin": 12}):
        options = dict(window=3, dmin=dmin, dmax=dmax, cost=cost, census_window=3,
                       census_pattern="dense", **mode)
        maps = kernels.match(left, right, engine="window", right_map=True, **options)
        for limit in (0, 2):
            want = oracle.lr_consistent(maps.disparity, maps.right_disparity, limit,
                                        kernels.invalid(dmin))
            assert 0.5 < want.mean() < 1 or mode  # CSW's claims may leave nothing to refuse
            for engine in ("fast", "window"):
                got = kernels.match(left, right, engine=engine, lr_check=limit, **options)
                np.testing.assert_array_equal(got.lr_valid, want, err_msg=f"{engine} {mode}")
                assert got.right_disparity is None  # not stored unless asked for
            rows = np.array([1, 2, 7])
            sampled = kernels.match(left, right, engine="fast", lr_check=limit, rows=rows,
                                    **options)
            np.testing.assert_array_equal(sampled.lr_valid, want[rows])

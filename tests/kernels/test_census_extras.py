"""Census cost and the extra maps (second-best, neighbour costs, the right image's map)
equal the oracle bit for bit on both engines, with and without CSW."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from csw import kernels
from csw.config.params import csw_margin_for
from csw.kernels.census import census_transform
from oracle import census, oracle_match

ENGINES = list(kernels.ENGINE_NAMES)


@pytest.mark.parametrize("size, pattern, bits",
                         [(3, "dense", 8), (5, "dense", 24), (7, "dense", 48),
                          (3, "sparse", 8), (5, "sparse", 16), (7, "sparse", 16),
                          (9, "sparse", 32), (11, "sparse", 32), (15, "sparse", 56)])
def test_census_transform_equals_the_oracle(size, pattern, bits):
    rng = np.random.default_rng(size)
    image = rng.integers(0, 6, (17, 19)).astype(np.uint8)  # few levels: many ties
    codes = census_transform(image, size, pattern=pattern)
    want = census(image, size, pattern)
    assert [[int(v) for v in row] for row in codes] == want.tolist()
    # The first neighbour's bit is the code's top one, in the narrowest type holding it.
    assert max(int(v) for v in want.ravel()).bit_length() == bits
    assert codes.dtype.itemsize * 8 == max(8, 1 << (bits - 1).bit_length())


@pytest.mark.parametrize("size, pattern, fix", [
    (9, "dense", "census window of 7 or less or the sparse pattern$"),
    (17, "sparse", "census window of 15 or less$")])
def test_census_window_over_64_bits_is_refused(size, pattern, fix):
    img = np.zeros((20, 20), np.uint8)
    with pytest.raises(ValueError, match=f"more than 64; use a {fix}"):
        kernels.match(img, img, engine="fast", window=3, dmin=0, dmax=2, cost="census",
                      census_window=size, census_pattern=pattern)


def assert_same(got, want):
    disp, mins, evaluated, more = want
    np.testing.assert_array_equal(got.disparity, disp)
    np.testing.assert_array_equal(got.min_cost, mins)
    assert got.evaluated == evaluated
    for name, values in more.items():
        np.testing.assert_array_equal(getattr(got, name), values, err_msg=name)


@pytest.mark.slow
@settings(deadline=None)
@given(seed=st.integers(0, 2**31), cost=st.sampled_from(["sad", "census", "shd", "ssd"]),
       census_kind=st.sampled_from([(3, "dense"), (5, "dense"), (7, "dense"), (5, "sparse"),
                                    (9, "sparse")]),
       window=st.sampled_from([1, 3, 5]),
       dmin=st.integers(0, 2), span=st.integers(0, 6),
       mode=st.sampled_from(["plain", "literal", "unique"]), levels=st.sampled_from([3, 256]))
def test_extras_and_census_equal_the_oracle(seed, cost, census_kind, window, dmin, span,
                                            mode, levels):
    rng = np.random.default_rng(seed)
    left = rng.integers(0, levels, (7, 14)).astype(np.uint8)
    right = np.roll(left, -2, axis=1) ^ (rng.random(left.shape) < 0.2).astype(np.uint8)
    dmax = min(dmin + span, 13)
    csw = mode != "plain"
    rule = "literal" if mode == "plain" else mode
    tau = {"plain": -1, "literal": 40, "unique": 10**9}[mode]
    census_window, census_pattern = census_kind
    want = oracle_match(left, right, window, dmin, dmax, cost, csw, tau, rule=rule,
                        census_window=census_window, census_pattern=census_pattern,
                        extras=True)
    for engine in ENGINES:
        got = kernels.match(left, right, engine=engine, window=window, dmin=dmin, dmax=dmax,
                            cost=cost, csw=csw, tau=tau, rule=rule, csw_margin=csw_margin_for(cost),
                            census_window=census_window, census_pattern=census_pattern,
                            extras=True, right_map=True)
        assert_same(got, want)


@pytest.mark.parametrize("engine", ENGINES)
def test_extras_leave_the_map_unchanged_and_sampled_rows_work(engine, small_scene):
    left, right, _, _ = small_scene
    options = dict(engine=engine, window=5, dmin=0, dmax=16, cost="census", census_window=5,
                   census_pattern="dense")
    plain = kernels.match(left, right, **options)
    extra = kernels.match(left, right, extras=True, right_map=True, **options)
    assert plain.second_cost is None and plain.right_disparity is None
    np.testing.assert_array_equal(extra.disparity, plain.disparity)
    rows = np.array([3, 30, 60])
    sampled = kernels.match(left, right, right_map=True, rows=rows, **options)
    assert sampled.second_cost is None
    np.testing.assert_array_equal(sampled.right_disparity, extra.right_disparity[rows])

"""Every engine equals the brute-force oracle exactly (tests/oracle.py)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from csw import kernels
from csw.config.params import csw_margin_for
from oracle import oracle_match

ENGINES = list(kernels.ENGINE_NAMES)


def random_pair(rng, height, width, dtype, shift=3, noise=0):
    """A random pair where right is left shifted by ``shift`` plus noise."""
    top = 256 if dtype == np.uint8 else 65536
    left = rng.integers(0, top, (height, width), dtype=np.int64)
    right = np.roll(left, -shift, axis=1) + rng.integers(-noise, noise + 1, left.shape)
    return left.astype(dtype), np.clip(right, 0, top - 1).astype(dtype)


def assert_equal_to_oracle(engine, left, right, **kw):
    """The kernels' map equals the oracle's; the unique rule's margin, which the kernels
    need given, is the oracle's default where ``kw`` has none."""
    margin = kw.get("csw_margin")
    if margin is None and kw.get("rule") == "unique":
        margin = csw_margin_for(kw["cost"])
    got = kernels.match(left, right, engine=engine, **dict(kw, csw_margin=margin))
    disp, mins, evaluated = oracle_match(left, right, kw["window"], kw["dmin"], kw["dmax"],
                                         kw["cost"], kw.get("csw", False), kw.get("tau", -1),
                                         rule=kw.get("rule", "literal"),
                                         csw_margin=kw.get("csw_margin"),
                                         slack=kw.get("slack"))
    np.testing.assert_array_equal(got.disparity, disp)
    np.testing.assert_array_equal(got.min_cost, mins)
    assert got.evaluated == evaluated


SLOW = pytest.mark.slow  # the oracle is plain Python: make test-quick keeps 8-bit SAD, window 3


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("cost", ["sad", pytest.param("ssd", marks=SLOW),
                                  pytest.param("shd", marks=SLOW)])
@pytest.mark.parametrize("window", [pytest.param(1, marks=SLOW), 3, pytest.param(9, marks=SLOW)])
@pytest.mark.parametrize("dtype", [np.uint8, pytest.param(np.uint16, marks=SLOW)])
def test_matches_oracle_plain_and_csw(engine, cost, window, dtype):
    rng = np.random.default_rng(window * 7 + len(cost))
    left, right = random_pair(rng, 11, 23, dtype, shift=2, noise=20)
    # dmax reaches past the left border for the first columns; dmin > 0 in one run.
    for dmin, dmax in [(0, 7), (2, 9)]:
        assert_equal_to_oracle(engine, left, right, window=window, dmin=dmin, dmax=dmax,
                               cost=cost)
        # tau from the plain min-cost distribution: the low quartile marks some pixels.
        plain = kernels.match(left, right, engine=engine, window=window, dmin=dmin,
                              dmax=dmax, cost=cost)
        for q in (25, 75):
            tau = float(np.percentile(plain.min_cost[plain.min_cost >= 0], q))
            for rule, csw_margin, slack in (("literal", None, None), ("unique", 0, None),
                                            ("unique", None, None), ("unique", 5, 0),
                                            ("literal", None, 2)):
                assert_equal_to_oracle(engine, left, right, window=window, dmin=dmin,
                                       dmax=dmax, cost=cost, csw=True, tau=tau, rule=rule,
                                       csw_margin=csw_margin, slack=slack)


@pytest.mark.slow
@settings(deadline=None)  # examples per run: see the profiles in conftest.py
@given(
    engine=st.sampled_from(ENGINES),
    seed=st.integers(0, 2**32 - 1),
    height=st.integers(1, 9),
    width=st.integers(2, 20),
    window=st.sampled_from([1, 3, 5]),
    cost=st.sampled_from(["sad", "ssd", "shd"]),
    sixteen=st.booleans(),
    csw=st.booleans(),
    tau_quantile=st.floats(0, 100),
    rule=st.sampled_from(["literal", "unique"]),
    csw_margin=st.integers(0, 40),
    data=st.data(),
)
def test_matches_oracle_hypothesis(engine, seed, height, width, window, cost, sixteen, csw,
                                   tau_quantile, rule, csw_margin, data):
    window = min(window, height if height % 2 else height - 1, width if width % 2 else width - 1)
    if window < 1:
        window = 1
    # Ranges reaching below 0 too: a candidate's right pixel must then lie in the image.
    dmax = data.draw(st.integers(-(width - 1), width - 1))
    dmin = data.draw(st.integers(-(width - 1), dmax))
    rng = np.random.default_rng(seed)
    dtype = np.uint16 if sixteen else np.uint8
    # Few grey levels make ties frequent, which exercises the smallest-d rule.
    levels = data.draw(st.sampled_from([2, 4, 256]))
    left = (rng.integers(0, levels, (height, width)) * (255 // (levels - 1))).astype(dtype)
    right = (rng.integers(0, levels, (height, width)) * (255 // (levels - 1))).astype(dtype)
    if sixteen:
        left, right = left * 257, right * 257
    plain = kernels.match(left, right, engine=engine, window=window, dmin=dmin, dmax=dmax,
                          cost=cost)
    valid = plain.min_cost[plain.min_cost >= 0]
    tau = float(np.percentile(valid, tau_quantile)) if valid.size else 0.0
    assert_equal_to_oracle(engine, left, right, window=window, dmin=dmin, dmax=dmax,
                           cost=cost, csw=csw, tau=tau, rule=rule, csw_margin=csw_margin)


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("shape", [(1, 1), (1, 6), (6, 1), (2, 3), (5, 7)])
def test_tiny_and_constant_images(engine, shape):
    """Edge shapes (one row, one column, one pixel), every disparity range the width
    allows, and a constant pair, where every candidate ties and the smallest d wins."""
    rng = np.random.default_rng(sum(shape))
    varied = rng.integers(0, 256, shape, dtype=np.int64).astype(np.uint8)
    constant = np.full(shape, 77, np.uint8)
    for left, right in ((varied, varied[:, ::-1].copy()), (constant, constant)):
        for dmin, dmax in {(0, 0), (0, shape[1] - 1), (shape[1] - 1, shape[1] - 1)}:
            for rule in ("literal", "unique"):
                assert_equal_to_oracle(engine, left, right, window=1, dmin=dmin, dmax=dmax,
                                       cost="sad", csw=True, tau=40, rule=rule)
    plain = kernels.match(constant, constant, engine=engine, window=1, dmin=0,
                          dmax=shape[1] - 1, cost="sad")
    assert (plain.disparity == 0).all() and (plain.min_cost == 0).all()

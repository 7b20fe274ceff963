"""Bound calls: a kernel's call made once and run again on each pair of a stream (bound entry
calls, kernels/native.py; FastCall, CensusCall, SpeckleCall), and the one-pass float
map.  A bound call's result equals the plain call's bit for bit, pair after pair."""

import numpy as np
import pytest

from csw import kernels
from csw.data.synth import render
from csw.kernels import filters, native, runtime
from csw.kernels.census import CensusCall, census_transform
from csw.kernels.fast import FastCall, match_fast
from csw.kernels.workspace import Workspace

FIELDS = ("disparity", "min_cost", "second_cost", "prev_cost", "next_cost",
          "right_disparity", "lr_valid")


def assert_results_equal(got, expected):
    for name in FIELDS:
        a, b = getattr(got, name), getattr(expected, name)
        assert (a is None) == (b is None), name
        if a is not None:
            np.testing.assert_array_equal(a, b, err_msg=name)
    assert (got.evaluated, got.candidates) == (expected.evaluated, expected.candidates)


def pairs(dtype, count=3, seed=0):
    """Random pairs and a rendered one, of one shape: a bound call sees different pixels each
    time, so nothing of the last pair may leak into the next."""
    rng = np.random.default_rng(seed)
    top = np.iinfo(dtype).max
    out = [tuple(rng.integers(0, top + 1, (40, 57), dtype=dtype) for _ in range(2))
           for _ in range(count - 1)]
    left, right = render(57, 40, 12, seed=seed)[:2]
    scale = 257 if dtype == np.uint16 else 1
    return out + [(left.astype(dtype) * scale, right.astype(dtype) * scale)]


CASES = [
    dict(cost="sad"),
    dict(cost="ssd", csw=True, tau=900),
    dict(cost="census", census_window=5, census_pattern="dense"),
    dict(cost="census", census_window=9, census_pattern="sparse", lr_check=1),
    dict(cost="sad", csw=True, tau=400, rule="unique", csw_margin=12, extras=True),
    dict(cost="census", census_window=7, census_pattern="dense", extras=True,
         right_map=True, lr_check=0),
    dict(cost="sad", dmin=3, lr_check=2, right_map=True),
]


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("case", CASES)
def test_a_planned_match_equals_a_fresh_one_pair_after_pair(case, dtype):
    options = dict(dict(window=5, dmin=0, dmax=12), **case)
    workspace = Workspace()
    for left, right in pairs(dtype):
        got = match_fast(left, right, workspace=workspace, **options)
        assert_results_equal(got, match_fast(left, right, **options))
    call = workspace.kept("fast-call", (left.shape, left.dtype, right.shape, right.dtype,
                                        *_ordered(options).values()))
    assert isinstance(call, FastCall)  # the workspace's bound call did the matching


def _ordered(options):
    """match_fast's options in the order of its bound call's key, with its defaults."""
    names = ("window", "dmin", "dmax", "cost", "csw", "tau", "rule", "csw_margin", "slack",
             "census_window", "census_pattern", "extras", "right_map", "lr_check")
    defaults = dict(csw=False, tau=-1, rule="literal", csw_margin=None, slack=None,
                    census_window=None, census_pattern=None, extras=False,
                    right_map=False, lr_check=None)
    return {name: options.get(name, defaults.get(name)) for name in names}


def test_a_plan_writes_into_the_callers_outputs_and_results_own_their_maps():
    (left, right), (left2, right2) = pairs(np.uint8, 2)
    options = dict(window=5, dmin=0, dmax=12, cost="sad", lr_check=1)
    workspace = Workspace()
    mine = {"disparity": np.empty(left.shape, np.int32),
            "lr_valid": np.empty(left.shape, np.uint8)}
    got = match_fast(left, right, workspace=workspace, into=mine, **options)
    assert np.shares_memory(got.disparity, mine["disparity"])
    assert np.shares_memory(got.lr_valid, mine["lr_valid"])
    first = match_fast(left, right, workspace=workspace, **options)
    match_fast(left2, right2, workspace=workspace, **options)  # the next pair
    assert_results_equal(first, match_fast(left, right, **options))


def test_what_a_plan_does_not_cover_runs_unplanned_with_equal_results():
    left, right = pairs(np.uint8, 1)[0]
    assert not FastCall.fits(left.shape, left.dtype, dict(dmin=-3, dmax=9, cost="sad"))
    assert not FastCall.fits((2000, 2000), np.dtype(np.uint8),
                             dict(dmin=0, dmax=63, cost="sad"))  # more than one stripe
    workspace = Workspace()
    for options in (dict(dmin=-3, dmax=9), dict(dmin=0, dmax=9, rows=[0, 5, 9])):
        got = match_fast(left, right, window=5, cost="sad", workspace=workspace, **options)
        assert_results_equal(got, match_fast(left, right, window=5, cost="sad", **options))
    assert workspace.kept("fast-call", None) is None and not workspace._kept


def test_a_plan_refuses_a_pair_of_another_shape_or_type():
    call = FastCall((40, 57), np.uint8, window=5, dmin=0, dmax=12, cost="sad")
    left, right = pairs(np.uint8, 1)[0]
    call(left, right)
    with pytest.raises(ValueError, match="pairs of"):
        call(left[:, :50], right[:, :50])
    with pytest.raises(ValueError, match="pairs of"):
        call(left.astype(np.uint16), right.astype(np.uint16))


def test_a_census_plan_equals_the_transform_in_every_layout():
    rng = np.random.default_rng(3)
    calls = {}
    for _ in range(2):
        image = rng.integers(0, 256, (31, 45), dtype=np.uint8)
        for pad, reverse in ((0, False), (2, False), (4, True)):
            call = calls.setdefault((pad, reverse), CensusCall(
                image.shape, image.dtype, 7, "dense", pad=pad, reverse=reverse))
            np.testing.assert_array_equal(
                call(image), census_transform(image, 7, pad=pad, reverse=reverse,
                                              pattern="dense"))


def test_a_bound_call_takes_only_arrays_of_its_bound_type_and_shape():
    entry = native.entry("filters", ("float",))
    disp = np.zeros((4, 5), np.int32)
    out = np.empty((4, 5), np.float32)
    bound = entry.bind(disp=disp, lr_valid=np.zeros((1, 1), np.uint8), out=out, y0=0,
                       y1=4, invalid=-1, checked=0)
    other = np.arange(20, dtype=np.int32).reshape(4, 5)
    bound.point("disp", other)
    bound()
    np.testing.assert_array_equal(out, other.astype(np.float32))
    for wrong in (np.zeros((4, 6), np.int32), np.zeros((4, 5), np.int64),
                  np.zeros((5, 4), np.int32).T):
        with pytest.raises(TypeError, match="disp must be"):
            bound.point("disp", wrong)


def speckled(seed, shape=(60, 80)):
    """A float map of flat regions of many sizes, with holes."""
    rng = np.random.default_rng(seed)
    coarse = rng.integers(0, 6, (shape[0] // 4 + 1, shape[1] // 4 + 1)).astype(np.float32)
    disp = np.kron(coarse, np.ones((4, 4), np.float32))[:shape[0], :shape[1]].copy()
    disp += rng.integers(0, 2, shape) * 3  # single pixels off their region
    disp[rng.random(shape) < 0.1] = np.nan
    return disp


@pytest.mark.parametrize("stripes", [False, True])
def test_speckle_masks_and_clearing_equal_the_unplanned_filter(stripes, monkeypatch):
    if stripes:  # maps this small in stripes, on every thread
        if runtime.max_threads() < 2:
            pytest.skip("one core: one stripe, a bound call")
        monkeypatch.setattr(runtime, "DIRECT_WORK", 1000)
    workspace = Workspace()
    for seed in range(3):
        disp = speckled(seed)
        expected = filters.speckle_mask(disp, 6, 1.0).copy()
        assert 0 < expected.sum() < np.isfinite(disp).sum()  # some regions, not all
        got = filters.speckle_mask(disp, 6, 1.0, workspace)
        np.testing.assert_array_equal(got, expected)
        cleared = disp.copy()
        got = filters.speckle_mask(cleared, 6, 1.0, workspace, clear=True)
        np.testing.assert_array_equal(got, expected)
        np.testing.assert_array_equal(cleared, np.where(expected, np.float32(np.nan), disp))
    assert bool(workspace._kept) != stripes  # a bound call for one stripe only


@pytest.mark.parametrize("invalid", [kernels.INVALID, kernels.NEG_INVALID])
@pytest.mark.parametrize("checked", [False, True])
def test_the_float_map_is_the_integer_map_with_nan_where_invalid(invalid, checked):
    rng = np.random.default_rng(5)
    disp = rng.integers(-1, 40, (33, 47)).astype(np.int32)
    disp[rng.random(disp.shape) < 0.2] = invalid
    lr_valid = rng.random(disp.shape) < 0.8
    got = filters.as_float(disp, lr_valid if checked else None, invalid)
    keep = (disp != invalid) & (lr_valid if checked else True)
    np.testing.assert_array_equal(got, np.where(keep, disp.astype(np.float32), np.nan))
    assert got.dtype == np.float32


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_the_padder_equals_edge_padding_of_the_image_and_of_it_reversed(dtype):
    from csw.kernels.contract import pad_edge
    from csw.kernels.pad import Padder

    rng = np.random.default_rng(7)
    for shape, h in (((9, 13), 4), ((1, 5), 2), ((6, 1), 0)):
        out = np.empty((shape[0] + 2 * h, shape[1] + 2 * h), dtype)
        padders = [Padder(shape, dtype, h, out, reverse=r) for r in (False, True)]
        for _ in range(2):
            image = rng.integers(0, np.iinfo(dtype).max + 1, shape, dtype=dtype)
            np.testing.assert_array_equal(padders[0](image), pad_edge(image, h, dtype))
            np.testing.assert_array_equal(padders[1](image),
                                          pad_edge(image[:, ::-1], h, dtype))
        wide = rng.integers(0, 200, (shape[0], 2 * shape[1]), dtype=dtype)
        view = wide[:, :shape[1]]  # a side-by-side frame's half: not contiguous
        np.testing.assert_array_equal(padders[0](view), pad_edge(view, h, dtype))


@pytest.mark.parametrize("fit", ["parabola", "linear"])
@pytest.mark.parametrize("threads", [1, pytest.param(2, marks=pytest.mark.two_cores)])
def test_the_subpixel_map_equals_the_oracle_in_every_stripe(fit, threads, monkeypatch):
    import oracle

    monkeypatch.setattr(runtime, "DIRECT_WORK", 0)  # the rows split between the threads
    rng = np.random.default_rng(11)
    shape = (37, 29)
    disp = rng.integers(0, 60, shape).astype(np.int32)
    best = rng.integers(0, 2000, shape)
    # Neighbours above, equal to (flat: no fit), below the best (a denominator <= 0) or
    # unknown (-1).
    prev = np.where(rng.random(shape) < 0.1, -1, best + rng.integers(-30, 400, shape))
    nxt = np.where(rng.random(shape) < 0.1, -1, best + rng.integers(-30, 400, shape))
    flat = rng.random(shape) < 0.1
    prev[flat], nxt[flat] = best[flat], best[flat]
    valid = rng.random(shape) < 0.8
    got = filters.subpixel(disp, best, prev, nxt, valid, fit, threads=threads)
    want = np.where(valid, oracle.subpixel(disp, best, prev, nxt, fit), np.nan)
    np.testing.assert_array_equal(got, want.astype(np.float32))
    moved = np.isfinite(got) & (got != disp)
    assert 0.3 < moved.mean() < 0.8  # the fit moved most pixels, not every one

"""Semi-global matching equals its brute-force oracle exactly (tests/oracle.py,
sgm_match), whatever the bands and threads, on every cost, window, path count and range."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from csw import kernels
from csw.kernels import native, sgm
from csw.kernels.jit.sgm import SC
from oracle import census, lr_consistent, sgm_match
from oracle import sgm_volume as oracle_volume

CENSUS = dict(census_window=3, census_pattern="dense")


def pair(rng, height, width, dtype=np.uint8, shift=2, noise=12):
    top = int(np.iinfo(dtype).max)
    left = rng.integers(0, top + 1, (height, width), dtype=np.int64)
    right = np.roll(left, -shift, axis=1) + rng.integers(-noise, noise + 1, left.shape)
    return left.astype(dtype), np.clip(right, 0, top).astype(dtype)


def assert_equals_oracle(left, right, band_bytes=None, threads=1, lr=1, starts=None,
                         slots=None, **kw):
    got = sgm.match_sgm(left, right, extras=True, right_map=True, lr_check=lr,
                        band_bytes=band_bytes, threads=threads, starts=starts, slots=slots,
                        **CENSUS, **kw)
    disp, mins, more = sgm_match(left, right, kw["window"], kw["dmin"], kw["dmax"],
                                 kw["cost"], kw["paths"], kw["p1"], kw["p2"], **CENSUS,
                                 starts=starts, band=slots)
    np.testing.assert_array_equal(got.disparity, disp)
    np.testing.assert_array_equal(got.min_cost, mins)
    for name in ("second_cost", "prev_cost", "next_cost", "right_disparity"):
        np.testing.assert_array_equal(getattr(got, name), more[name], err_msg=name)
    invalid = kernels.invalid(kw["dmin"])
    np.testing.assert_array_equal(got.lr_valid,
                                  lr_consistent(disp, more["right_disparity"], lr, invalid))
    return got


def one_row_bands(left, dmin, dmax, itemsize=3):
    """band_bytes that cut a band per row (slabs of costs and 16-bit sums)."""
    return left.shape[1] * (dmax - dmin + 1) * itemsize


@pytest.mark.parametrize("cost", ["sad", "ssd", "shd", "census"])
@pytest.mark.parametrize("window", [1, 3])
@pytest.mark.parametrize("paths", [4, 5, 8])
def test_every_cost_window_and_path_count(cost, window, paths):
    rng = np.random.default_rng(len(cost) * 10 + window + paths)
    left, right = pair(rng, 9, 14)
    p1, p2 = sgm.default_penalties(cost, window, 8)
    for dmin, dmax in [(0, 5), (-2, 4), (3, 7)]:
        assert_equals_oracle(left, right, window=window, dmin=dmin, dmax=dmax, cost=cost,
                             paths=paths, p1=p1, p2=p2)


@pytest.mark.parametrize("paths", [4, 5, 8])
@pytest.mark.parametrize("threads", [1, pytest.param(2, marks=pytest.mark.two_cores)])
def test_bands_and_threads_change_nothing(paths, threads, monkeypatch):
    """Bands of one, two and all rows, one thread or two: the same sums, bit for bit.
    Every step is split between the threads, however small (sgm.STEP_DIRECT_WORK): two
    split the costs' columns, each making its columns' path down with them (fused);
    one thread makes the vertical paths within the costs and winners steps; bands of
    odd and even heights."""
    monkeypatch.setattr(sgm, "STEP_DIRECT_WORK", 0)
    rng = np.random.default_rng(paths + threads)
    left, right = pair(rng, 11, 16)
    row = one_row_bands(left, 0, 6)
    for window in (1, 3):  # two threads split the costs' columns: with and without sums
        kw = dict(window=window, dmin=0, dmax=6, cost="sad", paths=paths, p1=40, p2=300)
        for band_bytes in (row, 2 * row + 1, 5 * row, None):
            assert_equals_oracle(left, right, band_bytes=band_bytes, threads=threads, **kw)


@pytest.mark.parametrize("cost,window", [("sad", 3), ("census", 1), ("ssd", 1), ("shd", 3)])
@pytest.mark.parametrize("paths", [4, 5, 8])
@pytest.mark.parametrize("threads", [1, pytest.param(2, marks=pytest.mark.two_cores)])
def test_ranges_padded_to_whole_vectors_change_nothing(cost, window, paths, threads,
                                                       monkeypatch):
    """Ranges of 22 to 27 disparities run their d axes to 32 (sgm.padded_depth): the
    slots past the range, at P1 < P2, P1 = P2 and P1 = 0, from a negative dmin too, in
    bands of one row and whole, on one thread or two, change no map."""
    monkeypatch.setattr(sgm, "STEP_DIRECT_WORK", 0)
    depths = []
    padded_depth = sgm.padded_depth
    monkeypatch.setattr(sgm, "padded_depth", lambda ndisp, *rest: depths.append(
        (ndisp, padded_depth(ndisp, *rest))) or depths[-1][1])
    rng = np.random.default_rng(len(cost) + 10 * window + paths + threads)
    left, right = pair(rng, 7, 40, shift=11, noise=30)
    p1, p2 = sgm.default_penalties(cost, window, 8)
    for dmin, dmax, (a, b) in [(0, 21, (p1, p2)), (-5, 21, (p2, p2)), (3, 29, (0, p2))]:
        for band_bytes in (one_row_bands(left, dmin, dmax, 8), None):
            assert_equals_oracle(left, right, window=window, dmin=dmin, dmax=dmax,
                                 cost=cost, paths=paths, p1=a, p2=b,
                                 band_bytes=band_bytes, threads=threads)
    assert depths and all(depth == 32 for _, depth in depths), depths


@pytest.mark.two_cores
@pytest.mark.parametrize("narrowed", [False, True])
def test_two_threads_cut_a_band_into_halves_fusing_every_vertical_step(narrowed,
                                                                       monkeypatch):
    """4 paths on two threads: the top half's costs go down and the bottom half's up
    (each thread a block of columns of both), then the winners the other way, a thread
    a half, each with its vertical path (sgm.py, halves), and no vertical path runs as a
    step of its own; the oracle's sums, bands of odd and even heights, every cost
    window."""
    monkeypatch.setattr(sgm, "STEP_DIRECT_WORK", 0)
    steps = []
    call = native.Bound.__call__

    def spy(bound):
        if bound.entry.key.startswith("sgm"):
            sc = bound.scalars
            steps.append((sc[SC.step], sc[SC.direction], sc[SC.fused]))
        return call(bound)

    monkeypatch.setattr(native.Bound, "__call__", spy)
    rng = np.random.default_rng(60 + narrowed)
    for height in (9, 12):
        left, right = pair(rng, height, 17)
        narrow = dict(starts=random_starts(rng, left.shape, 10, 4), slots=4) \
            if narrowed else {}
        for window, cost in ((1, "census"), (3, "sad"), (5, "shd")):
            kw = dict(window=window, dmin=0, dmax=9, cost=cost, paths=4, p1=40, p2=300)
            steps.clear()
            assert_equals_oracle(left, right, threads=2, **kw, **narrow)
            assert sorted(set(steps)) == [(sgm.COSTS, -1, 0), (sgm.COSTS, 1, 0),
                                          (sgm.SELECT, 1, 1), (sgm.SELECT, 1, 2)], steps
            assert len(steps) == 6  # a block of columns of each half, a half's winners
            for band_bytes in (one_row_bands(left, 0, 9) * 2 + 1,
                               one_row_bands(left, 0, 9) * 5):
                assert_equals_oracle(left, right, threads=2, band_bytes=band_bytes, **kw,
                                     **narrow)


@pytest.mark.two_cores
def test_a_taller_bottom_band_changes_nothing(monkeypatch):
    """The bottom band, made once, may be taller than the others (sgm.LAST_BAND_BYTES):
    bands of 2 rows above one of 6, the same sums as one band."""
    monkeypatch.setattr(sgm, "MIN_BAND_ROWS", 2)
    rng = np.random.default_rng(7)
    left, right = pair(rng, 13, 16)
    kw = dict(window=3, dmin=0, dmax=6, cost="sad", paths=4, p1=40, p2=300)
    row = one_row_bands(left, 0, 6, itemsize=4)
    monkeypatch.setattr(sgm, "LAST_BAND_BYTES", 6 * row)
    bands, rows = sgm.band_plan(13, 16, 7, 4, 0.5, 8 * row)
    assert bands == [(0, 2), (2, 4), (4, 6), (6, 7), (7, 13)] and rows == 6
    for threads in (1, 2):
        assert_equals_oracle(left, right, band_bytes=8 * row, threads=threads, **kw)


def random_starts(rng, shape, ndisp, slots):
    """Per-pixel starts in blobs, as a half-size pass makes them, with jumps between."""
    coarse = rng.integers(0, ndisp - slots + 1, ((shape[0] + 2) // 3, (shape[1] + 2) // 3))
    starts = np.kron(coarse, np.ones((3, 3), np.int64))[:shape[0], :shape[1]]
    jitter = rng.integers(-1, 2, shape)
    return np.clip(starts + jitter, 0, ndisp - slots).astype(np.int32)


@pytest.mark.parametrize("cost", ["sad", "census"])
@pytest.mark.parametrize("window", [1, 3])
@pytest.mark.parametrize("paths", [4, 5, 8])
def test_narrowed_search_every_cost_window_and_path_count(cost, window, paths):
    """Each pixel its own slots: the kernels meet the oracle's shifted paths."""
    rng = np.random.default_rng(len(cost) * 10 + window + paths + 1)
    left, right = pair(rng, 10, 16)
    p1, p2 = sgm.default_penalties(cost, window, 8)
    for dmin, dmax, slots in [(0, 9, 3), (-3, 5, 4), (2, 11, 1), (0, 6, 7)]:
        starts = random_starts(rng, left.shape, dmax - dmin + 1, slots)
        assert_equals_oracle(left, right, window=window, dmin=dmin, dmax=dmax, cost=cost,
                             paths=paths, p1=p1, p2=p2, starts=starts, slots=slots)


@pytest.mark.parametrize("cost", ["shd", "census"])
@pytest.mark.parametrize("paths", [4, 8])
@pytest.mark.parametrize("threads", [1, pytest.param(2, marks=pytest.mark.two_cores)])
def test_hamming_costs_above_a_byte_are_truncated(cost, paths, threads, monkeypatch):
    """A 7x7 window of 8-bit codes costs up to 392: costs above 255 are truncated to 255
    and the slab holds bytes, in the whole search and the narrowed one.  The right image
    is the left one inverted, so that many costs are above 255."""
    monkeypatch.setattr(sgm, "STEP_DIRECT_WORK", 0)
    rng = np.random.default_rng(7 + paths + threads)
    left, right = pair(rng, 12, 18, noise=0)
    right = 255 - right
    p1, p2 = sgm.default_penalties(cost, 7, 8)
    kw = dict(window=7, cost=cost, paths=paths, p1=p1, p2=p2, threads=threads)
    volume = oracle_volume(left, right, 7, 0, 5, cost, **CENSUS)
    assert volume.max() == 255 and (volume == 255).mean() > 0.2  # truncation exercised
    assert_equals_oracle(left, right, dmin=0, dmax=5, **kw)
    starts = random_starts(rng, left.shape, 8, 3)
    assert_equals_oracle(left, right, dmin=0, dmax=7, starts=starts, slots=3, **kw)


@pytest.mark.parametrize("paths", [4, 8])
@pytest.mark.parametrize("threads", [1, pytest.param(2, marks=pytest.mark.two_cores)])
def test_narrowed_search_bands_and_threads_change_nothing(threads, paths, monkeypatch):
    monkeypatch.setattr(sgm, "STEP_DIRECT_WORK", 0)
    rng = np.random.default_rng(threads + 40)
    left, right = pair(rng, 11, 16)
    starts = random_starts(rng, left.shape, 10, 4)
    row = one_row_bands(left, 0, 3)
    for window in (1, 3):
        kw = dict(window=window, dmin=0, dmax=9, cost="sad", paths=paths, p1=40, p2=300,
                  starts=starts, slots=4)
        for band_bytes in (row, 2 * row + 1, 5 * row, None):
            assert_equals_oracle(left, right, band_bytes=band_bytes, threads=threads, **kw)


@pytest.mark.two_cores
@pytest.mark.parametrize("window", [3, 5])
def test_narrowed_costs_in_tiles_of_rows_change_nothing(monkeypatch, window):
    """A narrowed search sums each column over the slots its pixels search in a tile of
    rows (sgm.TILE_ROWS): tiles of 1, 2 and 5 rows, and one tile, on every cost, bands
    and threads, all meet the oracle."""
    monkeypatch.setattr(sgm, "STEP_DIRECT_WORK", 0)
    rng = np.random.default_rng(window + 50)
    left, right = pair(rng, 13, 19)
    for tile in (1, 2, 5, 16):
        monkeypatch.setattr(sgm, "TILE_ROWS", tile)
        for cost, dmin, dmax, slots, threads in [("census", 0, 11, 4, 1), ("sad", -3, 8, 5, 2),
                                                 ("ssd", 2, 13, 3, 1), ("shd", 0, 9, 6, 2)]:
            starts = random_starts(rng, left.shape, dmax - dmin + 1, slots)
            p1, p2 = sgm.default_penalties(cost, window, 8)
            assert_equals_oracle(left, right, window=window, dmin=dmin, dmax=dmax, cost=cost,
                                 paths=4, p1=p1, p2=p2, starts=starts, slots=slots,
                                 threads=threads,
                                 band_bytes=one_row_bands(left, 0, slots) * 3 + 1)


def test_narrowed_search_of_every_slot_is_the_whole_search():
    rng = np.random.default_rng(3)
    left, right = pair(rng, 8, 13)
    kw = dict(window=3, dmin=-1, dmax=6, cost="census", paths=8, p1=5, p2=40,
              lr_check=1, extras=True, right_map=True, **CENSUS)
    whole = sgm.match_sgm(left, right, **kw)
    narrowed = sgm.match_sgm(left, right, starts=np.zeros(left.shape, np.int32), slots=8,
                             **kw)
    for name in ("disparity", "min_cost", "second_cost", "right_disparity", "lr_valid"):
        np.testing.assert_array_equal(getattr(narrowed, name), getattr(whole, name))


def test_sixteen_bit_pixels_take_32_bit_sums():
    rng = np.random.default_rng(5)
    left, right = pair(rng, 8, 12, np.uint16, noise=3000)
    p1, p2 = sgm.default_penalties("sad", 3, pixels=np.uint16)
    cmax = 65535 * 9
    assert sgm.accumulator(cmax, p1, p2, 4) == np.uint32
    assert_equals_oracle(left, right, window=3, dmin=0, dmax=5, cost="sad", paths=4,
                         p1=p1, p2=p2, band_bytes=one_row_bands(left, 0, 5, 8))


@settings(deadline=None, max_examples=20)
@given(seed=st.integers(0, 2**31), height=st.integers(1, 7), width=st.integers(3, 12),
       span=st.integers(0, 5), dmin=st.integers(-3, 3), p1=st.integers(0, 30),
       extra=st.integers(0, 200), paths=st.sampled_from([4, 5, 8]),
       rows_per_band=st.integers(1, 8))
def test_random_shapes_ranges_and_penalties(seed, height, width, span, dmin, p1, extra,
                                            paths, rows_per_band):
    rng = np.random.default_rng(seed)
    left, right = pair(rng, height, width, noise=40)
    dmin = min(max(dmin, -(width - 1)), width - 1)
    dmax = min(dmin + span, width - 1)
    assert_equals_oracle(left, right, window=1, dmin=dmin, dmax=dmax, cost="sad",
                         paths=paths, p1=p1, p2=p1 + extra,
                         band_bytes=rows_per_band * one_row_bands(left, dmin, dmax))


@pytest.mark.parametrize("cost,window", [("sad", 3), ("census", 1), ("ssd", 1)])
def test_no_penalty_is_local_matching(cost, window):
    """With P1 = P2 = 0 every path is the cost itself: the local matcher's map, and its
    costs times the paths."""
    rng = np.random.default_rng(3)
    left, right = pair(rng, 10, 15)
    for paths in (4, 5, 8):
        got = sgm.match_sgm(left, right, window=window, dmin=0, dmax=6, cost=cost,
                            paths=paths, p1=0, p2=0, **CENSUS)
        local = kernels.match(left, right, engine="fast", window=window, dmin=0, dmax=6,
                              cost=cost, **CENSUS)
        np.testing.assert_array_equal(got.disparity, local.disparity)
        np.testing.assert_array_equal(got.min_cost,
                                      np.where(local.min_cost >= 0, paths * local.min_cost,
                                               -1))


def test_census_codes_are_the_oracles():
    """The census cost compares the codes the oracle computes (a sparse pattern too)."""
    rng = np.random.default_rng(8)
    left, right = pair(rng, 9, 12)
    kw = dict(window=1, dmin=0, dmax=4, cost="census", paths=4, p1=3, p2=10)
    got = sgm.match_sgm(left, right, census_window=5, census_pattern="sparse", **kw)
    disp, mins, _ = sgm_match(left, right, 1, 0, 4, "census", 4, 3, 10, 5, "sparse")
    np.testing.assert_array_equal(got.disparity, disp)
    np.testing.assert_array_equal(got.min_cost, mins)
    assert census(left, 5, "sparse").dtype == object  # the oracle's own transform


def test_real_pair_crop(data_dir):
    """A crop of Tsukuba, census 5x5 over a 3x3 window: the oracle's map."""
    from csw.data import datasets

    loaded = datasets.load("tsukuba", data_dir)
    gray = loaded.left if loaded.left.ndim == 2 else loaded.left.mean(axis=2)
    left = np.ascontiguousarray(gray[100:118, 120:150]).astype(np.uint8)
    gray_r = loaded.right if loaded.right.ndim == 2 else loaded.right.mean(axis=2)
    right = np.ascontiguousarray(gray_r[100:118, 120:150]).astype(np.uint8)
    got = assert_equals_oracle(left, right, window=3, dmin=0, dmax=12, cost="census",
                               paths=4, p1=18, p2=72,
                               band_bytes=one_row_bands(left, 0, 12) * 4)
    assert (got.disparity >= 0).mean() > 0.5


@pytest.mark.parametrize("bad,message", [
    (dict(paths=6), "paths must be one of 4, 5, 8"),
    (dict(p1=10, p2=5), "must not exceed P2"),
    (dict(p1=-1), "P1 must be a whole number"),
    (dict(csw=True), "no CSW"),
    (dict(rows=[3, 1]), "strictly increasing"),
])
def test_bad_options_are_refused(bad, message):
    left = np.zeros((6, 10), np.uint8)
    kw = dict(window=1, dmin=0, dmax=3, cost="sad", paths=4, p1=1, p2=2)
    with pytest.raises(ValueError, match=message):
        sgm.match_sgm(left, left, **{**kw, **bad})


def test_sums_that_would_pass_32_bits_are_refused():
    with pytest.raises(ValueError, match="exceed 32 bits"):
        sgm.accumulator(65535 * 65535 * 81, 1, 2, 8)


@pytest.mark.parametrize("narrowed", [False, True])
def test_without_the_second_best_every_other_map_equals_the_oracle(narrowed):
    """second=False (no stage reads the second best): the second best is not made, and
    the winners, their neighbours' totals, the right map and the check are the oracle's,
    including at the left edge where a pixel has no candidate."""
    rng = np.random.default_rng(8)
    left, right = pair(rng, 11, 17)
    p1, p2 = sgm.default_penalties("census", 3, 8)
    dmin, dmax = -1, 8
    starts, slots = None, None
    if narrowed:
        slots = 6
        starts = rng.integers(0, dmax - dmin + 2 - slots, left.shape).astype(np.int32)
    kw = dict(window=3, dmin=dmin, dmax=dmax, cost="census", paths=4, p1=p1, p2=p2)
    got = sgm.match_sgm(left, right, extras=True, right_map=True, lr_check=1, second=False,
                        starts=starts, slots=slots, **CENSUS, **kw)
    disp, mins, more = sgm_match(left, right, 3, dmin, dmax, "census", 4, p1, p2, **CENSUS,
                                 starts=starts, band=slots)
    assert got.second_cost is None
    np.testing.assert_array_equal(got.disparity, disp)
    np.testing.assert_array_equal(got.min_cost, mins)
    for name in ("prev_cost", "next_cost", "right_disparity"):
        np.testing.assert_array_equal(getattr(got, name), more[name], err_msg=name)
    assert (more["second_cost"] >= 0).any() and (got.prev_cost >= 0).any()

"""The thread's workspace: buffers kept between matches, never shared between threads,
never kept past the limit, and never changing a result."""

import threading

import numpy as np
import pytest

import csw
from csw import kernels
from csw.config import params
from csw.kernels.workspace import Workspace, for_this_thread
from csw.matching import pipeline


def test_a_role_reuses_its_buffer_and_grows_it():
    ws = Workspace(limit=1 << 20)
    a = ws.empty("codes", (10, 20), np.uint64)
    b = ws.empty("codes", (5, 4), np.int32)
    assert a.shape == (10, 20) and b.shape == (5, 4) and b.dtype == np.int32
    assert np.shares_memory(a, b)
    assert not np.shares_memory(a, ws.empty("mask", (10, 20), np.uint8))
    c = ws.empty("codes", (30, 30), np.uint64)  # larger: a new buffer replaces the old
    assert c.shape == (30, 30) and not np.shares_memory(a, c)
    assert ws.held() == 30 * 30 * 8 + 10 * 20


def test_past_the_limit_arrays_are_fresh_and_not_kept():
    ws = Workspace(limit=1000)
    kept = ws.empty("small", (100,), np.uint8)
    big = ws.empty("big", (200,), np.uint64)  # 1600 bytes: over the limit
    assert big.shape == (200,) and ws.held() == 100
    again = ws.empty("big", (200,), np.uint64)
    assert not np.shares_memory(big, again)
    assert np.shares_memory(kept, ws.empty("small", (50,), np.uint8))
    ws.release()
    assert ws.held() == 0
    assert not np.shares_memory(kept, ws.empty("small", (50,), np.uint8))


def test_each_thread_has_its_own_workspace():
    mine = for_this_thread()
    assert for_this_thread() is mine
    theirs = []
    thread = threading.Thread(target=lambda: theirs.append(for_this_thread()))
    thread.start()
    thread.join()
    assert theirs[0] is not mine


@pytest.mark.parametrize("cost", ["census", "sad"])
def test_matches_through_the_workspace_equal_fresh_ones(small_scene, cost):
    left, right = small_scene[:2]
    census = dict(census_window=5, census_pattern="dense")
    fresh = kernels.match(left, right, engine="fast", window=5, dmin=0, dmax=12,
                          cost=cost, right_map=True, **census)
    ws = Workspace()
    for pair in [(left, right), (right, left), (left, right)]:  # later runs reuse buffers
        got = kernels.match(*pair, engine="fast", window=5, dmin=0, dmax=12, cost=cost,
                            right_map=True, workspace=ws, **census)
    np.testing.assert_array_equal(got.disparity, fresh.disparity)
    np.testing.assert_array_equal(got.right_disparity, fresh.right_disparity)
    np.testing.assert_array_equal(got.min_cost, fresh.min_cost)
    for name in ("disparity", "min_cost", "right_disparity"):  # results own their maps
        array = getattr(got, name)
        assert not any(np.shares_memory(array, buffer) for buffer in ws._held.values())
    # The padded images or census codes, kept: in a bound call (kernels/fast.py) at this size.
    assert ws.held() > 0 or ws._kept


def test_a_caller_lends_the_outputs_it_wants_written_in_place(small_scene):
    """``into``: the disparity and the check go into the caller's own arrays."""
    left, right = small_scene[:2]
    mine = {"disparity": np.empty(left.shape, np.int32),
            "lr_valid": np.empty(left.shape, np.uint8)}
    for engine in ("fast", "window"):
        got = kernels.match(left, right, engine=engine, window=5, dmin=0, dmax=12,
                            cost="sad", lr_check=1, into=mine)
        fresh = kernels.match(left, right, engine=engine, window=5, dmin=0, dmax=12,
                              cost="sad", lr_check=1)
        assert np.shares_memory(got.disparity, mine["disparity"])
        assert np.shares_memory(got.lr_valid, mine["lr_valid"])
        np.testing.assert_array_equal(got.disparity, fresh.disparity)
        np.testing.assert_array_equal(got.lr_valid, fresh.lr_valid)
    with pytest.raises(ValueError, match="disparity output must be"):
        kernels.match(left, right, engine="fast", window=5, dmin=0, dmax=12, cost="sad",
                      into={"disparity": np.empty((2, 2), np.int32)})


def test_slabs_are_kept_beside_the_limit_up_to_their_own_largest(monkeypatch):
    from csw.kernels import workspace

    monkeypatch.setattr(workspace, "SLAB_LARGEST", 4000)
    ws = Workspace(limit=1000, largest=100)
    costs = ws.slab("sgm-costs", (10, 20, 10), np.uint16)  # 4000 bytes: kept
    assert ws.held() == 0  # outside the limit of the other buffers
    assert np.shares_memory(costs, ws.slab("sgm-costs", (5, 5, 5), np.uint8))
    assert not np.shares_memory(costs, ws.slab("sgm-sums", (10, 20, 10), np.uint16))
    big = ws.slab("sgm-costs", (2001,), np.uint16)  # over the largest: fresh, and the
    assert not np.shares_memory(big, ws.slab("sgm-costs", (2001,), np.uint16))  # old
    assert "sgm-costs" not in ws._slabs  # buffer dropped
    sums = ws.slab("sgm-sums", (10,), np.uint8)
    ws.release()
    assert not np.shares_memory(sums, ws.slab("sgm-sums", (10,), np.uint8))


def test_semi_global_matches_reuse_their_slabs_and_equal_fresh_ones(small_scene):
    """The sgm preset narrowed (its half-size pass too) through the thread's workspace,
    on pairs of other sizes in turn, equals runs that keep nothing."""
    left, right = small_scene[:2]
    ws = for_this_thread()
    ws.release()
    options = dict(preset="sgm", dmax=24, sgm_narrow=8)
    pairs = [(left, right), (right[:40, :50], left[:40, :50]), (left, right)]
    for pair in pairs:
        got = csw.match(*pair, want_confidence=True, **options)
        opts = params.resolve(**options)
        want, confidence, _ = pipeline.run(*pair, opts.kernel_args(), opts.stages,
                                           confidence=True)
        np.testing.assert_array_equal(got.disparity, want)
        np.testing.assert_array_equal(got.confidence, confidence)
        assert {"sgm-costs", "sgm-sums"} <= set(ws._slabs)
        assert not any(np.shares_memory(got.disparity, b) for b in ws._slabs.values())


@pytest.mark.parametrize("preset", ["accurate", "raw", "sgm"])
def test_results_of_csw_match_survive_the_next_match(small_scene, preset):
    """What csw.match returns is the caller's: a later match on the same thread, of
    another size, leaves it as it was."""
    left, right = small_scene[:2]
    first = csw.match(left, right, dmax=12, preset=preset, want_confidence=True)
    kept = first.disparity.copy(), first.min_cost.copy(), first.confidence.copy()
    assert kept[2].max() > 0
    csw.match(left[:40, :50], right[:40, :50], dmax=8, preset=preset)
    csw.match(right, left, dmax=12, preset=preset, want_confidence=True)
    np.testing.assert_array_equal(first.disparity, kept[0])
    np.testing.assert_array_equal(first.min_cost, kept[1])
    np.testing.assert_array_equal(first.confidence, kept[2])


def test_a_confidence_not_computed_is_a_read_only_map_of_zeros(small_scene):
    left, right = small_scene[:2]
    result = csw.match(left, right, dmax=12, preset="raw")
    assert result.confidence.shape == result.shape
    assert result.confidence.dtype == np.float32 and not result.confidence.any()
    with pytest.raises(ValueError, match="read-only"):
        result.confidence[0, 0] = 1


def test_a_buffer_over_the_largest_is_never_kept():
    ws = Workspace(limit=1 << 20, largest=1000)
    big = ws.empty("codes", (200,), np.uint64)  # 1600 bytes: larger than any kept
    assert ws.held() == 0
    assert not np.shares_memory(big, ws.empty("codes", (200,), np.uint64))
    assert ws.held() == 0 and ws.empty("codes", (100,), np.uint64).nbytes == 800
    assert ws.held() == 800


def test_csw_match_uses_its_threads_workspace_and_bare_pipeline_runs_do_not(small_scene):
    """Whole-image matches reuse the thread's buffers; a pipeline run without a
    workspace (the tiled bands, whose memory is planned) keeps nothing."""
    left, right = small_scene[:2]
    ws = for_this_thread()
    ws._held.clear()
    opts = params.resolve(dmax=12)
    pipeline.run(left, right, opts.kernel_args(), opts.stages)
    assert ws.held() == 0
    csw.match(left, right, dmax=12)
    assert ws.held() > 0  # the census codes, the right map, the masks


def test_one_pair_written_to_files_keeps_nothing(pair_files, tmp_path):
    """csw.match_files writes its outputs right after the match: scratch kept for a next
    match would only raise that stage's peak memory."""
    left, right = pair_files[:2]
    csw.match(str(left), str(right), dmax=12)
    assert for_this_thread().held() > 0
    csw.match_files(str(left), str(right), str(tmp_path / "d.pfm"), dmax=12)
    assert for_this_thread().held() == 0
    assert (tmp_path / "d.pfm").stat().st_size > 0

"""Known answers and CSW invariants for every engine."""

import numpy as np
import pytest

from csw import kernels
from csw.data.synth import render
from oracle import oracle_match

ENGINES = list(kernels.ENGINE_NAMES)


@pytest.fixture(scope="module")
def scene():
    return render(160, 96, dmax=24, seed=3)


@pytest.mark.parametrize("engine", ENGINES)
def test_synthetic_disparity_recovered_in_textured_unoccluded_parts(engine, scene):
    left, right, gt, nonocc = scene
    result = kernels.match(left, right, engine=engine, window=9, dmin=0, dmax=24, cost="sad")
    # Pixels whose whole 9x9 window is non-occluded, on a fronto-parallel (integer-d)
    # layer of one disparity, and away from the image border.
    integer = np.isclose(gt, np.round(gt))
    good = nonocc & integer
    for axis in (0, 1):
        for shift in range(-4, 5):
            good &= np.roll(nonocc & integer, shift, axis=axis)
            good &= np.roll(np.round(gt), shift, axis=axis) == np.round(gt)
    good[:4], good[-4:], good[:, :28], good[:, -4:] = False, False, False, False
    assert good.sum() > 1000  # the test must look at a real share of the image
    np.testing.assert_array_equal(result.disparity[good], np.round(gt[good]).astype(np.int32))


@pytest.mark.parametrize("engine", ENGINES)
def test_small_case_worked_by_hand(engine):
    # One row, window 1, SAD. left = [5, 9, 2, 7], right = [9, 2, 7, 0], d in 0..2.
    # x=0: d=0 only: |5-9| = 4 -> D=0, m=4.
    # x=1: d=0 |9-2|=7, d=1 |9-9|=0 -> D=1, m=0.
    # x=2: d=0 |2-7|=5, d=1 |2-2|=0, d=2 |2-9|=7 -> D=1, m=0.
    # x=3: d=0 |7-0|=7, d=1 |7-7|=0, d=2 |7-2|=5 -> D=1, m=0.
    left = np.array([[5, 9, 2, 7]], np.uint8)
    right = np.array([[9, 2, 7, 0]], np.uint8)
    plain = kernels.match(left, right, engine=engine, window=1, dmin=0, dmax=2, cost="sad")
    assert plain.disparity.tolist() == [[0, 1, 1, 1]]
    assert plain.min_cost.tolist() == [[4, 0, 0, 0]]
    assert plain.evaluated == 1 + 2 + 3 + 3
    # With CSW and tau = 0: x=0 (m=4) claims nothing; x=1 (m=0) claims right 0.
    # x=2: d=2 is right 0, claimed, so skipped; D=1 claims right 1.
    # x=3: d=2 is right 1, claimed, so skipped; D=1 (right 2) as before.
    csw = kernels.match(left, right, engine=engine, window=1, dmin=0, dmax=2, cost="sad",
                        csw=True, tau=0)
    assert csw.disparity.tolist() == [[0, 1, 1, 1]]
    assert csw.evaluated == 1 + 2 + 2 + 2


@pytest.mark.parametrize("engine", ENGINES)
def test_csw_never_chooses_a_blocked_candidate(engine, scene):
    left, right, _, _ = scene
    result = kernels.match(left, right, engine=engine, window=5, dmin=0, dmax=24, cost="sad",
                           csw=True, tau=900)
    for y in range(left.shape[0]):
        claimed_by = {}
        for x in range(left.shape[1]):
            d, m = result.disparity[y, x], result.min_cost[y, x]
            if d < 0:
                continue
            assert x - d not in claimed_by, (y, x, d)
            if m <= 900:
                claimed_by[x - d] = x


@pytest.mark.parametrize("engine", ENGINES)
def test_negative_tau_is_plain_matching(engine, scene):
    left, right, _, _ = scene
    plain = kernels.match(left, right, engine=engine, window=7, dmax=20, cost="ssd", dmin=0)
    csw = kernels.match(left, right, engine=engine, window=7, dmax=20, cost="ssd", csw=True,
                        tau=-0.5, dmin=0)
    np.testing.assert_array_equal(plain.disparity, csw.disparity)
    np.testing.assert_array_equal(plain.min_cost, csw.min_cost)
    assert plain.evaluated == csw.evaluated == plain.candidates


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_evaluated_count_equals_oracle_on_scene_rows(engine, scene):
    left, right, _, _ = scene
    rows = np.arange(10, 96, 17)
    got = kernels.match(left, right, engine=engine, window=3, dmax=24, csw=True, tau=200,
                        rows=rows, dmin=0, cost="sad")
    disp, mins, evaluated = oracle_match(left, right, 3, 0, 24, "sad", True, 200, rows=rows)
    np.testing.assert_array_equal(got.disparity, disp)
    assert got.evaluated == evaluated
    assert 0 < got.work_saved < 1


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.two_cores
@pytest.mark.parametrize("rule", ["literal", "unique"])
def test_result_does_not_depend_on_thread_count(engine, rule, scene):
    left, right, _, _ = scene
    runs = [kernels.match(left, right, engine=engine, dmax=24, csw=True, tau=1500, rule=rule,
                          csw_margin=12, threads=t, window=9, dmin=0, cost="sad") for t in (1, 2)]
    np.testing.assert_array_equal(runs[0].disparity, runs[1].disparity)
    np.testing.assert_array_equal(runs[0].min_cost, runs[1].min_cost)
    assert runs[0].evaluated == runs[1].evaluated


@pytest.mark.parametrize("bad, message", [
    (dict(window=4), "odd"),
    (dict(window=0), "odd"),
    (dict(window=99), "larger than the image"),
    (dict(dmin=5, dmax=2), "must not exceed"),
    (dict(dmin=-40), "minus the image width"),
    (dict(dmax=40), "less than the image width"),
    (dict(cost="ncc"), "cost must be one of"),
    (dict(threads=0), "threads"),
])
def test_entry_rejects_bad_parameters_with_a_fix(bad, message):
    img = np.zeros((20, 40), np.uint8)
    with pytest.raises(ValueError, match=message):
        kernels.match(img, img, **dict(dict(engine="window", window=3, dmin=0, dmax=8, cost="sad"),
                                        **bad))


def test_entry_rejects_bad_images():
    with pytest.raises(ValueError, match="astype"):
        kernels.match(np.zeros((5, 5), np.float32), np.zeros((5, 5), np.float32), window=1,
                      dmax=1, engine="window", dmin=0, cost="sad")
    with pytest.raises(ValueError, match="differ in size"):
        kernels.match(np.zeros((5, 5), np.uint8), np.zeros((5, 6), np.uint8), engine="window",
                      window=1, dmin=0, dmax=1, cost="sad")
    with pytest.raises(ValueError, match="2-D"):
        kernels.match(np.zeros((5, 5, 3), np.uint8), np.zeros((5, 5, 3), np.uint8), window=1,
                      dmax=1, engine="window", dmin=0, cost="sad")


def test_unknown_engine_is_rejected():
    img = np.zeros((5, 5), np.uint8)
    with pytest.raises(ValueError, match="engine must be one of"):
        kernels.match(img, img, engine="gpu", window=1, dmax=1, dmin=0, cost="sad")

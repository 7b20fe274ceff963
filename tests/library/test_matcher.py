"""csw.Matcher: made once, called per pair; the same results as csw.match, bit for bit,
on every preset; options checked and kernels loaded at construction."""

import numpy as np
import pytest

import csw
from csw.kernels import native


def same(a, b):
    np.testing.assert_array_equal(a.disparity, b.disparity)
    np.testing.assert_array_equal(a.confidence, b.confidence)
    np.testing.assert_array_equal(a.min_cost, b.min_cost)
    assert (a.evaluated, a.candidates) == (b.evaluated, b.candidates)
    assert {k: v for k, v in a.settings.items()} == b.settings


@pytest.mark.parametrize("options", [
    {}, {"preset": "raw"}, {"preset": "paper"}, {"preset": "raw", "csw": True},
    {"preset": "raw", "csw": True, "csw_rule": "unique"},
    {"subpixel": "parabola", "median": 3, "fill": "background"},
    {"preset": "raw", "cost": "census", "lr_check": 1, "uniqueness_ratio": 10},
], ids=str)
def test_a_matcher_equals_csw_match_on_every_preset(small_scene, options):
    left, right = small_scene[:2]
    matcher = csw.Matcher(dmax=16, **options)
    for want in (False, True):
        once = csw.match(left, right, dmax=16, want_confidence=want, **options)
        for _ in range(2):  # and again: nothing of a pair stays in the matcher
            same(matcher.match(left, right, want_confidence=want), once)


def test_a_matcher_takes_16_bit_pairs_and_paths(small_scene, pair_files):
    left, right = small_scene[:2]
    matcher = csw.Matcher(dmax=16)
    wide = matcher.match(left.astype(np.uint16) * 257, right.astype(np.uint16) * 257)
    same(wide, csw.match(left.astype(np.uint16) * 257, right.astype(np.uint16) * 257,
                         dmax=16))
    same(matcher.match(*pair_files), csw.match(*pair_files, dmax=16))


def test_bad_options_fail_at_construction():
    with pytest.raises(ValueError, match="window"):
        csw.Matcher(window=4)
    with pytest.raises(TypeError, match="unknown option"):
        csw.Matcher(windw=5)


def test_kernels_are_loaded_at_construction(monkeypatch):
    loaded = []
    real = native.ensure
    monkeypatch.setattr(native, "ensure", lambda wanted, *a, **k: (loaded.extend(wanted),
                                                                   real(wanted, *a, **k))[1])
    csw.Matcher(dmax=16, preset="raw", cost="ssd")
    assert any(kernel == "fast" and variant[0] == "ssd" for kernel, variant in loaded)


def test_an_auto_range_is_found_on_the_first_pair_and_kept():
    left, right, gt, _ = csw.synthetic_pair(320, 200, dmax=40, seed=2)
    matcher = csw.Matcher(dmax="auto")
    first = matcher.match(left, right)
    assert first.settings["range_source"] == "auto"
    second = matcher.match(left[:, ::-1].copy(), right[:, ::-1].copy())  # another scene
    assert (second.settings["dmin"], second.settings["dmax"]) == \
        (first.settings["dmin"], first.settings["dmax"])
    assert second.settings["range_source"] == "auto (from the first pair)"


def test_keep_range_false_finds_each_pairs_own_range():
    shallow = csw.synthetic_pair(320, 200, dmax=12, seed=2)[:2]
    deep = csw.synthetic_pair(320, 200, dmax=48, seed=3)[:2]
    matcher = csw.Matcher(dmax="auto", keep_range=False)
    results = [matcher.match(*shallow), matcher.match(*deep)]
    streamed = list(matcher.stream([shallow, deep, shallow]))
    for result, pair in zip(results + streamed, [shallow, deep, shallow, deep, shallow],
                            strict=True):
        alone = csw.match(*pair, dmax="auto")
        assert result.settings["range_source"] == "auto"
        assert (result.settings["dmin"], result.settings["dmax"]) == \
            (alone.settings["dmin"], alone.settings["dmax"])
        assert np.array_equal(result.disparity, alone.disparity, equal_nan=True)
    assert results[1].settings["dmax"] > results[0].settings["dmax"] + 20
    with pytest.raises(TypeError, match="keep_range"):
        csw.Matcher(keep_range="no")


def test_a_matcher_keeps_a_bounded_number_of_set_ups(monkeypatch):
    """A batch's one Matcher sees pairs of many sizes (or calibrations): it keeps the
    newest KEPT_SET_UPS set-ups, not one a pair."""
    from csw.matching import matcher as matcher_module

    monkeypatch.setattr(matcher_module, "KEPT_SET_UPS", 2)
    matcher = csw.Matcher(dmax=4, preset="raw")
    rng = np.random.default_rng(0)
    for width in (32, 33, 34, 35):
        pair = rng.integers(0, 255, (2, 16, width), dtype=np.uint8)
        matcher.match(pair[0], pair[1])
    assert [key[2] for key in matcher._ready] == [(16, 34), (16, 35)]

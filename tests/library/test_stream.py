"""csw.Matcher.stream: frames in flight give csw.match's results, bit for bit, in order."""

import numpy as np
import pytest

import csw
from csw.data.synth import render
from csw.matching.matcher import STREAM_STRIPES_WORK, stream_concurrency


def frames(count, width=96, height=64, dmax=15, seed=3):
    return [render(width, height, dmax, seed, phase=i / count)[:2] for i in range(count)]


def same(a, b):
    np.testing.assert_array_equal(a.disparity, b.disparity)  # NaN where NaN
    np.testing.assert_array_equal(a.min_cost, b.min_cost)
    assert a.evaluated == b.evaluated and a.candidates == b.candidates


@pytest.mark.parametrize("preset", ["accurate", "raw", "paper"])
@pytest.mark.parametrize("in_flight", [None, 1, 2, 3])
def test_stream_equals_match_in_order(preset, in_flight):
    pairs = frames(7)
    matcher = csw.Matcher(preset=preset, dmax=15)
    results = list(matcher.stream(pairs, in_flight=in_flight))
    assert len(results) == len(pairs)
    for (left, right), result in zip(pairs, results, strict=True):
        same(result, csw.match(left, right, preset=preset, dmax=15))


def test_stream_with_csw_and_tau_auto_samples_each_pair():
    # tau auto samples each pair's costs: a kept set-up must not carry one pair's tau
    # to the next.
    pairs = frames(4)
    options = dict(preset="raw", csw=True, tau="auto", dmax=15)
    results = list(csw.Matcher(**options).stream(pairs, in_flight=2))
    for (left, right), result in zip(pairs, results, strict=True):
        expected = csw.match(left, right, **options)
        same(result, expected)
        assert result.settings["tau"] == expected.settings["tau"]
    assert len({r.settings["tau"] for r in results}) > 1  # the pairs do differ


def test_stream_finds_an_auto_range_on_the_first_frame_and_keeps_it():
    pairs = frames(4, width=160, height=96, dmax=24)
    results = list(csw.Matcher().stream(pairs, in_flight=2))
    first = results[0].settings
    assert first["range_source"] == "auto"
    for result in results[1:]:
        s = result.settings
        assert (s["dmin"], s["dmax"]) == (first["dmin"], first["dmax"])
        assert s["range_source"] == "auto (from the first pair)"
    left, right = pairs[2]
    same(results[2], csw.match(left, right, dmin=first["dmin"], dmax=first["dmax"]))


def test_stream_reads_paths_and_takes_a_generator(tmp_path):
    import imageio.v3 as iio

    pairs = frames(3)
    paths = []
    for i, (left, right) in enumerate(pairs):
        paths.append((tmp_path / f"l{i}.png", tmp_path / f"r{i}.png"))
        iio.imwrite(paths[-1][0], left)
        iio.imwrite(paths[-1][1], right)
    results = list(csw.Matcher(dmax=15).stream(p for p in paths))
    for (left, right), result in zip(pairs, results, strict=True):
        same(result, csw.match(left, right, dmax=15))


def test_a_bad_frame_is_yielded_as_its_error_and_the_stream_goes_on():
    pairs = frames(5)
    pairs[2] = (pairs[2][0], pairs[2][1][:, :-4])  # the right image narrower
    out = list(csw.Matcher(dmax=15).stream(pairs, in_flight=2, errors="yield"))
    assert isinstance(out[2], ValueError) and "size" in str(out[2]).lower()
    for i in (0, 1, 3, 4):
        same(out[i], csw.match(*pairs[i], dmax=15))
    with pytest.raises(ValueError):
        list(csw.Matcher(dmax=15).stream(pairs, in_flight=2))


def test_a_new_frame_size_is_set_up_anew():
    small, large = frames(1)[0], frames(1, width=128, height=80)[0]
    matcher = csw.Matcher(dmax=15)
    results = list(matcher.stream([small, large, small]))
    same(results[1], csw.match(*large, dmax=15))
    same(results[2], csw.match(*small, dmax=15))


def test_an_empty_stream_yields_nothing():
    assert list(csw.Matcher(dmax=15).stream([])) == []


@pytest.mark.two_cores
def test_stream_plan_puts_small_frames_side_by_side_and_stripes_large_ones():
    config = csw.config.params.resolve(dmax=63, threads=1)
    assert stream_concurrency(config, (480, 640)) == (1, 1)
    config = config.replace(threads=2)
    assert stream_concurrency(config, (480, 640)) == (2, 1)
    side = int(np.sqrt(STREAM_STRIPES_WORK / 64)) + 10
    assert stream_concurrency(config, (side, side)) == (1, 2)
    assert stream_concurrency(config, (480, 640), in_flight=1) == (1, 2)
    with pytest.raises(ValueError, match="in_flight"):
        stream_concurrency(config, (480, 640), in_flight=0)


def test_repeated_matches_reuse_the_set_up_and_stay_equal():
    left, right = frames(1)[0]
    matcher = csw.Matcher(dmax=15)
    first, second = matcher.match(left, right), matcher.match(left, right)
    same(first, second)
    assert second.compile_seconds == 0.0
    assert first.settings == second.settings
    assert first.settings is not second.settings  # each result owns its settings


@pytest.mark.parametrize("in_flight", [2, 3])
def test_no_more_frames_are_read_ahead_than_in_flight(in_flight):
    """When result i is yielded, at most i + in_flight pairs have been read: a camera's
    frames are not taken before a thread can match them."""
    pulled = []

    def pairs():
        for pair in frames(8):
            pulled.append(1)
            yield pair

    matcher = csw.Matcher(dmax=15)
    for i, _ in enumerate(matcher.stream(pairs(), in_flight=in_flight)):
        assert len(pulled) <= i + in_flight, (i, len(pulled))
    assert len(pulled) == 8


def test_a_signal_during_a_held_block_is_acted_on_after_it():
    """csw.scale.summary.signals_held: a frame's outputs and its entry are written together;
    the Ctrl-C that came meanwhile is acted on (by the handler in place) once they are."""
    import os
    import signal

    from csw.scale.summary import signals_held

    seen = []
    saved = signal.signal(signal.SIGINT, lambda signum, frame: seen.append(signum))
    try:
        with signals_held():
            os.kill(os.getpid(), signal.SIGINT)
            sum(range(10**5))  # a handler runs between bytecodes: here, were it not held
            assert seen == []
        assert seen == [signal.SIGINT]
    finally:
        signal.signal(signal.SIGINT, saved)


def test_a_known_range_matches_the_first_frame_beside_the_next(monkeypatch):
    """Nothing is learnt from a first frame whose range is given: it is matched in the
    frames' pool like the rest, not alone in the caller's thread; with a range "auto" it
    is matched alone, first."""
    import threading

    from csw.matching.matcher import Matcher

    where = []
    guarded = Matcher._guarded

    def spy(self, *args):
        where.append(threading.current_thread().name)
        return guarded(self, *args)

    monkeypatch.setattr(Matcher, "_guarded", spy)
    pairs = frames(4)
    results = list(csw.Matcher(dmax=15).stream(pairs, in_flight=2))
    assert all(name.startswith("csw-frame") for name in where), where
    for (left, right), result in zip(pairs, results, strict=True):
        same(result, csw.match(left, right, dmax=15))
    where.clear()
    list(csw.Matcher().stream(pairs, in_flight=2))
    assert where[0] == threading.current_thread().name
    assert all(name.startswith("csw-frame") for name in where[1:]), where


def test_frames_side_by_side_run_where_glibc_is_not_found(monkeypatch):
    import ctypes

    from csw.matching import matcher

    def no_libc(*args, **kwargs):
        raise OSError("no libc.so.6 here")

    monkeypatch.setattr(matcher, "_HEAP_SET", [])
    monkeypatch.setattr(ctypes, "CDLL", no_libc)
    pairs = frames(3)
    results = list(csw.Matcher(dmax=15).stream(pairs, in_flight=2))
    for (left, right), result in zip(pairs, results, strict=True):
        same(result, csw.match(left, right, dmax=15))
    assert matcher._HEAP_SET == [True]  # tried once, not again each stream


def test_streams_of_one_matcher_reuse_their_frame_threads(monkeypatch):
    """A thread's scratch (the slabs of a semi-global match) lives with the thread: each
    stream's frames run on the same threads, not on new ones that would make it again.
    The pool starts its threads as frames wait (a quick stream may use only one), so
    three streams of a matcher keeping two threads use at most two in all; with threads
    made for each stream, they would use at least three."""
    import threading

    from csw.matching.matcher import Matcher

    seen = []
    guarded = Matcher._guarded

    def spy(self, *args):
        seen.append(threading.current_thread())  # the Thread objects, kept alive
        return guarded(self, *args)

    monkeypatch.setattr(Matcher, "_guarded", spy)
    matcher = csw.Matcher(dmax=15)
    for _ in range(3):
        list(matcher.stream(frames(4), in_flight=2))
    assert threading.main_thread() not in seen  # a given range: every frame in the pool
    assert len(seen) == 12 and len(set(seen)) <= 2

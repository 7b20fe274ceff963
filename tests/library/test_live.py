"""csw.scale.frames.LiveFrames: a live source read in a thread of its own, every frame
kept in order, or (latest) only the newest, the others counted as dropped."""

import time

import pytest

from csw.io.video import VideoError
from csw.scale.frames import Frame, LiveFrames

INFO = {"rate": 30.0, "frames": 0, "notes": [], "size": (8, 4)}


def source(count, fail_after=None):
    def frames():
        for index in range(count):
            if index == fail_after:
                raise VideoError("the stream broke")
            yield Frame(index)
    return lambda: (frames(), dict(INFO))


def test_every_frame_in_order_without_latest():
    live = LiveFrames(source(50))
    assert live.info()["size"] == (8, 4)
    assert [frame.index for frame in live] == list(range(50)) and live.dropped == 0


def test_latest_keeps_the_newest_and_counts_the_rest():
    live = LiveFrames(source(200), latest=True)
    live.info()
    taken = []
    for frame in live:
        taken.append(frame.index)
        time.sleep(0.002)  # a matcher slower than the source
    assert taken == sorted(taken) and taken[-1] == 199
    assert len(taken) + live.dropped == 200


def test_a_source_that_fails_raises_after_its_frames():
    live = LiveFrames(source(10, fail_after=3))
    live.info()
    taken = []
    with pytest.raises(VideoError, match="broke"):
        for frame in live:
            taken.append(frame.index)
    assert taken == [0, 1, 2]
    empty = LiveFrames(lambda: (_ for _ in ()).throw(VideoError("not a video")))
    with pytest.raises(VideoError, match="not a video"):
        empty.info()

"""The frames of a stream: :class:`Frame`, the frames of two videos or one side by side
(``video_frames``), and a live source's, read in a thread of their own
(:class:`LiveFrames`).  csw.scale.stream matches them."""

import threading
import time
from collections import deque
from dataclasses import dataclass

import numpy as np

from ..io.video import VideoError, VideoReader


@dataclass
class Frame:
    """One frame of a stream: its index, the pair (gray uint8 (H, W)), the left frame
    in colour where asked for (uint8 (H, W, 3)), or the error that lost it."""

    index: int
    left: np.ndarray | None = None
    right: np.ndarray | None = None
    colour: np.ndarray | None = None
    error: Exception | None = None
    stamp: int | None = None  # a log's frame: the left header's stamp, nanoseconds
    arrived: float | None = None  # time.perf_counter() when it was decoded


def video_frames(left, right=None, sbs=False, colour=False):
    """(frames, info): the frames (:class:`Frame`) of two videos paired by index, or of
    one side-by-side video (left half: the left camera); info: "rate" (the left video's
    frames a second, 0 when unknown), "frames" (its header's count, 0 when unknown) and
    "notes", a list the generator appends a note to when one video ends before the
    other (the stream stops at the shorter).

    VideoError, one line, for a file that is not a video, an odd side-by-side width, a
    pair of videos of different sizes, or a frame whose size differs from the first's
    (raised when that frame is reached).
    """
    if sbs == (right is not None):
        raise ValueError("give two videos, or one side-by-side video with sbs")
    readers = [VideoReader(left, colour)]
    if right is not None:
        readers.append(VideoReader(right))
        if readers[0].size != readers[1].size:
            sizes = " and ".join(f"{w}x{h}" for w, h in (r.size for r in readers))
            raise VideoError(f"the two videos' frames differ in size ({sizes}); csw "
                             "matches frames of one size")
    width, height = readers[0].size
    if sbs and width % 2:
        raise VideoError(f"{left}: a side-by-side frame must have an even width (two "
                         f"halves), got {width}")
    info = {"rate": readers[0].rate, "frames": readers[0].frames, "notes": [],
            "size": (width // 2 if sbs else width, height)}
    return _frames(readers, sbs, info["notes"]), info


def _frames(readers, sbs, notes):
    first = None
    iterators = [iter(reader) for reader in readers]
    count = 0
    try:
        while True:
            items = [next(iterator, None) for iterator in iterators]
            if items[0] is None or items[-1] is None:
                if len(items) == 2 and items[0] is not items[1]:
                    ended, other = (0, 1) if items[0] is None else (1, 0)
                    notes.append(f"{readers[ended].path} ended after {count} frames, "
                                 f"before {readers[other].path}; matched the {count} "
                                 "frames both have")
                short = [r for r in readers if r.frames > r.read]
                if short and not notes:  # a damaged file whose decoder dropped frames
                    notes.append(f"{short[0].path}: its header says {short[0].frames} "
                                 f"frames; {short[0].read} could be read (the others "
                                 "are damaged, or the header's count was a guess)")
                return
            count += 1
            index = items[0][0]
            error = next((item[1] for item in items if isinstance(item[1], Exception)), None)
            if error is not None:
                yield Frame(index, error=error)
                continue
            left, right = items[0][1], (items[1][1] if len(items) == 2 else None)
            rgb = items[0][2]
            if sbs:
                half = left.shape[1] // 2
                left, right = left[:, :half], left[:, half:]
                rgb = None if rgb is None else rgb[:, :half]
            if first is None:
                first = left.shape
            elif left.shape != first or right.shape != first:
                raise VideoError(f"frame {index}: the size changed from {_size(first)} to "
                                 f"{_size(left.shape)}; csw matches a stream of one size")
            yield Frame(index, left, right, rgb, arrived=time.perf_counter())
    finally:
        for reader in readers:
            reader.close()


def _size(shape):
    return f"{shape[1]}x{shape[0]}"


# Frames a live source may run ahead of the matcher without --latest (then it waits).
LIVE_QUEUE = 8


class LiveFrames:
    """A live source's frames, opened and decoded in a thread of their own, so that the
    main thread only waits for them, in steps, and a Ctrl-C or SIGTERM lands at once
    (raised inside PyAV's read of standard input, it would be dropped).  latest: keep
    only the newest frame, a frame not taken before the next arrives dropped (``dropped``
    counts them), so that a matcher slower than the source never falls behind it;
    otherwise up to LIVE_QUEUE frames wait and then the source does."""

    def __init__(self, open_frames, latest=False):
        self.latest, self.dropped = latest, 0
        self._ready = threading.Condition()
        self._waiting = deque()
        self._info = self._error = None
        self._done = self._stopped = False
        threading.Thread(target=self._read, args=(open_frames,), daemon=True,
                         name="csw-live").start()

    def _read(self, open_frames):
        try:
            frames, info = open_frames()
            with self._ready:
                self._info = info
                self._ready.notify_all()
            for frame in frames:
                with self._ready:
                    while not self.latest and len(self._waiting) >= LIVE_QUEUE and \
                            not self._stopped:
                        self._ready.wait(0.1)
                    if self._stopped:
                        return
                    if self.latest:
                        self.dropped += len(self._waiting)
                        self._waiting.clear()
                    self._waiting.append(frame)
                    self._ready.notify_all()
        except BaseException as exc:  # noqa: BLE001 (handed to the main thread, raised there)
            self._error = exc
        finally:
            with self._ready:
                self._done = True
                self._ready.notify_all()

    def _wait(self, ready):
        with self._ready:
            while not ready() and not self._done:
                self._ready.wait(0.1)  # in steps: a Ctrl-C lands between them

    def info(self):
        """The source's info (as video_frames'), once it is open."""
        self._wait(lambda: self._info is not None)
        if self._info is None:
            raise self._error or VideoError("the live source ended before its first frame")
        return self._info

    def __iter__(self):
        try:
            while True:
                self._wait(lambda: self._waiting)
                with self._ready:
                    frame = self._waiting.popleft() if self._waiting else None
                    self._ready.notify_all()
                if frame is None:
                    if self._error is not None:
                        raise self._error
                    return
                yield frame
        finally:
            with self._ready:  # the reader stops at its next frame
                self._stopped = True
                self._ready.notify_all()

"""``csw.match``: one rectified pair in memory, a disparity map and what goes with it out.

Pairs bigger than memory go through :mod:`csw.scale.tiled`; :func:`csw.scale.files.match_files`
chooses between the two for files.  Both prepare through :mod:`csw.matching.setup`.
"""

import functools
import itertools
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import kernels
from ..camera import calibration as calib_module
from ..config.params import resolve
from ..io.images import read_image, to_gray
from . import disparity_range
from .disparity_range import crowded_end, shrink
from .pipeline import CandidateCounts, match_rows
from .pipeline import run as run_pipeline
from .setup import load_kernels, set_up


def resolved(config, options, who):
    """The options a caller gave, or a csw.config.params.Config it resolved already
    (csw's own callers resolve once, before they read any file): TypeError for both,
    naming ``who``; a bad option fails here, before any work."""
    if config is not None and options:
        raise TypeError(f"give {who} its options or a resolved config, not both")
    return resolve(**options) if config is None else config


@dataclass
class Result(CandidateCounts):
    """What :func:`match` returns.

    disparity: float32 (H, W), the disparity (subpixel where asked), NaN where invalid (no
        candidate, or refused by a validity stage or filter).
    confidence: float32 (H, W), 0..1: (second - best) / second of the costs, 0 where
        invalid (unless the second-best costs were computed, see ``match``, a read-only
        map of zeros).
    min_cost:  int64 (H, W), the minimum cost m at the chosen d, -1 where no candidate.
    evaluated: candidates (pixel, d) whose cost was evaluated.
    candidates: candidates plain matching evaluates, so ``work_saved`` is CSW's share.
    settings: every option as used (csw.config.params.Config.as_dict), the range
        decided and ``range_source`` saying where it came from, ``tau`` resolved to a
        number (-1 when CSW is off) and ``tau_source`` saying where it came from.
    seconds: the match itself; compile_seconds: JIT compile or cache load before it.
    notes: lines for the user about the result (the range looks cut short...); the CLI
        prints them on stderr.
    """

    disparity: np.ndarray
    confidence: np.ndarray
    min_cost: np.ndarray
    evaluated: int
    candidates: int
    settings: dict = field(default_factory=dict)
    seconds: float = 0.0
    compile_seconds: float = 0.0
    notes: list = field(default_factory=list)
    stripes = None  # matched whole (csw.scale.tiled's results give their stripe count)

    @property
    def shape(self):
        return self.disparity.shape

    @property
    def valid(self):
        """bool (H, W): where a disparity was found."""
        return np.isfinite(self.disparity)

    @property
    def invalid_share(self):
        """Share (0..1) of pixels without a disparity."""
        size = self.disparity.size  # a count, not a mean of a negated mask (every frame)
        return (size - np.count_nonzero(self.valid)) / size if size else 0.0


def as_gray(image, name):
    """A path, or a (H, W) / (H, W, 3|4) uint8/uint16 array -> uint8/uint16 (H, W)."""
    if isinstance(image, (str, Path)):
        return read_image(image)
    image = np.asarray(image)
    if image.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"{name} image must be uint8 or uint16, got {image.dtype}; change the "
                         "dtype with .astype(np.uint8) or .astype(np.uint16)")
    return to_gray(image, name)


def match(left, right, want_confidence=False, **options):
    """Match a rectified pair; left is the reference.

    Parameters
    ----------
    left, right : path or ndarray
        Image files, or uint8/uint16 arrays (H, W) or (H, W, 3|4); colour is converted to
        gray with the ITU-R 601-2 luma, as ``csw match`` does.
    preset : {"sgm", "accurate", "raw", "paper"}
        A named set of the options below (see :data:`csw.config.params.PRESETS`); options given
        explicitly override it.  "paper" takes no stage.
    engine : {"fast", "window"}
        Running sums, or a full window sum per candidate (the paper's method).  Both give
        identical results.
    cost : {"sad", "ssd", "shd", "census"}
        Census compares census codes (of a ``census_window`` square, ``census_pattern``
        dense or sparse) by Hamming distance.
    window : int
        Odd window side.
    dmin, dmax : int
        The disparity range searched.
    csw : bool
        Skip right pixels already claimed by a confident match on the row.
    csw_rule : {"literal", "unique"}
    tau : float, "auto" or "none", optional
        CSW's cost threshold; default: auto for the literal rule, none for the unique rule.
    csw_margin : int, optional
        The unique rule's margin in percent (default 12; 25 for SSD).
    threads : int, optional
        Threads (default: all cores).
    prefilter, prefilter_cap, census_window, census_pattern, lr_check, uniqueness_ratio,
    texture_threshold, subpixel, speckle_size, speckle_range, median, fill
        The pipeline's stages (see :mod:`csw.matching.pipeline`); ``lr_check``,
        ``uniqueness_ratio`` and ``texture_threshold`` take a number or "off" (None).
    want_confidence : bool
        Compute the confidence map even when no stage needs the second-best costs.

    Every option's default, allowed values and help are in :data:`csw.config.params.OPTIONS`.

    ``csw.match(left, right, **options)`` is ``csw.Matcher(**options).match(left,
    right)``: for many pairs with the same options, make the Matcher once.

    Returns
    -------
    Result

    Raises
    ------
    ValueError
        On bad input, with a message that says how to fix it.
    TypeError
        On an unknown option name.
    """
    return Matcher(pixels=None, **options).match(left, right, want_confidence)


class Matcher:
    """A matcher made once and called per pair, as OpenCV's ``StereoBM_create(...)`` and
    ``compute(l, r)``: the options are resolved and checked at construction, and the
    kernels they need loaded (compiled once, if need be), so that a bad option or a
    missing kernel fails now, not at the thousandth pair.

    >>> matcher = csw.Matcher(dmax=64)                      # the same options as csw.match
    >>> result = matcher.match(left, right)                 # a csw.Result, as csw.match's
    >>> for result in matcher.stream(pairs): ...            # frames in flight, in order

    pixels: the images' type whose kernels are loaded now (np.uint8 by default; a pair of
    another type loads its own on first use; None: none now).  A range "auto" is found
    from the first pair and kept for the next ones (``settings["range_source"]`` says
    so), as a stream from one rig wants; with ``keep_range=False`` each pair finds its
    own, as :func:`match` does (a drive whose depths change; a coarse match of the pair
    shrunk, which at 640x480 adds about a tenth to a frame's time, and at 320x240
    doubles it).  The set-up of a frame size (its checks, its kernels, its
    arguments) is made on its first pair and kept, unless it depends on the pixels (tau
    auto with CSW samples each pair, a range found on each pair), so that the next pairs
    pay only their matching.

    One Matcher may be used from several threads at once: each thread matches with
    scratch of its own (kernels/workspace.py), and the matcher keeps nothing of a pair
    but that first range and the set-ups.
    """

    def __init__(self, pixels=np.uint8, config=None, keep_range=True, **options):
        if not isinstance(keep_range, bool):
            raise TypeError(f"keep_range must be True or False, got {keep_range!r}")
        self.keep_range = keep_range
        # TypeError / ValueError now.  config: a csw.config.params.Config resolved
        # already (csw's own callers, which resolve before they read any file).
        self.config = resolved(config, options, "a Matcher")
        self._found = None  # the config with the range found on the first pair
        self._ready = {}  # (config, shapes, dtypes, confidence) -> Prepared
        if pixels is not None and self.config.range_known:
            load_kernels(self.config, np.dtype(pixels))

    def match(self, left, right, want_confidence=False, calibration=None):
        """Match a rectified pair (paths or arrays, as for :func:`csw.match`); returns a
        :class:`Result`.  calibration: the pair's csw.Calibration, whose ndisp sets the
        range when no dmax was given (default: a calib.txt beside a left image file)."""
        return self._match_with(self._found or self.config, left, right, want_confidence,
                                calibration)

    def _match_with(self, config, left, right, want_confidence, calibration=None):
        result = _match(config, left, right, want_confidence, self._ready, calibration)
        if self._found is None and not config.range_known and self.keep_range:
            self._found = disparity_range.kept_from_first(config, result.settings)
        return result

    def stream(self, pairs, in_flight=None, want_confidence=False, errors="raise"):
        """Match a stream of rectified pairs; yield their :class:`Result` in order.

        pairs: an iterable of (left, right), paths or arrays as for :meth:`match`; it is
            read only as frames are started, so a camera or a video can feed it.
        in_flight: frames matched at once, each on threads of its own; default: as
            :func:`stream_concurrency` decides from the first frame's size (small frames: one
            frame per thread, since a frame under about 50 million pixel-disparities
            runs on one thread; large ones: one frame at a time, cut into row stripes).
        errors: "raise" (a frame's error ends the stream) or "yield" (the frame's
            exception is yielded in its place and the stream goes on).

        With a range "auto", the first frame is matched alone (it finds the range for the
        rest, unless the matcher was made with ``keep_range=False``), as it is when its
        left image is a path (its size plans the stream); otherwise it is matched beside
        the next ones.  A result equals :meth:`match`'s on the same pair bit for bit; its
        settings' ``threads`` says how many threads its frame used.  Frames are read from
        ``pairs`` in this thread, at most ``in_flight`` ahead of the one yielded; on a
        Ctrl-C, no frame is started after it and the ones running finish first.  When
        ``pairs`` itself raises, the frames it gave before are yielded first.
        """
        if errors not in ("raise", "yield"):
            raise ValueError(f"errors must be 'raise' or 'yield', got {errors!r}")
        iterator = iter(pairs)
        config = self._found or self.config
        shape = None
        if config.range_known:
            # Nothing to learn from a first frame: an array's size plans the stream, and
            # the frame is matched beside the next ones rather than alone first.
            for pair in iterator:
                shape = _shape_of(pair)
                iterator = itertools.chain([pair], iterator)
                break
            else:
                return
        if shape is None:
            for left, right in iterator:  # the first frame, alone
                first = self._guarded(config, left, right, want_confidence, errors)
                break
            else:
                return
            config = self._found or self.config
            shape = first.shape if isinstance(first, Result) else None
            yield first
        planned = config  # a range found on each frame: planned with the first one's
        if shape is not None and not config.range_known:
            planned = config.replace(dmin=first.settings["dmin"], dmax=first.settings["dmax"])
        frames, threads = stream_concurrency(planned, shape, in_flight)
        frame_config = config.replace(threads=threads)
        if frames == 1:
            for left, right in iterator:
                yield self._guarded(frame_config, left, right, want_confidence, errors)
            return
        yield from self._side_by_side(iterator, frames, frame_config, want_confidence, errors)

    def _side_by_side(self, iterator, frames, config, want_confidence, errors):
        """The frames of ``iterator`` matched ``frames`` at a time with ``config``, yielded
        in order, reading at most ``frames`` ahead of the one yielded."""
        from concurrent.futures import wait

        # Frames in flight on a pool of their own, not csw.scale.executor.run_tasks (the
        # engine of batches and stripes, which yields tasks as they finish and queues
        # two a thread): a stream yields in order, reads its source at most
        # ``in_flight`` frames ahead (a camera must not be drained), and lives under
        # csw.scale, which imports this module.  kernels/runtime.py's pool is another
        # level again: the row stripes inside one frame.
        _keep_freed_memory()
        pending = deque()
        # The frames' threads are kept from stream to stream, with their scratch: new
        # ones would fault in a 640x480 d 0..63 frame's 78 MB of slabs again on their
        # first frames (a tenth of a 24-frame stream's time).
        pool = kernels.runtime.kept_pool(frames, "csw-frame")
        try:
            while True:
                try:
                    left, right = next(iterator)
                except StopIteration:
                    break
                except Exception:  # the source failed: the frames it gave first count
                    while pending:
                        yield pending.popleft().result()
                    raise
                pending.append(pool.submit(self._guarded, config, left, right,
                                           want_confidence, errors))
                if len(pending) >= frames:
                    yield pending.popleft().result()
            while pending:
                yield pending.popleft().result()
        finally:
            for future in pending:  # a Ctrl-C or an error: start nothing more
                future.cancel()
            wait(pending)  # and the frames running finish first

    def _guarded(self, config, left, right, want_confidence, errors):
        """One frame of a stream; its exception returned, not raised, when errors is
        "yield" (KeyboardInterrupt and SystemExit always propagate)."""
        try:
            return self._match_with(config, left, right, want_confidence)
        except Exception as exc:
            if errors == "raise":
                raise
            return exc


# Frames side by side allocate their maps in the pool threads' heaps, which glibc hands
# back to the system as each frame's arrays are freed, so that the next frame faults its
# pages in again: about 500 page faults and 1.8 ms of system time a 640x480 frame on two
# threads, 4% of the stream's frames a second.  A stream raises glibc's thresholds once a
# process: blocks under FRAME_HEAP_MMAP bytes come from the heaps, and a heap keeps up to
# FRAME_HEAP_TRIM bytes free (csw.scale.tiled gives memory back itself, malloc_trim).
FRAME_HEAP_MMAP = 8 << 20
FRAME_HEAP_TRIM = 64 << 20
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3  # glibc's malloc.h
_HEAP_SET = []


def _keep_freed_memory():
    """Set glibc's thresholds for frames side by side, once a process; a no-op where
    there is no glibc."""
    if _HEAP_SET:
        return
    _HEAP_SET.append(True)
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(_M_MMAP_THRESHOLD, FRAME_HEAP_MMAP)
        libc.mallopt(_M_TRIM_THRESHOLD, FRAME_HEAP_TRIM)
    except (OSError, AttributeError):
        pass


def _shape_of(pair):
    """(H, W) of a stream's pair whose left image is an array; None otherwise (a path,
    whose size is known once read, or not a pair: its frame reports that)."""
    if isinstance(pair, (tuple, list)) and len(pair) == 2:
        left = pair[0]
        if isinstance(left, np.ndarray) and left.ndim in (2, 3):
            return left.shape[:2]
    return None


# A frame with more work than this (pixels x disparities) is matched in row stripes on
# every thread, one frame at a time; smaller frames are matched one per thread, side by
# side.  Measured on 2 cores (reports/stream.md): at 1242x375 d 0..127 (60 M) frames side
# by side gave more frames a second than stripes; at 1920x1080 d 0..255 (530 M) the two
# were within noise, and stripes give a frame in half the time.
STREAM_STRIPES_WORK = 200_000_000


def stream_concurrency(config, shape, in_flight=None):
    """(frames in flight, threads per frame) for a stream of frames of ``shape`` (H, W;
    None: not known) matched with ``config`` (its range decided)."""
    threads = kernels.runtime.thread_count(config.threads)
    if in_flight is not None:
        if isinstance(in_flight, bool) or int(in_flight) != in_flight or in_flight < 1:
            raise ValueError(f"in_flight must be a whole number of frames, at least 1, got "
                             f"{in_flight!r}")
        in_flight = int(in_flight)
        return in_flight, max(1, threads // in_flight)
    if shape is None or threads == 1:
        return 1, threads
    work = shape[0] * shape[1] * (config.dmax - config.dmin + 1)
    return (1, threads) if work > STREAM_STRIPES_WORK else (threads, 1)


@functools.lru_cache(maxsize=64)
def _zeros(shape):
    """A read-only float32 map of zeros of ``shape`` taking no memory, shared by the
    results of that shape (making one costs about 10 us, a stream's frame's share)."""
    return np.broadcast_to(np.float32(0), shape)


# Set-ups a Matcher keeps: a stream has one frame size, a batch a few; a batch whose
# pairs each bring a calibration (a range of their own) must not keep one a pair.
KEPT_SET_UPS = 16


def _match(config, left, right, want_confidence, ready=None, calibration=None):
    """One pair with a resolved ``config``.  ready: a dict of set-ups kept between pairs
    (a Matcher's), filled with the ones that don't depend on the pixels.  calibration:
    the pair's, for its ndisp (default: a calib.txt beside a left image file, as csw
    match reads it)."""
    if calibration is None and "dmax" not in config.given:
        calibration = calib_module.resolve(None, left)
    left, right = as_gray(left, "left"), as_gray(right, "right")
    ndisp = (calibration.ndisp, calibration.source) if calibration is not None and \
        calibration.ndisp else None
    key = (config, ndisp, left.shape, left.dtype, right.shape, right.dtype, want_confidence)
    prepared = None if ready is None else ready.get(key)
    compile_seconds = 0.0
    if prepared is None:
        def sample_min_cost(args, stages, rows):
            return match_rows(left, right, dict(args, rows=rows), stages)[2].min_cost

        def shrunk(f):
            return shrink(left, f), shrink(right, f)

        prepared = set_up(config, left.shape, left.dtype, right=(right.shape, right.dtype),
                          sample_min_cost=sample_min_cost, confidence=want_confidence,
                          shrunk=shrunk, calibration=calibration)
        compile_seconds = prepared.compile_seconds
        # Kept unless it came from these pixels: a range or a tau found from the pair.
        if ready is not None and not prepared.from_pixels and \
                prepared.settings["tau_source"] != "auto":
            # The oldest go (dicts keep their order); list() copies the keys in one step,
            # so a batch's threads sharing the Matcher never see the dict change under it.
            for old in list(ready)[:max(0, len(ready) - KEPT_SET_UPS + 1)]:
                ready.pop(old, None)
            ready[key] = prepared
    start = time.perf_counter()
    # This thread's workspace: a notebook's or a batch's repeated matches reuse their
    # scratch instead of faulting it in again (kernels/workspace.py).
    disparity, confidence, raw = run_pipeline(left, right, prepared.args,
                                              prepared.config.stages,
                                              confidence=want_confidence,
                                              workspace=kernels.workspace.for_this_thread())
    seconds = time.perf_counter() - start
    if confidence is None:  # not computed: zeros that take no memory (a fresh 4 bytes a
        # pixel per match made glibc return and fault in the heap's top on every call)
        confidence = _zeros(disparity.shape)
    settings = dict(prepared.settings)  # each result its own, a kept set-up's unchanged
    note = crowded_end(disparity, settings)
    return Result(disparity, confidence, raw.min_cost, raw.evaluated, raw.candidates,
                  settings, seconds, compile_seconds, [note] if note else [])

"""A video, or two, in; a map per frame and a preview video out: ``csw match`` on video.

The frames go through :meth:`csw.Matcher.stream` (frames in flight on every core), while
this thread decodes the next frames and writes the finished ones.  Outputs follow the
batch's rules (csw.scale.batch): every map is written atomically into the output
folder, a rerun skips the frames whose map exists, a frame that fails is reported in
the summary and the others go on, and a Ctrl-C keeps what is written, the preview video
closed as it stands and the summary marked interrupted.
"""

import errno
import os
import queue
import threading
import time
from array import array
from collections import deque
from contextlib import closing
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..config.params import OptionError
from ..io import safety
from ..io.formats import check_map_range, one_file, suffixes
from ..io.outputs import PairOutputs, check_range_of, role_suffixes
from ..io.pictures import DisparityColours
from ..io.progress import progress_bar
from ..io.video import WRITTEN_SUFFIXES, VideoError, VideoWriter, is_live
from ..matching.disparity_range import check_bounds
from ..matching.matcher import Matcher, resolved
from ..robot.logs import LogError, format_stamp
from .batch import failure_message
from .frames import Frame, LiveFrames, video_frames
from .summary import PairLog, signals_held, write_summary

FRAME_NAME = "{index:06d}"  # a frame's outputs: 000000.pfm, 000001.pfm ...
# Its other outputs (frame_outputs): NNNNNN + this + their format, as a batch's pairs'.
FRAME_INFIX = {"preview": ".preview", "confidence": ".confidence"}


# A write that fails with one of these fails for every frame after it: the run stops.
DISK_FULL = {errno.ENOSPC, errno.EDQUOT, errno.EROFS}


def match_video(left, right=None, *, sbs=False, out_dir=None, suffix=".pfm",
                overwrite=False, preview_video=None, preview_sbs=False, summary=None,
                progress=True, in_flight=None, keep_range=True, latest=False, config=None,
                frame_outputs=None, **match_options):
    """Match every frame of two videos (frames paired by index), or of one side-by-side
    video (``sbs``: the left half is the left camera).

    Parameters
    ----------
    left, right : path
        The videos (right None with ``sbs``).
    out_dir : path, optional
        A folder (created if missing) for each frame's map, NNNNNN + ``suffix`` (frame
        0 is 000000.pfm), and summary.json.  A frame whose map exists is skipped unless
        ``overwrite``, so a rerun resumes.
    preview_video : path, optional
        The colour disparity video (Turbo over the range, invalid black), at the input's
        frame rate; ``preview_sbs``: the left frame beside it.
    summary : path, optional
        Where to write the JSON summary (default: out_dir/summary.json; none without
        out_dir).
    progress : bool or callable
        A progress bar on stderr with frames a second; or ``progress(done, total)``.
    in_flight : int, optional
        Frames matched at once (see :meth:`csw.Matcher.stream`).
    keep_range : bool
        With a range "auto": find it on the first frame and keep it (True), or find it
        on every frame (False: each entry of the summary gives its frame's range, and
        the preview's colours span the widest range seen so far).
    latest : bool
        A live source ("-": standard input; /dev/video0: a V4L2 camera): decode in a
        thread of its own and match the newest frame, dropping the ones that arrive
        while the matcher is busy (the summary's "dropped") rather than fall behind.
    frame_outputs : dict, optional
        More outputs per frame beside its map, role -> format, as a batch's pairs:
        {"preview": ".png", "confidence": ".pfm"} writes NNNNNN.preview.png and
        NNNNNN.confidence.pfm, with the bytes csw.match_files writes for the pair.
    **match_options
        As for :func:`csw.match`; or ``config``, a csw.config.params.Config.

    Returns
    -------
    dict
        The summary: counts (ok, skipped, failed), frames, seconds, frames_per_second,
        latency_ms (median and p99: from a frame decoded, or arrived from a live source,
        to its map written), size, range,
        stream_notes (one video ended first ...), stopped (why the stream ended early:
        a frame size that changed, a file damaged past a point; None), failed (the
        failed frames' entries), interrupted, and pairs (read from the summary file when
        asked for; an empty list without one).
    """
    config = resolved(config, match_options, "a stream")
    inputs = [Path(p) for p in (left, right) if p is not None]
    out_dir, summary = _check_outputs(config, inputs, out_dir, suffix, summary,
                                      preview_video=preview_video,
                                      frame_outputs=frame_outputs)
    if is_live(left):
        frames = LiveFrames(lambda: video_frames(left, right, sbs, colour=preview_sbs),
                            latest)
        info = frames.info()
        if latest:
            info["summary"] = lambda: {"dropped": frames.dropped}
    elif latest:
        raise OptionError("latest", "latest is for a live source (- or /dev/videoN)")
    else:
        frames, info = video_frames(left, right, sbs, colour=preview_sbs)
    return _match_stream(frames, info, config, out_dir=out_dir, suffix=suffix,
                         overwrite=overwrite, summary=summary, preview_video=preview_video,
                         preview_sbs=preview_sbs, progress=progress, in_flight=in_flight,
                         keep_range=keep_range, frame_outputs=frame_outputs)


def match_log(log, *, out_dir=None, suffix=".pfm", overwrite=False, bag_out=None,
              depth=False, preview_video=None, preview_sbs=False, summary=None,
              progress=True, in_flight=None, keep_range=True, config=None,
              frame_outputs=None, **match_options):
    """Match every stereo frame of a robot's log: a ROS 1 bag, a ROS 2 bag (folder,
    .db3 or .mcap) or a KITTI raw drive, as :func:`match_video` matches a video.

    log : path or csw.robot.logs.Log
        The log, or one opened by :func:`csw.read_log` (its topics, rig, tolerance).
    out_dir, suffix, overwrite, preview_video, preview_sbs, summary, progress,
    in_flight, keep_range, frame_outputs, **match_options
        As for :func:`match_video`; each summary entry holds its frame's ``stamp_ns``.
    bag_out : path, optional
        A new bag (.bag: ROS 1; .mcap; else a ROS 2 bag folder) with each frame's
        stereo_msgs/DisparityImage on NS/disparity and sensor_msgs/PointCloud2 on
        NS/points2 (NS: the topics' namespace, as stereo_image_proc's), with ``depth``
        a 32FC1 depth Image in metres on NS/depth: each with the frame's stamp and the
        left frames' frame id (csw.robot.bags).

    Returns the summary, as :func:`match_video`'s, with "log": the topics, pairs,
    unpaired frames (left, right), whether csw rectified the frames, and with which
    rig.
    """
    from ..robot.logs import Log

    config = resolved(config, match_options, "a stream")
    if isinstance(log, (str, os.PathLike)):  # opened here: closed here
        with closing(Log(log, colour=bag_out is not None or preview_sbs)) as opened:
            return match_log(opened, out_dir=out_dir, suffix=suffix, overwrite=overwrite,
                             bag_out=bag_out, depth=depth, preview_video=preview_video,
                             preview_sbs=preview_sbs, summary=summary, progress=progress,
                             in_flight=in_flight, keep_range=keep_range, config=config,
                             frame_outputs=frame_outputs)
    inputs = [log.path, *(log.rig.paths if log.rig is not None else ())]
    out_dir, summary = _check_outputs(config, inputs, out_dir, suffix, summary,
                                      preview_video=preview_video, bag_out=bag_out,
                                      frame_outputs=frame_outputs)
    if bag_out is not None and log.calibration is None:
        raise OptionError("bag_out", f"{log.path}: the log gives no calibration for its "
                                     "rectified frames (no camera_info); give --rig")
    if depth and bag_out is None:
        raise OptionError("depth", "depth images go into --bag-out: give it")
    found = {"path": str(log.path), "left_topic": log.left_topic,
             "right_topic": log.right_topic, "pairs": log.pairs,
             "unpaired": {"left": log.unpaired[0], "right": log.unpaired[1]},
             "rectified_by_csw": log.rectifier is not None,
             "rig": log.rig.source if log.rig is not None else None}
    info = {"rate": log.rate, "frames": log.pairs, "notes": [], "size": tuple(log.size),
            "summary": lambda: {"log": found}}
    frames = (Frame(index, error=left, stamp=stamp) if isinstance(left, Exception) else
              Frame(index, left, right, colour, stamp=stamp)
              for index, left, right, colour, stamp in log.frames())
    publish = None
    if bag_out is not None:
        from ..robot.bags import BagWriter

        publish = _Publisher(BagWriter(bag_out), log, config, depth)
    return _match_stream(frames, info, config, out_dir=out_dir, suffix=suffix,
                         overwrite=overwrite, summary=summary, preview_video=preview_video,
                         preview_sbs=preview_sbs, progress=progress, in_flight=in_flight,
                         keep_range=keep_range, rectifier=log.rectifier, publish=publish,
                         frame_outputs=frame_outputs)


class _Publisher:
    """A log's frames' messages into a bag (csw.robot.bags), on the topics' namespace."""

    def __init__(self, writer, log, config, depth):
        self.writer, self.depth = writer, depth
        self.calibration, self.frame_id = log.calibration, log.frame_id
        self.namespace = log.output_topics()

    def __call__(self, frame, result):
        from ..robot.bags import stereo_messages

        colour = frame.colour if frame.colour is not None else frame.left
        settings = dict(result.settings)
        for name, msg in stereo_messages(self.writer, frame.stamp, self.frame_id,
                                         result.disparity, self.calibration, settings,
                                         colour, self.depth):
            self.writer.write(f"{self.namespace}/{name}", frame.stamp, msg)

    def close(self):
        return self.writer.close()

    def discard(self):
        self.writer.discard()


def _check_outputs(config, inputs, out_dir, suffix, summary, preview_video=None,
                   bag_out=None, frame_outputs=None):
    """Before any frame is read: the stream's outputs (out_dir, summary, preview_video,
    bag_out) checked against each other and the ``inputs``.  Returns (out_dir,
    summary)."""
    if out_dir is None and preview_video is None and bag_out is None:
        raise OptionError("output_dir", "give --output-dir for the maps, --preview-video, "
                                        "or both")
    if suffix not in suffixes("whole"):
        raise OptionError("suffix", f"must be one of {', '.join(suffixes('whole'))}, got "
                                    f"{suffix!r}")
    if config.range_known:
        check_range_of(f"map{suffix}", config.dmin, config.dmax)
    for role, extra in (frame_outputs or {}).items():
        if out_dir is None:
            raise OptionError(role, "a frame's outputs go into --output-dir: give it")
        # A frame's outputs are files beside its map: no store folders (zarr).
        allowed = [s for s in role_suffixes(role) if one_file(s)] if role in FRAME_INFIX \
            else []
        if str(extra).lower() not in allowed:
            raise OptionError(role, f"a frame's {role.replace('_', ' ')} takes a format, "
                                    f"one of {', '.join(allowed)}; got {extra!r}")
    for path in inputs:
        safety.protect(path)
    out_dir = Path(out_dir) if out_dir is not None else None
    if out_dir is not None and out_dir.exists() and not out_dir.is_dir():
        raise OptionError("output_dir", f"{out_dir} exists and is not a folder")
    summary = Path(summary) if summary else (out_dir / "summary.json" if out_dir else None)
    checked = {"preview_video": preview_video, "summary": summary, "bag_out": bag_out}
    real_inputs = {os.path.realpath(p): str(p) for p in inputs}
    for option, path in checked.items():
        if path is None:
            continue
        if os.path.realpath(path) in real_inputs:  # checked here too: a notebook's call
            # runs outside the CLI's guard
            raise OptionError(option, f"{path} is an input of this run; an output must not "
                                      "overwrite an input")
        if option == "preview_video" and Path(path).suffix.lower() not in WRITTEN_SUFFIXES:
            raise OptionError(option, f"{path} is not named as a video; use .mp4, .mkv, "
                                      ".mov or .avi")
        if option == "bag_out" and os.path.lexists(path):
            raise OptionError(option, f"{path} exists; csw writes a new bag, never over "
                                      "one (remove it or name another)")
        safety.check_target(path, option, folder_ok=option == "bag_out")
        folder = Path(path).parent
        if folder != out_dir and not folder.is_dir():
            raise OptionError(option, f"folder {str(folder)!r} does not exist; create it "
                                      "first")
    seen = {}
    for option, path in checked.items():
        if path is not None:
            other = seen.setdefault(os.path.realpath(path), option)
            if other != option:  # the option named last, which the user may change
                raise OptionError(option, f"{path} is also the {other.replace('_', ' ')}; "
                                          "two outputs can't be one file")
    return out_dir, summary


def _match_stream(frames, info, config, *, out_dir, suffix, overwrite, summary,
                  preview_video, preview_sbs, progress, in_flight, keep_range,
                  rectifier=None, publish=None, frame_outputs=None):
    """The run shared by videos and logs: ``frames`` (Frame) matched through
    Matcher.stream into the outputs checked by _check_outputs."""
    try:
        check_bounds(config, info["size"][0])  # from the header: before a frame is decoded
        if out_dir is not None:
            try:
                out_dir.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise OptionError("output_dir", f"can't create the folder {out_dir} "
                                                f"({exc.strerror or exc})") from None
        for option, folder in (("output_dir", out_dir),
                               ("summary", summary and summary.parent),
                               ("preview_video", preview_video and Path(preview_video).parent)):
            if folder is not None and not os.access(folder or ".", os.W_OK):  # before decoding
                raise OptionError(option, f"the folder {folder} is not writable")
        matcher = Matcher(config=config, keep_range=keep_range)
        try:
            run = _FrameRun(out_dir, suffix, overwrite, summary, preview_video, preview_sbs,
                       info["rate"] or 30.0, progress, info["frames"] or None,
                       each_range=not (keep_range or config.range_known))
        except OSError as exc:  # its log beside the summary: the folder can't be written
            folder = summary.parent if summary is not None else Path(".")
            raise OptionError("output_dir", f"can't write in {folder} "
                                            f"({exc.strerror or exc})") from None
    except BaseException:
        if publish is not None:
            publish.discard()
        raise
    run.rectifier, run.publish = rectifier, publish
    run.frame_outputs = dict(frame_outputs or {})
    run.extra = info.get("summary", dict)
    try:
        run.go(matcher, frames, in_flight)
    except (VideoError, LogError) as exc:  # the stream can't go on (a size changed, a
        run.stopped = str(exc)  # damaged file): what is done is kept, and the summary
        # says why it ended
    except KeyboardInterrupt:
        with signals_held():  # a second Ctrl-C waits until the summary is written
            run.finish(config, info["notes"], interrupted=True)
        raise
    except BaseException:
        run.abandon()
        raise
    return run.finish(config, info["notes"])


# Frames decoded ahead of the matcher, and frames matched waiting to be written: enough
# to cover a slow frame on either side, few enough that memory stays flat (a 640x480
# frame and its map are about 1.5 MB).
DECODE_AHEAD, WRITE_BEHIND = 4, 4


class _Ahead:
    """The frames of a generator, produced in a thread of their own and handed over
    through a queue of ``depth``: iterating yields them in order, and raises what the
    generator raised where it raised it.  PyAV decodes and converts outside the GIL, so
    the decoding runs beside the matcher's threads.  close() stops the thread and
    closes the generator (its readers) in it."""

    _END = object()

    def __init__(self, frames, depth):
        self._queue = queue.Queue(depth)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._produce, args=(frames,),
                                        name="csw-decode", daemon=True)
        self._thread.start()

    def _produce(self, frames):
        try:
            for frame in frames:
                if not self._put(frame):
                    break
        except BaseException as exc:  # noqa: BLE001 (handed to the consumer, raised there)
            self._put(_Raised(exc))
        finally:
            close = getattr(frames, "close", None)
            if close is not None:
                close()
            self._put(self._END)

    def _put(self, item):
        while not self._stop.is_set():
            try:
                self._queue.put(item, timeout=0.05)
                return True
            except queue.Full:
                continue
        return False

    def __iter__(self):
        while True:
            item = self._queue.get()
            if item is self._END:
                return
            if isinstance(item, _Raised):
                raise item.exception
            yield item

    def close(self):
        self._stop.set()
        self._thread.join()


@dataclass
class _Raised:
    exception: BaseException


class _Behind:
    """Tasks (callables) run in order in a thread of their own, at most ``depth``
    waiting: the writes of a stream's outputs.  The first task that raises stops the
    rest (they are dropped) and its exception is raised in the caller's thread, by the
    next put() or by close().  Signals reach the main thread only, so a task is never
    cut short by a Ctrl-C: a frame's outputs and entry are written whole."""

    def __init__(self, depth):
        self._queue = queue.Queue(depth)
        self.error = None
        self._raised = False
        self._thread = threading.Thread(target=self._run, name="csw-write", daemon=True)
        self._thread.start()

    def _run(self):
        while True:
            task = self._queue.get()
            if task is None:
                return
            if self.error is None:
                try:
                    task()
                except BaseException as exc:  # noqa: BLE001 (raised in the caller's thread)
                    self.error = exc

    def _raise(self):
        if self.error is not None and not self._raised:
            self._raised = True
            raise self.error

    def put(self, task):
        self._raise()
        self._queue.put(task)

    def close(self, raising=True):
        """Wait for every task put; then raise a task's error (once), unless not
        ``raising``."""
        if self._thread.is_alive():
            self._queue.put(None)
            self._thread.join()
        if raising:
            self._raise()


class _Now:
    """:class:`_Behind`'s interface, each task run at once in the caller's thread, with
    signals held so that a Ctrl-C never cuts a frame's outputs and entry short."""

    def put(self, task):
        with signals_held():
            task()

    def close(self, raising=True):
        pass


class _FrameRun:
    """The bookkeeping of one video's run: outputs written as results come, the
    summary's entries kept on disk (csw.scale.summary.PairLog), latencies in an array."""

    def __init__(self, out_dir, suffix, overwrite, summary, preview_video, preview_sbs,
                 rate, progress, total=None, each_range=False):
        self.out_dir, self.suffix, self.overwrite = out_dir, suffix, overwrite
        self.each_range = each_range  # every frame finds its own range
        self.summary, self.preview_sbs = summary, preview_sbs
        self.preview_path, self.rate, self.progress = preview_video, rate, progress
        self.preview = None
        self.colours = DisparityColours()  # its arrays kept from frame to frame
        self.bar_range = self.canvas = None  # the preview's colour bar, and its frame
        folder = summary.parent if summary is not None else None
        self.log = PairLog(folder if folder is not None else Path("."), 0)
        self.latency = array("d")
        self.size = self.range = None
        self.start = time.perf_counter()
        self.seconds = 0.0
        self.bar = progress_bar(total, "csw match", "frame", progress is True)
        self.total = total
        self.stopped = None  # why the stream ended before its end, if it did
        self.rectifier = None  # raw frames rectified: their maps' sourceless pixels go
        self.publish = None  # a log's messages into a bag, per frame
        self.frame_outputs = {}  # role -> format of the outputs beside each map
        self.extra = dict  # more of the summary: a log's topics and pairs, the frames a
        # live source dropped
        self.halt = None  # a write that stops the run (a full disk), once the frame is logged
        self.behind = None  # the writer's thread, while frames are matched (see go)

    def map_path(self, index):
        return self.out_dir / (FRAME_NAME.format(index=index) + self.suffix)

    def outputs(self, index):
        """The frame's outputs (csw.io.outputs.PairOutputs): its map and the
        frame_outputs asked for (their formats checked with the stream's outputs before
        the run, each file by csw.io.atomic as it is written)."""
        name = FRAME_NAME.format(index=index)
        return PairOutputs({"output": self.map_path(index),
                            **{role: self.out_dir / (name + FRAME_INFIX[role] + extra)
                               for role, extra in self.frame_outputs.items()}})

    def go(self, matcher, frames, in_flight):
        """Match the frames, decoded ahead in a thread of their own and written behind
        in another (:class:`_Ahead`, :class:`_Behind`), so that this thread only hands
        them on: a frame's decoding and the last one's writing no longer leave a core
        idle while the matcher waits for them.  The outputs, the summary's entries and
        the progress are all written by the writer's thread, in the frames' order."""
        waiting = deque()  # the frames handed to the matcher, oldest first
        # A bag's writer (a ROS 2 bag's SQLite) works only in the thread that opened it,
        # and a live source with latest drops frames at the source so that none waits:
        # those runs write in this thread, with no queue of frames matched behind.
        latest = isinstance(frames, LiveFrames) and frames.latest
        self.behind = behind = _Now() if self.publish is not None or latest else \
            _Behind(WRITE_BEHIND)
        # A live source reads in a thread of its own already, and with latest it must
        # hand over only its newest frame: a queue ahead of it would keep old ones.
        ahead = frames if isinstance(frames, LiveFrames) else _Ahead(frames, DECODE_AHEAD)

        def pairs():
            for frame in ahead:
                if frame.error is not None:
                    behind.put(lambda frame=frame: self.lost(frame))
                    continue
                if self.out_dir is not None and not self.overwrite and \
                        self.map_path(frame.index).exists():
                    if self.preview_path is None and self.publish is None:
                        behind.put(lambda frame=frame: self.add(frame.index, "skipped",
                                                                stamp=frame.stamp))
                        continue
                waiting.append((frame, frame.arrived or time.perf_counter()))
                yield frame.left, frame.right

        try:
            for result in matcher.stream(pairs(), in_flight=in_flight, errors="yield",
                                         want_confidence="confidence" in self.frame_outputs):
                frame, started = waiting.popleft()
                if isinstance(result, Exception):
                    behind.put(lambda frame=frame, result=result: self.add(
                        frame.index, "failed", error=failure_message(result),
                        stamp=frame.stamp))
                    continue
                if self.rectifier is not None:  # as csw match --rig: no source, no disparity
                    self.rectifier.invalidate(result.disparity)
                # The writer's thread, which signals never cut short: a frame's outputs
                # and entry are written all or none.
                behind.put(lambda frame=frame, result=result, started=started:
                           self.save(frame, result, started))
        finally:
            if ahead is not frames:
                ahead.close()
        behind.close()  # every frame matched is written; a write's error is raised here

    def lost(self, frame):
        """A frame that could not be decoded: its entry, and a black preview frame (the
        video's timing)."""
        self.add(frame.index, "failed", error=failure_message(frame.error), stamp=frame.stamp)
        if self.preview is not None:
            self.write_preview(frame, None)

    def save(self, frame, result, started=None):
        """A frame's map, bag messages and preview frame, then its entry, with its latency
        from ``started`` (its arrival, perf_counter seconds) to its outputs written."""
        s = result.settings
        if self.size is None:
            self.size = [int(result.shape[1]), int(result.shape[0])]
            self.range = [s["dmin"], s["dmax"]]
            if self.out_dir is not None and not self.each_range:  # every map: stop now
                check_map_range(f"map{self.suffix}", s["dmax"], s["dmin"])
        else:  # a range found on each frame: the summary's, and the colours', grows
            self.range = [min(self.range[0], s["dmin"]), max(self.range[1], s["dmax"])]
        status, error = "ok", None
        if self.out_dir is not None:
            path = self.map_path(frame.index)
            if path.exists() and not self.overwrite:
                status = "skipped"  # matched only for the preview; the map stays
            else:
                try:
                    outputs = self.outputs(frame.index)
                    outputs.add_map(result.disparity)
                    outputs.add_preview(result.disparity, s["dmin"], s["dmax"])
                    outputs.add_float_map("confidence", result.confidence)
                    outputs.write()
                except ValueError as exc:  # a frame's own range more than the format holds
                    status, error = "failed", str(exc)
                except OSError as exc:  # the frame fails; a full or read-only disk would
                    status = "failed"   # fail every next one too: the run stops after it
                    error = f"can't write {path}: {exc.strerror or exc}"
                    if exc.errno in DISK_FULL:
                        self.halt = f"frame {frame.index}: {error}"
        if self.publish is not None and self.halt is None:
            try:
                self.publish(frame, result)
            except OSError as exc:
                self.halt = f"frame {frame.index}: can't write the bag " \
                            f"({exc.strerror or exc})"
        if self.preview_path is not None and self.halt is None:
            try:
                self.write_preview(frame, result.disparity)
            except (OSError, VideoError) as exc:
                self.halt = f"frame {frame.index}: can't write the preview video " \
                            f"{self.preview_path} ({getattr(exc, 'strerror', None) or exc})"
        fields = {"error": error} if error is not None else {
            "seconds": result.seconds, "invalid": 100.0 * result.invalid_share,
            "notes": list(result.notes)}
        if self.each_range:
            fields["range"] = [s["dmin"], s["dmax"]]
        if started is not None:
            latency = time.perf_counter() - started
            self.latency.append(latency)
            fields["latency_ms"] = round(latency * 1e3, 2)
        self.add(frame.index, status, stamp=frame.stamp, **fields)
        if self.halt is not None:  # match_video keeps what is done and writes the summary
            raise VideoError(self.halt)

    def write_preview(self, frame, disparity):
        if disparity is None and self.size is None:
            return  # a lost frame before the video's size is known: nothing to show yet
        if self.preview is None:
            self.preview = VideoWriter(self.preview_path, self.rate)
        width, height = self.size
        canvas = self.with_bar(width * 2 if self.preview_sbs else width)
        top = canvas[:height]
        if disparity is None:  # a lost frame: black
            top[:] = 0
        elif self.preview_sbs:
            top[:, width:] = self.colours(disparity, *self.range)
        else:  # coloured in place, into the writer's own frame: no copy of it
            self.colours(disparity, *self.range, out=top)
        if self.preview_sbs:
            top[:, :width] = frame.colour if frame.colour is not None else 0
        self.preview.write(canvas)

    def with_bar(self, picture_width):
        """The preview's frame (the writer's canvas: VideoWriter.canvas) with the still
        previews' colour bar under the map (disparity in pixels over the range so far),
        drawn again only when the range grows; the rows above it are the caller's."""
        from ..io.pictures import BACKGROUND, bar

        width, height = self.size
        if self.bar_range != self.range:
            strip = bar(width, *self.range, "disparity (pixels)")
            self.canvas = self.preview.canvas(height + strip.shape[0], picture_width)
            self.canvas[height:] = (*BACKGROUND, 255)
            self.canvas[height:, -width:, :3] = strip
            self.bar_range = list(self.range)
        return self.canvas

    def add(self, index, status, stamp=None, **fields):
        entry = {"name": FRAME_NAME.format(index=index), "frame": index, "status": status,
                 **fields}
        if stamp is not None:  # a log's frame: its stamp, exact, and as people read it
            entry.update(stamp_ns=stamp, stamp=format_stamp(stamp))
        if self.out_dir is not None and status != "failed":
            entry.update({role: str(path) for role, path in
                          self.outputs(index).paths.items()})  # "output": the map
        self.log.add(self.log.done, entry)  # in the order they come
        self.bar.update()
        if callable(self.progress):
            self.progress(self.log.done, self.total)

    def finish(self, config, notes, interrupted=False):
        if self.behind is not None:  # stopped early: what was matched is written first
            self.behind.close(raising=False)
        self.seconds = time.perf_counter() - self.start
        self.bar.close()
        wrote_preview = False
        if self.preview is not None:
            try:
                self.preview.close()  # what was matched, a whole video, interrupted or not
                wrote_preview = True
            except (OSError, VideoError) as exc:  # a full disk: the summary still says
                reason = f"the preview video {self.preview_path} could not be written " \
                         f"({getattr(exc, 'strerror', None) or exc})"
                self.stopped = f"{self.stopped}; {reason}" if self.stopped else reason
        wrote_bag = False
        if self.publish is not None:
            try:
                # as the preview: what was matched, interrupted or not (a bag of no
                # messages is not written)
                wrote_bag = bool(self.publish.close())
            except (OSError, LogError) as exc:
                reason = f"the bag could not be written ({getattr(exc, 'strerror', None) or exc})"
                self.stopped = f"{self.stopped}; {reason}" if self.stopped else reason
        latency = np.frombuffer(self.latency, np.float64) * 1e3
        extra = {
            "frames": self.log.done,
            "seconds": round(self.seconds, 3),
            # Frames matched a second, over the whole run (reading and writing included).
            "frames_per_second": round(latency.size / self.seconds, 2) if self.seconds
            else 0.0,
            "latency_ms": {"median": round(float(np.median(latency)), 2),
                           "p99": round(float(np.percentile(latency, 99)), 2)}
            if latency.size else None,
            "size": self.size, "range": self.range, "stream_notes": list(notes),
            # None where no frame was matched (the video starts at the first) or its
            # writing failed
            "preview_video": str(self.preview_path) if wrote_preview else None,
            "bag_written": wrote_bag,
            "stopped": self.stopped, **self.extra(),
        }
        try:
            if self.summary is not None:
                report = write_summary(self.summary, self.log, config.as_dict(),
                                       interrupted, extra)
            else:
                report = dict(counts=self.log.counts, interrupted=interrupted,
                              options=config.as_dict(), failed=list(self.log.failed),
                              noted=list(self.log.noted), notes=self.log.notes, pairs=[],
                              **extra)
        finally:
            self.log.close()
        return report

    def abandon(self):
        if self.behind is not None:
            self.behind.close(raising=False)
        self.bar.close()
        if self.preview is not None:
            self.preview.discard()
        if self.publish is not None:
            self.publish.discard()
        self.log.close()

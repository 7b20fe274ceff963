"""Video in and out, with PyAV (FFmpeg's libraries, in the ``csw[video]`` extra).

Frames are read as gray uint8 (H, W) straight from the decoder: FFmpeg's scaler takes
the luma of a YUV frame to full-range gray (about 1 ms at 640x480 here), where decoding
to RGB and converting in Python would cost several times that.  So a video's gray is
the video's own luma (BT.601 or BT.709, as the file says), not Pillow's RGB luma; on a
video of a still image the two differ by a gray level or two.  Where a left colour
frame is wanted too (a preview beside the map), it is converted to RGB as well; the
gray matched is the same either way.

PyAV rather than imageio's ffmpeg plugin: imageio-ffmpeg pipes raw frames through a
subprocess, which costs a copy of every frame through a pipe and keeps no errors per
frame; PyAV decodes in this process, reports a damaged packet as an exception of its
own, and its wheels carry FFmpeg, so ``pip install 'csw-stereo[video]'`` needs nothing else.
"""

import os
from pathlib import Path

import numpy as np

from . import safety
from .images import ImageError, error_reason

# What csw treats as a video by its name (any FFmpeg container would do; these are the
# ones cameras and recorders write).
VIDEO_SUFFIXES = (".mp4", ".mkv", ".avi", ".mov", ".webm", ".m4v", ".mpg", ".mpeg", ".ts",
                  ".mjpeg", ".h264", ".h265", ".y4m")
WRITTEN_SUFFIXES = (".mp4", ".mkv", ".mov", ".avi")  # what a preview video may be


# A live source is probed on its first 32 KB only: FFmpeg's defaults (1 MB to find the
# format, then 5 MB or 5 s of the stream) hold the first frame back that long, or to the
# end of a short stream.
LIVE_PROBE = {"probesize": "32768", "formatprobesize": "32768", "analyzeduration": "0"}

# The previews' bit rate: maps are smooth, and half a bit a pixel keeps their edges.
BITS_PER_PIXEL = 0.5


class VideoError(ImageError):
    """A video that can't be read or written; the message says why, in one line."""


def is_video(path):
    """Whether ``path`` names a video file by its suffix."""
    return Path(path).suffix.lower() in VIDEO_SUFFIXES


def is_live(path):
    """Whether ``path`` is a live source: "-" (a stream on standard input, in any
    container FFmpeg finds by probing: MJPEG, y4m, MPEG-TS, NUT ...) or a V4L2 camera
    (/dev/video0)."""
    return str(path) == "-" or str(path).startswith("/dev/video")


def _av():
    try:
        import av
    except ImportError:
        raise VideoError("reading and writing video needs PyAV: "
                         "pip install 'csw-stereo[video]' (from a checkout: '.[video]')") from None
    # FFmpeg's own log lines ("No JPEG data found in image") would come on stderr beside
    # csw's one line per lost frame, which says the same with the frame's number.
    av.logging.set_level(av.logging.PANIC)
    return av


class VideoReader:
    """The frames of a video file, one at a time.

    path: the file.  colour: also give each frame in colour, RGBA uint8 (H, W, 4) (the
    alpha 255: the form a video writer takes without a copy).
    frames: the frame count the file's header gives (0 when it gives none); read: the
    frames iterated so far, lost ones included; size: (W, H) of its frames.  Iterating
    yields (index, gray uint8 (H, W), rgb or None) per frame, in order; a packet that
    can't be decoded yields (index, VideoError, None) in its frame's place and the
    reading goes on (the index counts the frames read and the ones lost).
    """

    def __init__(self, path, colour=False):
        av = _av()
        self.path, self.colour = Path(path), colour
        self.live = is_live(path)
        if not self.live:  # a camera is a device and standard input a pipe, on purpose
            safety.protect(self.path)
            safety.check_input(self.path, "a video file", VideoError)
            if not self.path.exists():
                raise VideoError(f"{self.path}: no such file")
            if self.path.is_dir():
                raise VideoError(f"{self.path}: is a directory, not a video")
        try:
            if str(path) == "-":  # FFmpeg reads the descriptor itself: no Python file
                # object, whose lock a reading thread would hold when the process exits
                self._container = av.open("pipe:0", "r", options=LIVE_PROBE)
            elif self.live:  # PyAV's V4L2 input
                self._container = av.open(str(self.path), "r", format="v4l2",
                                          options=LIVE_PROBE)
            else:
                self._container = av.open(str(self.path), "r")
            streams = self._container.streams.video
        except av.error.FFmpegError as exc:
            raise VideoError(f"{self.path}: not a readable video ({_reason(exc)})") from None
        except OSError as exc:
            raise VideoError(f"{self.path}: can't read it ({exc.strerror or exc})") from None
        if not streams:
            self._container.close()
            raise VideoError(f"{self.path}: holds no video stream")
        self._stream = streams[0]
        # One decoding thread: a stream decodes in a thread of its own beside a matcher
        # that keeps every core busy, where FFmpeg's frame threads only add their
        # hand-overs (a 1280x480 H.264 frame: 6.0 ms of CPU with them, 5.0 without).
        self._stream.codec_context.thread_count = 1
        # One converter for every frame: a frame's own to_ndarray(format=...) makes a new
        # swscale context each time, which cost 11 ms of a 1280x480 frame's 11.3 (the
        # conversion itself, reused, 2.8; the same bytes).
        from av.video.reformatter import VideoReformatter
        self._gray, self._rgba = VideoReformatter(), VideoReformatter()
        context = self._stream.codec_context
        self.size = (int(context.width), int(context.height))
        self.frames = int(self._stream.frames or 0)
        self.read = 0  # frames yielded so far, lost ones too: the next frame's index
        rate = self._stream.average_rate or self._stream.guessed_rate
        self.rate = float(rate) if rate else 0.0

    def __iter__(self):
        av = _av()
        end = 0
        try:
            for packet in self._container.demux(self._stream):
                if packet.pos is not None and packet.size:
                    end = packet.pos + packet.size
                try:
                    decoded = packet.decode()
                except av.error.FFmpegError as exc:
                    # A damaged packet: its frame is lost; the decoder goes on from the
                    # next one (and conceals what it can in the frames after it).
                    yield self.read, VideoError(f"{self.path}: frame {self.read} can't be "
                                                f"decoded ({_reason(exc)})"), None
                    self.read += 1
                    continue
                for frame in decoded:
                    yield (self.read, *self._arrays(frame))
                    self.read += 1
            if self.read == 0:  # the run stops, saying so (a header's count can be a
                # guess: only an empty file is sure to be wrong)
                raise VideoError(f"{self.path}: holds no frames")
            if self._container.format.name == "yuv4mpegpipe" and not self.live and \
                    os.path.getsize(self.path) > end:  # raw frames end to end: the demuxer
                # drops a last frame that the file cuts short, without a word
                raise VideoError(f"{self.path}: the file ends inside frame {self.read} "
                                 "(cut short)")
        except av.error.FFmpegError as exc:  # the container itself, past a point
            yield self.read, VideoError(f"{self.path}: the file is damaged after "
                                        f"frame {self.read} ({_reason(exc)})"), None
        finally:
            self.close()

    def _arrays(self, frame):
        # The same gray with or without colour.
        gray = self._gray.reformat(frame, format="gray").to_ndarray()
        return gray, self._rgba.reformat(frame, format="rgba").to_ndarray() \
            if self.colour else None

    def close(self):
        self._container.close()


def _reason(exc):
    """An FFmpeg error's reason, without the file name PyAV appends."""
    text = getattr(exc, "strerror", None) or error_reason(exc)
    return str(text).split(": '")[0][:120]


class VideoWriter:
    """A video written frame by frame into a temporary file beside ``path``, renamed
    into place by :meth:`close` (so a failure never leaves a partial video at
    ``path``); :meth:`discard` removes it instead.

    codec: "mpeg4" (MPEG-4 part 2, what OpenCV's "mp4v" writes: about 5 ms a 640x480
    frame here, at BITS_PER_PIXEL) for previews, or "h264" (libx264 "veryfast" at
    constant quality ``quality``, x264's crf: 0 lossless, 20 good to look at; about
    13 ms a frame) for videos that are inputs (csw synth --video).  The container is the
    suffix's; sizes are made even (yuv420p needs it) by repeating the last row or
    column.  rate: frames a second.
    """

    def __init__(self, path, rate=30.0, quality=20, codec="mpeg4"):
        import tempfile
        from fractions import Fraction

        from .atomic import sweep, temporary_prefix

        av = _av()
        if codec not in ("mpeg4", "h264"):
            raise ValueError(f"codec must be 'mpeg4' or 'h264', got {codec!r}")
        self.path = Path(path)
        safety.check_target(self.path)
        directory = self.path.parent if str(self.path.parent) else Path(".")
        sweep(directory)
        fd, tmp = tempfile.mkstemp(prefix=temporary_prefix(self.path.name),
                                   suffix=".tmp", dir=directory)
        os.close(fd)
        self.tmp = tmp
        self._rate = Fraction(rate).limit_denominator(1001)
        try:
            fmt = {".mkv": "matroska", ".mov": "mov", ".avi": "avi"}.get(
                self.path.suffix.lower(), "mp4")
            self._container = av.open(tmp, "w", format=fmt)
        except av.error.FFmpegError as exc:
            os.unlink(tmp)
            raise VideoError(f"{self.path}: can't write the video ({_reason(exc)})") from None
        self._stream = None
        self.frames = 0
        self.quality, self.codec = quality, codec
        self._canvas = (None, None, None)  # (size, av.VideoFrame or None, its array)

    def canvas(self, height, width):
        """A uint8 (height, width, 4) RGBA array to draw a frame in, which :meth:`write`
        takes without a copy (an array is copied into FFmpeg's frame: 1.4 MB a 640x560
        preview frame): the buffer of a frame this writer keeps, so a later canvas of the
        same size is the same array.  An odd size, or one whose rows FFmpeg pads, gets a
        plain array (written with the copy)."""
        if self._canvas[0] != (height, width):
            frame = _av().VideoFrame(width, height, "rgba")
            plane = frame.planes[0]
            if plane.line_size == 4 * width and not (height % 2 or width % 2):
                array = np.frombuffer(plane, np.uint8).reshape(height, width, 4)
            else:
                frame, array = None, np.empty((height, width, 4), np.uint8)
            self._canvas = ((height, width), frame, array)
        return self._canvas[2]

    def write(self, rgb):
        """Add a frame: uint8 (H, W, 3) RGB or (H, W, 4) RGBA (alpha ignored), the size
        of the first."""
        av = _av()
        rgb = _even(rgb)
        if self._stream is None:
            height, width = rgb.shape[:2]
            if self.codec == "h264":
                self._stream = self._container.add_stream("libx264", rate=self._rate)
                self._stream.options = {"preset": "veryfast", "crf": str(self.quality)}
            else:
                self._stream = self._container.add_stream("mpeg4", rate=self._rate)
                self._stream.bit_rate = int(BITS_PER_PIXEL * width * height *
                                            float(self._rate))
                # One encoding thread, as for decoding (VideoReader): a preview's frames
                # come from a writer's thread beside a busy matcher, and FFmpeg's threads
                # cost CPU in hand-overs (a 640x546 frame: 6.7 ms with them, 5.4 without).
                self._stream.codec_context.thread_count = 1
            self._stream.width, self._stream.height = width, height
            self._stream.pix_fmt = "yuv420p"
        _, frame, canvas = self._canvas
        if frame is None or rgb is not canvas:  # the canvas's frame is encoded as it is
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(rgb),
                                               format="rgba" if rgb.shape[2] == 4 else "rgb24")
        for packet in self._stream.encode(frame):
            self._container.mux(packet)
        self.frames += 1

    def close(self):
        """Flush the encoder and put the video in place (a video of no frames is not
        written).  Returns whether it was written."""
        try:
            if self._stream is not None:
                for packet in self._stream.encode():
                    self._container.mux(packet)
            self._container.close()
        except BaseException:
            self.discard()
            raise
        if self.frames == 0:
            self.discard()
            return False
        from .atomic import mode_for

        os.chmod(self.tmp, mode_for(self.path))
        os.replace(self.tmp, self.path)
        return True

    def discard(self):
        """Drop the video: nothing is left at ``path`` nor beside it."""
        try:
            self._container.close()
        except Exception:  # noqa: BLE001 (closing a broken encoder: the file goes anyway)
            pass
        if os.path.exists(self.tmp):
            os.unlink(self.tmp)


def _even(image):
    """The image with its height and width made even, by repeating the last row or
    column (H.264 in yuv420p needs even sizes)."""
    height, width = image.shape[:2]
    if height % 2:
        image = np.concatenate([image, image[-1:]], axis=0)
    if width % 2:
        image = np.concatenate([image, image[:, -1:]], axis=1)
    return image


def write_video(path, frames, rate=30.0, quality=20, codec="h264"):
    """Write ``frames`` (an iterable of uint8 (H, W, 3) RGB or (H, W) gray) as a video
    (see :class:`VideoWriter`)."""
    writer = VideoWriter(path, rate, quality, codec)
    try:
        for frame in frames:
            frame = np.asarray(frame)
            writer.write(np.repeat(frame[..., None], 3, axis=2) if frame.ndim == 2 else frame)
    except BaseException:
        writer.discard()
        raise
    writer.close()

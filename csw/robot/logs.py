"""Robot logs in: a ROS 1 bag, a ROS 2 bag (its folder, or one .db3 or .mcap file) or a
KITTI raw drive read as a stream of stereo frames (:func:`read_log`).

ROS logs are read with rosbags (the ``csw[logs]`` extra): a pure-Python reader and
writer of ROS 1, ROS 2 and MCAP bags with the message types built in, so no ROS install
is needed.  A log is read twice: a first pass takes only the header stamps of the two
image topics (the bytes 4..12 of every message, ROS 1 and ROS 2 alike: nothing is
decoded), checks them and pairs them; the second decodes the paired frames in order.  So
a log that can't be matched (stamps out of order, a damaged file, no pair) fails before
any output is written, and memory stays flat however long the log: only the stamps and
the few messages waiting for their partner are held.

Frames are paired by header stamp: a left and a right frame are partners when each is
the other's nearest within ``tolerance`` (exact stamps with 0), as message_filters'
approximate-time policy pairs two topics; the frames left over are counted.
"""

import io
import re
import struct
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from ..io import safety
from ..io.images import ImageError, check_pixels, luma, quiet_decoders, read_colour, read_image

LOG_SUFFIXES = (".bag", ".mcap", ".db3")
IMAGE = "sensor_msgs/msg/Image"
COMPRESSED = "sensor_msgs/msg/CompressedImage"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"

# encoding -> (pixel type, channels, channel order or Bayer pattern)
ENCODINGS = {
    "mono8": ("u1", 1, "mono"), "8uc1": ("u1", 1, "mono"),
    "mono16": ("u2", 1, "mono"), "16uc1": ("u2", 1, "mono"),
    "rgb8": ("u1", 3, "rgb"), "bgr8": ("u1", 3, "bgr"), "8uc3": ("u1", 3, "bgr"),
    "rgba8": ("u1", 4, "rgb"), "bgra8": ("u1", 4, "bgr"), "8uc4": ("u1", 4, "bgr"),
    "rgb16": ("u2", 3, "rgb"), "bgr16": ("u2", 3, "bgr"),
    "rgba16": ("u2", 4, "rgb"), "bgra16": ("u2", 4, "bgr"),
    **{f"bayer_{p}{bits}": ("u1" if bits == 8 else "u2", 1, p)
       for p in ("rggb", "bggr", "gbrg", "grbg") for bits in (8, 16)},
}
COMPRESSED_FORMATS = ("jpeg", "jpg", "png")


class LogError(ImageError):
    """A log that can't be read or matched; the message says why, in one line."""


def is_log(path):
    """Whether ``path`` names a log: a .bag, .mcap or .db3 file, a ROS 2 bag folder
    (metadata.yaml inside) or a KITTI raw drive (image_02/data and image_03/data)."""
    path = Path(path)
    if path.suffix.lower() in LOG_SUFFIXES:
        return True
    try:
        return path.is_dir() and ((path / "metadata.yaml").is_file() or _is_kitti(path))
    except OSError:  # a name too long, a folder that can't be read: the image reader
        return False  # says why in its words


def _is_kitti(path):
    return (path / "image_02" / "data").is_dir() and (path / "image_03" / "data").is_dir()


@dataclass(frozen=True)
class Topic:
    """An image topic of a log, for ``csw info``: its count, encoding, size (W, H) and
    rate (messages a second over the log's span; 0 when unknown)."""

    name: str
    msgtype: str
    count: int
    encoding: str
    size: tuple
    rate: float


def read_log(path, left_topic=None, right_topic=None, *, rig=None, tolerance=0.0,
             alpha=0.0, colour=False, threads=None):
    """A log's stereo frames (:class:`Log`): iterate it for ``(left, right, stamp)``,
    rectified and ready for :class:`csw.Matcher` (gray uint8/uint16 (H, W); stamp: the
    left header's, integer nanoseconds).

    >>> log = csw.read_log("drive.mcap")             # topics found by their names
    >>> log.rig, log.calibration                      # the rig rebuilt from CameraInfo
    >>> for result in csw.Matcher(dmax=64).stream((l, r) for l, r, _ in log): ...

    left_topic, right_topic: the image topics (default: a .../left/... topic whose name
    with "right" for "left" is one too, rectified ones first); rig: a csw.Rig that
    replaces the log's calibration; tolerance: seconds between partners' stamps (0:
    exact); alpha, threads: the Rectifier's, for raw topics; colour: also decode the
    left frame in colour (``frames()`` gives it).  LogError, one line, for a log that
    can't be matched.
    """
    return Log(path, left_topic, right_topic, rig=rig, tolerance=tolerance, alpha=alpha,
               colour=colour, threads=threads)


class Log:
    """An opened log (see :func:`read_log`).  Attributes: path; left_topic, right_topic;
    rectified (the topics were rectified already); rig (csw.Rig or None); rectifier (raw
    topics: the csw.Rectifier that rectifies them); calibration (the rectified pair's,
    in metres, or None); size (W, H); frame_id (the left frames'); pairs (how many);
    unpaired ((left, right) frames with no partner); rate (frames a second, 0 unknown).
    """

    def __init__(self, path, left_topic=None, right_topic=None, *, rig=None,
                 tolerance=0.0, alpha=0.0, colour=False, threads=None):
        if not (isinstance(tolerance, (int, float)) and 0 <= tolerance < 10):
            raise ValueError(f"tolerance must be 0 or more seconds (less than 10), got "
                             f"{tolerance!r}")
        self.path, self.colour = Path(path), colour
        safety.protect(self.path)
        safety.check_input(self.path, "a log", LogError)
        if not self.path.exists():
            raise LogError(f"{self.path}: no such file or folder")
        self._source = _Kitti(self.path) if self.path.is_dir() and _is_kitti(self.path) \
            else _Bag(self.path)
        try:
            self._open(left_topic, right_topic, rig, tolerance, alpha, threads)
        except BaseException:
            self.close()
            raise

    def _open(self, left_topic, right_topic, rig, tolerance, alpha, threads):
        source = self._source
        self.left_topic, self.right_topic = source.choose(left_topic, right_topic)
        self.rectified = source.rectified
        stamps = source.stamps()
        self.pairs_index = pair_stamps(*stamps, round(tolerance * 1e9))
        self.pairs = len(self.pairs_index)
        self.unpaired = getattr(source, "unpaired", None) or \
            (len(stamps[0]) - self.pairs, len(stamps[1]) - self.pairs)
        if not self.pairs:
            hint = "" if tolerance else "; if the cameras are not synchronised, give a " \
                "stamp tolerance (--stamp-tolerance)"
            raise LogError(f"{self.path}: no left frame of {self.left_topic} has a right "
                           f"frame of {self.right_topic} with its stamp{hint}")
        self.size, self.frame_id, self.rate = source.size, source.frame_id, source.rate
        given = rig is not None
        self.rig = rig if given else source.rig
        self.rectifier = None
        self.calibration = None if given else source.calibration
        if self.rig is not None:
            self.rig.check_size(self.size, f"the log's frames ({self.left_topic})")
        if not self.rectified:
            if self.rig is None:
                raise LogError(f"{self.left_topic} holds raw frames and the log has no "
                               f"camera_info beside them ({source.info_hint}); give the "
                               "rig with --rig")
            from ..camera.rectify import Rectifier

            self.rectifier = Rectifier(self.rig, alpha, threads)
            self.calibration = self.rectifier.calibration
        elif given:
            from ..camera.calibration import rectified_calibration
            from ..camera.rectification import rectification

            _, _, p1, p2 = rectification(self.rig, alpha)
            self.calibration = rectified_calibration(self.rig, p1, p2)
        if self.calibration is not None and self.calibration.units is None:  # ROS: metres
            self.calibration = replace(self.calibration, units="m")

    def frames(self):
        """Yield (index, left, right, colour or None, stamp) per pair, in stamp order,
        rectified; a frame that can't be decoded is (index, LogError, None, None, stamp)
        and the reading goes on."""
        for index, (raw_left, raw_right, stamp) in enumerate(self._source.read(
                self.pairs_index)):
            try:
                left, colour = self._source.decode(raw_left, "left", self.colour)
                right, _ = self._source.decode(raw_right, "right", False)
                for image, side in ((left, "left"), (right, "right")):
                    if image.shape[::-1] != tuple(self.size):
                        raise LogError(f"the {side} frame is {image.shape[1]}x"
                                       f"{image.shape[0]}, not {self.size[0]}x"
                                       f"{self.size[1]} as the first")
                if self.rectifier is not None:
                    left, right = self.rectifier.rectify(left, right)
                    if colour is not None:
                        colour = self.rectifier.rectify_one(colour, 0)
            except (ValueError, OSError) as exc:
                yield index, LogError(f"frame {index} (stamp {format_stamp(stamp)}): "
                                      f"{exc}"), None, None, stamp
                continue
            yield index, left, right, colour, stamp

    def __iter__(self):
        """(left, right, stamp) per pair; a frame that can't be decoded raises LogError."""
        for _, left, right, _, stamp in self.frames():
            if isinstance(left, Exception):
                raise left
            yield left, right, stamp

    def __len__(self):
        return self.pairs

    def close(self):
        self._source.close()

    def output_topics(self):
        """The namespace of the stereo pair's outputs (stereo_image_proc's): the topics'
        common prefix before left/right, e.g. /stereo for /stereo/left/image_raw."""
        head = self.left_topic.rsplit("left", 1)[0].rstrip("/_")
        return head if head.startswith("/") else "/" + head if head else "/stereo"


def format_stamp(stamp):
    return f"{stamp // 10**9}.{stamp % 10**9:09d}"


def pair_stamps(left, right, tolerance):
    """[(i, j)]: left[i] and right[j] (integer stamps, each increasing) whose each is the
    other's nearest, at most ``tolerance`` apart; in order."""
    left, right = np.asarray(left, np.int64), np.asarray(right, np.int64)
    if not left.size or not right.size:
        return []
    to_right, gap = _nearest(left, right)
    to_left, _ = _nearest(right, left)
    chosen = np.nonzero((gap <= tolerance) & (to_left[to_right] == np.arange(left.size)))[0]
    return list(zip(chosen.tolist(), to_right[chosen].tolist(), strict=True))


def _nearest(stamps, others):
    """For each stamp, the index of the nearest of ``others`` (the earlier on a tie) and
    the distance to it."""
    after = np.clip(np.searchsorted(others, stamps), 0, others.size - 1)
    before = np.clip(after - 1, 0, others.size - 1)
    take_before = np.abs(stamps - others[before]) <= np.abs(others[after] - stamps)
    nearest = np.where(take_before, before, after)
    return nearest, np.abs(others[nearest] - stamps)


def _check_increasing(stamps, topic):
    stamps = np.asarray(stamps, np.int64)
    back = np.nonzero(np.diff(stamps) <= 0)[0]
    if back.size:
        i = int(back[0]) + 1
        what = "repeats" if stamps[i] == stamps[i - 1] else "goes back from"
        raise LogError(f"{topic}: message {i}'s header stamp {what} the one before "
                       f"({format_stamp(int(stamps[i - 1]))} then "
                       f"{format_stamp(int(stamps[i]))}); csw pairs frames by stamp, in "
                       "order")
    return stamps


# ---- ROS bags ------------------------------------------------------------------------


def _rosbags():
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise LogError("reading ROS bags needs rosbags: pip install 'csw-stereo[logs]' "
                       "(from a checkout: '.[logs]')") from None
    return AnyReader, get_typestore(Stores.ROS2_HUMBLE)


def _damaged(path, exc):
    reason = str(exc).splitlines()[0][:160] if str(exc) else type(exc).__name__
    return LogError(f"{path}: not a readable log, or damaged ({reason})")


class _Bag:
    """A ROS bag, through rosbags' AnyReader.  rosbags raises many kinds of exception on
    a damaged file (its own, struct's, KeyError, zstd's, sqlite3's ...), so every call
    into it turns any Exception into one LogError line."""

    info_hint = "expected .../camera_info beside each image topic"

    def __init__(self, path):
        reader_class, typestore = _rosbags()
        if path.is_dir() and not (path / "metadata.yaml").is_file():
            raise LogError(f"{path}: a folder without metadata.yaml; csw reads ROS 2 bag "
                           "folders, .bag, .mcap and .db3 files and KITTI raw drives")
        self.path = path
        try:
            self.reader = reader_class([path], default_typestore=typestore)
            self.reader.open()
        except Exception as exc:  # noqa: BLE001 (see the class's docstring)
            raise _damaged(path, exc) from None
        self.ros2 = bool(getattr(self.reader, "is2", True))
        self.connections = {}
        for connection in self.reader.connections:
            self.connections.setdefault(connection.topic, []).append(connection)

    def close(self):
        try:
            self.reader.close()
        except Exception:  # noqa: BLE001 (closing a damaged file: nothing more to say)
            pass

    def _type(self, topic):
        return self.connections[topic][0].msgtype

    def image_topics(self):
        return sorted(t for t, cons in self.connections.items()
                      if cons[0].msgtype in (IMAGE, COMPRESSED))

    def describe(self):
        """[Topic] for every image topic."""
        span = (self.reader.end_time - self.reader.start_time) / 1e9 \
            if self.reader.message_count else 0.0
        rows = []
        for topic in self.image_topics():
            count = sum(c.msgcount for c in self.connections[topic])
            try:
                encoding, size = self._first_format(topic)
            except LogError as exc:
                encoding, size = f"? ({exc})", None
            rate = (count - 1) / span if span > 0 and count > 1 else 0.0
            rows.append(Topic(topic, self._type(topic), count, encoding, size, rate))
        return rows

    def _messages(self, topics):
        connections = [c for t in topics for c in self.connections[t]]
        try:
            yield from self.reader.messages(connections=connections)
        except Exception as exc:  # noqa: BLE001 (see the class's docstring)
            raise _damaged(self.path, exc) from None

    def _first(self, topic):
        for connection, _, raw in self._messages([topic]):
            return self._deserialize(raw, connection.msgtype)
        return None

    def _deserialize(self, raw, msgtype):
        try:
            return self.reader.deserialize(raw, msgtype)
        except Exception as exc:  # noqa: BLE001 (see the class's docstring)
            raise LogError(f"a message can't be read ({str(exc)[:120] or 'damaged'})"
                           ) from None

    def _first_format(self, topic):
        msg = self._first(topic)
        if msg is None:
            raise LogError(f"{topic} holds no message")
        gray, _ = decode(msg, topic=topic)
        return _encoding(msg), (gray.shape[1], gray.shape[0])

    def choose(self, left, right):
        images = self.image_topics()
        listed = ", ".join(images) or "none"
        for topic, option in ((left, "--left-topic"), (right, "--right-topic")):
            if topic is not None and topic not in self.connections:
                raise LogError(f"{self.path} has no topic {topic} ({option}); its image "
                               f"topics: {listed}")
            if topic is not None and topic not in images:
                raise LogError(f"{topic} holds {self._type(topic)}, not images ({option})")
        if left is None:
            left = _conventional(images, self.path, listed)
        if right is None:
            right = _partner(left)
            if right not in images:
                raise LogError(f"{self.path}: no right topic {right} beside {left}; name it "
                               f"with --right-topic (image topics: {listed})")
        self.left, self.right = left, right
        self.rectified = "rect" in left.removesuffix("/compressed").split("/")[-1]
        # The first frames: their encodings are known now, and their sizes compared.
        formats = [self._first_format(t) for t in (left, right)]
        if formats[0][1] != formats[1][1]:
            raise LogError(f"the left and right frames differ in size ({formats[0][1][0]}x"
                           f"{formats[0][1][1]} and {formats[1][1][0]}x{formats[1][1][1]}); "
                           "csw matches frames of one size")
        self.size = formats[0][1]
        self.frame_id = str(self._first(left).header.frame_id)
        self.rig = self.calibration = None
        infos = [self._first(_camera_info(t)) if _camera_info(t) in self.connections and
                 self._type(_camera_info(t)) == CAMERA_INFO else None for t in (left, right)]
        if all(info is not None for info in infos):
            self._calibrate(infos)
        return left, right

    def _calibrate(self, infos):
        from ..camera.rig import rig_from_camera_info

        source = f"{self.path} ({_camera_info(self.left)}, {_camera_info(self.right)})"
        try:
            self.rig = replace(rig_from_camera_info([_info_dict(i) for i in infos], source),
                               units="m", paths=(self.path,))
        except ValueError as exc:
            raise LogError(f"{exc}; give the rig with --rig") from None
        if self.rectified:  # the projection matrices describe the rectified pair
            from ..camera.calibration import rectified_calibration

            _, _, p1, p2 = self.rig.rectification
            self.calibration = rectified_calibration(self.rig, p1, p2)

    def stamps(self):
        found = {self.left: [], self.right: []}
        for connection, _, raw in self._messages([self.left, self.right]):
            found[connection.topic].append(_stamp(raw, self.ros2))
        left, right = (_check_increasing(found[t], t) for t in (self.left, self.right))
        self._stamps = (left, right)
        span = (left[-1] - left[0]) / 1e9 if left.size > 1 else 0.0
        self.rate = (left.size - 1) / span if span > 0 else 0.0
        return left, right

    def read(self, pairs):
        """(raw left, raw right, stamp) per pair, in order; a message waits only for its
        partner."""
        wanted = {self.left: {int(self._stamps[0][i]): k for k, (i, _) in enumerate(pairs)},
                  self.right: {int(self._stamps[1][j]): k for k, (_, j) in enumerate(pairs)}}
        waiting, next_k = {}, 0
        for connection, _, raw in self._messages([self.left, self.right]):
            stamp = _stamp(raw, self.ros2)
            k = wanted[connection.topic].get(stamp)
            if k is None:
                continue  # unpaired
            halves = waiting.setdefault(k, [None, None, stamp])
            halves[0 if connection.topic == self.left else 1] = (raw, connection.msgtype)
            if connection.topic == self.left:
                halves[2] = stamp
            while next_k in waiting and None not in waiting[next_k][:2]:
                yield tuple(waiting.pop(next_k))
                next_k += 1

    def decode(self, item, side, colour):
        raw, msgtype = item
        return decode(self._deserialize(raw, msgtype), colour)


def _stamp(raw, ros2):
    """A message's header stamp, integer nanoseconds, from its first bytes: ROS 2's CDR
    puts sec (int32) and nanosec at 4..12 after its encapsulation header (byte 1: 1 for
    little-endian); ROS 1 puts them at 4..12 after the header's seq, little-endian."""
    order = "<" if not ros2 or raw[1] == 1 else ">"
    try:
        sec, nsec = struct.unpack_from(order + "iI", raw, 4)
    except struct.error:
        raise LogError("a message is too short to hold a header") from None
    return sec * 1_000_000_000 + nsec


# Image topic names in the order csw prefers them: rectified frames first (matched as
# they are), then raw; uncompressed before compressed.
def _rank(topic):
    name = topic.removesuffix("/compressed").split("/")[-1]
    return ("rect" not in name, topic.endswith("/compressed"), topic)


def _partner(topic):
    head, _, tail = topic.rpartition("left")
    return f"{head}right{tail}"


def _conventional(images, path, listed):
    lefts = [t for t in images if "left" in t and _partner(t) in images]
    if not lefts:
        raise LogError(f"{path}: no pair of image topics named .../left/... and "
                       f".../right/...; name them with --left-topic and --right-topic "
                       f"(image topics: {listed})")
    lefts.sort(key=_rank)
    best = [t for t in lefts if _rank(t)[:2] == _rank(lefts[0])[:2]]
    if len(best) > 1:
        raise LogError(f"{path}: several stereo pairs of topics ({', '.join(best)}); "
                       "choose one with --left-topic")
    return best[0]


def _camera_info(topic):
    """The camera_info topic beside an image topic: /a/left/image_raw ->
    /a/left/camera_info (a /compressed topic's too)."""
    return topic.removesuffix("/compressed").rpartition("/")[0] + "/camera_info"


def _info_dict(msg):
    """A CameraInfo message as the mapping ROS's YAML files hold (ROS 1's field names
    are upper case: D K R P)."""
    def field(name):
        value = getattr(msg, name, None)
        return getattr(msg, name.upper()) if value is None else value

    return {"camera_matrix": list(map(float, field("k"))),
            "distortion_coefficients": list(map(float, field("d"))),
            "rectification_matrix": list(map(float, field("r"))),
            "projection_matrix": list(map(float, field("p"))),
            "image_width": int(msg.width), "image_height": int(msg.height),
            "distortion_model": str(msg.distortion_model or "plumb_bob")}


def _encoding(msg):
    fmt = getattr(msg, "format", None)
    return f"compressed ({fmt})" if fmt is not None else str(msg.encoding)


def decode(msg, colour=False, topic=None):
    """(gray uint8/uint16 (H, W), RGB uint8/uint16 (H, W, 3) or None) of a sensor_msgs
    Image or CompressedImage message; LogError, one line, for an encoding csw can't
    read or data that don't fit it."""
    where = f"{topic}: " if topic else ""
    fmt = getattr(msg, "format", None)
    if fmt is not None:
        return _decode_compressed(msg, str(fmt), colour, where)
    encoding = str(msg.encoding).lower()
    if encoding not in ENCODINGS:
        raise LogError(f"{where}encoding {msg.encoding!r} is not one csw reads "
                       f"(mono8/16, rgb8, bgr8, rgba8, bgra8 and 16-bit, Bayer, "
                       "CompressedImage JPEG/PNG)")
    kind, channels, order = ENCODINGS[encoding]
    height, width, step = int(msg.height), int(msg.width), int(msg.step)
    dtype = np.dtype(kind).newbyteorder(">" if msg.is_bigendian else "<")
    row = width * channels * dtype.itemsize
    data = np.asarray(msg.data, np.uint8)
    if height < 1 or width < 1 or step < row or data.size < step * height:
        raise LogError(f"{where}a {width}x{height} {encoding} frame needs {step * height} "
                       f"bytes of {step} a row, got {data.size}")
    pixels = data[:step * height].reshape(height, step)[:, :row]
    pixels = np.ascontiguousarray(pixels).view(dtype).astype(dtype.newbyteorder("="),
                                                             copy=False)
    pixels = pixels.reshape(height, width, channels)
    if order == "mono":
        gray = pixels[..., 0]
        return gray, (np.repeat(gray[..., None], 3, axis=2) if colour else None)
    rgb = demosaic(pixels[..., 0], order) if order not in ("rgb", "bgr") else \
        pixels[..., :3] if order == "rgb" else pixels[..., 2::-1]
    rgb = np.ascontiguousarray(rgb)
    return luma(rgb), (rgb if colour else None)


def _decode_compressed(msg, fmt, colour, where):
    from PIL import Image, UnidentifiedImageError

    if not any(name in fmt.lower() for name in COMPRESSED_FORMATS) or \
            "compresseddepth" in fmt.lower():
        raise LogError(f"{where}compressed format {fmt!r} is not one csw reads (JPEG, PNG)")
    try:
        with quiet_decoders(), Image.open(io.BytesIO(bytes(msg.data))) as image:
            check_pixels((image.height, image.width), f"{where}the compressed frame")
            image.load()
            if image.mode in ("I;16", "I;16B", "I"):
                gray = np.asarray(image).astype(np.uint16)
                rgb = None
            else:
                rgb = np.asarray(image.convert("RGB"))
                gray = luma(rgb)
    except UnidentifiedImageError:  # its text names a BytesIO object
        raise LogError(f"{where}the compressed frame can't be decoded (its bytes are no "
                       f"{fmt} image)") from None
    except (Image.DecompressionBombError, OSError, SyntaxError) as exc:
        raise LogError(f"{where}the compressed frame can't be decoded ({exc})") from None
    except ImageError as exc:  # over the pixel limit: a log's error, one frame's
        raise LogError(str(exc)) from None
    if colour and rgb is None:
        rgb = np.repeat(gray[..., None], 3, axis=2)
    return gray, (rgb if colour else None)


def demosaic(raw, pattern):
    """RGB (H, W, 3), raw's type, of a Bayer mosaic (H, W) with ``pattern`` ("rggb",
    "bggr", "gbrg", "grbg": the top-left 2x2 block, row by row): bilinear, each missing
    sample the mean of its nearest samples of that colour (edges mirrored)."""
    height, width = raw.shape
    padded = np.pad(raw.astype(np.float32), 1, mode="reflect")
    rgb = np.empty((height, width, 3), np.float32)
    y, x = np.mgrid[0:height + 2, 0:width + 2]
    y, x = (y - 1) % 2, (x - 1) % 2  # each padded pixel's place in its 2x2 block
    for channel, name in enumerate("rgb"):
        mask = np.zeros((height + 2, width + 2), np.float32)
        for k, letter in enumerate(pattern):
            if letter == name:
                mask[(y == k // 2) & (x == k % 2)] = 1.0
        samples = padded * mask
        weights = ((1, 2, 1), (2, 4, 2), (1, 2, 1))
        total = np.zeros((height, width), np.float32)
        count = np.zeros((height, width), np.float32)
        for dy in range(3):
            for dx in range(3):
                w = weights[dy][dx]
                total += w * samples[dy:dy + height, dx:dx + width]
                count += w * mask[dy:dy + height, dx:dx + width]
        rgb[..., channel] = total / count
    return np.rint(rgb).astype(raw.dtype)


# ---- KITTI raw drives ----------------------------------------------------------------


class _Kitti:
    """A KITTI raw drive: image_02 (left) and image_03 (right), data/*.png paired by
    name, timestamps.txt beside data/, and calib_cam_to_cam.txt in the date folder.  A
    *_sync drive's frames are rectified already (KITTI's P_rect gives their
    calibration); an *_extract drive's are raw, rectified with the calibration's rig."""

    info_hint = "expected calib_cam_to_cam.txt in the drive's date folder"

    def __init__(self, path):
        self.path = path
        self.calib_path = path.parent / "calib_cam_to_cam.txt"

    def close(self):
        pass

    def _files(self, camera):
        folder = self.path / camera / "data"
        return {p.name: p for p in folder.iterdir() if p.suffix.lower() == ".png"}

    def describe(self):
        rows = []
        for camera in ("image_02", "image_03"):
            files = sorted(self._files(camera).values())
            height, width = read_image(files[0]).shape if files else (0, 0)
            stamps = self._timestamps(camera, len(files)) if files else []
            span = (stamps[-1] - stamps[0]) / 1e9 if len(stamps) > 1 else 0
            rows.append(Topic(camera, "KITTI PNG", len(files), "png", (width, height),
                              (len(files) - 1) / span if span > 0 else 0.0))
        return rows

    def choose(self, left, right):
        if left not in (None, "image_02") or right not in (None, "image_03"):
            raise LogError(f"{self.path}: a KITTI drive's topics are image_02 and image_03")
        left_files, right_files = self._files("image_02"), self._files("image_03")
        self.names = sorted(set(left_files) & set(right_files))
        self.left_names, self.right_names = sorted(left_files), sorted(right_files)
        if not self.names:
            raise LogError(f"{self.path}: image_02/data and image_03/data share no frame")
        sizes = [read_image(self.path / cam / "data" / self.names[0]).shape
                 for cam in ("image_02", "image_03")]
        if sizes[0] != sizes[1]:
            raise LogError("the left and right frames differ in size; csw matches frames "
                           "of one size")
        self.size = (sizes[0][1], sizes[0][0])
        self.frame_id = "camera_02"
        self.rectified = not self.path.name.endswith("_extract")
        self.rig = self.calibration = None
        if self.calib_path.is_file():
            from ..camera.calibration import rectified_calibration
            from ..camera.rig import read_rig

            try:
                rig = read_rig(self.calib_path)
            except ValueError as exc:
                raise LogError(str(exc)) from None
            if self.rectified and rig.rectification is not None:
                _, _, p1, p2 = rig.rectification
                self.calibration = replace(rectified_calibration(rig, p1, p2),
                                           width=self.size[0], height=self.size[1])
            if not self.rectified:
                self.rig = rig
        return "image_02", "image_03"

    def _timestamps(self, camera, count):
        path = self.path / camera / "timestamps.txt"
        if not path.is_file():
            raise LogError(f"{path}: missing; a KITTI drive's frames take their stamps "
                           "from it")
        lines = [line for line in read_small_text(path).splitlines() if line.strip()]
        if len(lines) != count:
            raise LogError(f"{path}: {len(lines)} stamps for {count} frames")
        return [_kitti_stamp(line, path, i) for i, line in enumerate(lines)]

    def stamps(self):
        stamps = [self._timestamps(cam, len(names)) for cam, names in
                  (("image_02", self.left_names), ("image_03", self.right_names))]
        left, right = (_check_increasing(s, cam) for s, cam in
                       zip(stamps, ("image_02", "image_03"), strict=True))
        # Frames are paired by name (KITTI's sync did it); the stamps are the left's.
        by_name = [dict(zip(names, s.tolist(), strict=True)) for names, s in
                   ((self.left_names, left), (self.right_names, right))]
        self._pairs = [(name, by_name[0][name]) for name in self.names]
        self.unpaired = (len(self.left_names) - len(self.names),
                         len(self.right_names) - len(self.names))
        span = (left[-1] - left[0]) / 1e9 if left.size > 1 else 0.0
        self.rate = (left.size - 1) / span if span > 0 else 0.0
        # pair_stamps then finds each left frame's own right frame: the same stamps.
        return np.array([s for _, s in self._pairs]), np.array([s for _, s in self._pairs])

    def read(self, pairs):
        for i, _ in pairs:
            name, stamp = self._pairs[i]
            yield (self.path / "image_02" / "data" / name,
                   self.path / "image_03" / "data" / name, stamp)

    def decode(self, path, side, colour):
        gray = read_image(path)
        return gray, (read_colour(path)[..., :3] if colour else None)


def read_small_text(path):
    return safety.read_small(path, "a timestamps file", LogError,
                             limit=64 << 20).decode(errors="replace")


_KITTI_STAMP = re.compile(r"^\s*(\d{4}-\d\d-\d\d) (\d\d):(\d\d):(\d\d)(?:\.(\d{1,9}))?\s*$")


def _kitti_stamp(line, path, index):
    """'2011-09-26 13:02:25.964389445' -> integer nanoseconds (taken as UTC)."""
    found = _KITTI_STAMP.match(line)
    if not found:
        raise LogError(f"{path}: line {index + 1} is not a stamp ({line.strip()[:40]!r})")
    try:
        day = datetime.strptime(found.group(1), "%Y-%m-%d").replace(tzinfo=UTC)
        seconds = int(day.timestamp()) + 3600 * int(found.group(2)) + \
            60 * int(found.group(3)) + int(found.group(4))
    except (ValueError, OverflowError) as exc:  # a month 99, a year 0
        raise LogError(f"{path}: line {index + 1} is not a stamp ({exc})") from None
    stamp = seconds * 10**9 + int((found.group(5) or "0").ljust(9, "0"))
    if not 0 <= stamp < 2**63:  # stamps are int64 nanoseconds since 1970, as ROS's
        raise LogError(f"{path}: line {index + 1}'s stamp {found.group(1)} is outside "
                       "1970-2262, which csw's nanosecond stamps hold")
    return stamp


def describe_log(path):
    """[Topic]: a log's image topics (or a KITTI drive's two cameras), for csw info."""
    path = Path(path)
    safety.protect(path)
    safety.check_input(path, "a log", LogError)
    if not path.exists():
        raise LogError(f"{path}: no such file or folder")
    source = _Kitti(path) if path.is_dir() and _is_kitti(path) else _Bag(path)
    try:
        return source.describe()
    finally:
        source.close()



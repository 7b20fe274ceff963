"""Robot messages out: a bag written with rosbags (the ``csw[logs]`` extra), as a ROS 1
``.bag``, one ``.mcap`` file, or a ROS 2 bag folder (SQLite), and the messages a stereo
node publishes: stereo_msgs/DisparityImage, sensor_msgs/PointCloud2 and a depth Image,
filled as stereo_image_proc fills them (:func:`stereo_messages`).

A bag is written inside a temporary folder beside its path and moved into place by
:meth:`BagWriter.close`, so a failed run leaves no partial bag; a bag that exists is
never replaced (a bag folder can't be written over as one file can).
"""

import os
import shutil
from pathlib import Path

import numpy as np

from ..io import safety
from ..io.atomic import make_temporary_dir
from .logs import LogError

# PointField's datatype for float32.
FLOAT32 = 7


def bag_kind(path):
    """"ros1" (.bag), "mcap" (.mcap file) or "ros2" (a ROS 2 bag folder, SQLite)."""
    suffix = Path(path).suffix.lower()
    return {".bag": "ros1", ".mcap": "mcap"}.get(suffix, "ros2")


class BagWriter:
    """A bag written message by message (see the module's docstring).  path: .bag (ROS
    1), .mcap (one MCAP file) or any other name (a ROS 2 bag folder)."""

    def __init__(self, path):
        from rosbags.typesys import Stores, get_typestore

        self.path = Path(path)
        self.kind = bag_kind(self.path)
        safety.check_target(self.path, "bag_out", folder_ok=True)
        if os.path.lexists(self.path):
            raise LogError(f"{self.path} exists; csw writes a new bag, never over one "
                           "(remove it or name another)")
        folder = self.path.parent if str(self.path.parent) else Path(".")
        self.tmp = make_temporary_dir(folder, self.path.name)
        self.ros1 = self.kind == "ros1"
        self.typestore = get_typestore(Stores.ROS1_NOETIC if self.ros1 else
                                       Stores.ROS2_HUMBLE)
        try:
            if self.ros1:
                from rosbags.rosbag1 import Writer

                self.inner = self.tmp / "out.bag"
                self.writer = Writer(self.inner)
            else:
                from rosbags.rosbag2 import StoragePlugin, Writer

                self.inner = self.tmp / "bag"
                plugin = StoragePlugin.MCAP if self.kind == "mcap" else StoragePlugin.SQLITE3
                self.writer = Writer(self.inner, version=9, storage_plugin=plugin)
            self.writer.open()
        except BaseException:
            shutil.rmtree(self.tmp, ignore_errors=True)
            raise
        self.connections = {}
        self.messages = 0

    def message(self, msgtype, **fields):
        """A message of ``msgtype`` ("sensor_msgs/msg/Image") from fields named in lower
        case (ROS 1's upper-case names, D K R P T, are found too; a Header's seq is 0)."""
        cls = self.typestore.types[msgtype]
        # Longer upper-case names are a type's constants (PointField.FLOAT32), not fields.
        names = {name.lower(): name for name in cls.__dataclass_fields__
                 if name != "__msgtype__" and (not name.isupper() or len(name) == 1)}
        values = {names[key.lower()]: value for key, value in fields.items()}
        if msgtype == "std_msgs/msg/Header" and "seq" in names:
            values.setdefault("seq", 0)
        return cls(**values)

    def header(self, stamp, frame_id):
        time = self.message("builtin_interfaces/msg/Time", sec=stamp // 10**9,
                            nanosec=stamp % 10**9)
        return self.message("std_msgs/msg/Header", stamp=time, frame_id=frame_id)

    def write(self, topic, stamp, msg):
        """Add ``msg`` on ``topic`` at log time ``stamp`` (integer nanoseconds)."""
        msgtype = msg.__msgtype__
        connection = self.connections.get(topic)
        if connection is None:
            connection = self.writer.add_connection(topic, msgtype, typestore=self.typestore)
            self.connections[topic] = connection
        data = self.typestore.serialize_ros1(msg, msgtype) if self.ros1 else \
            self.typestore.serialize_cdr(msg, msgtype)
        self.writer.write(connection, int(stamp), data)
        self.messages += 1

    def close(self):
        """Finish the bag and move it into place.  Returns whether it was written (a bag
        of no messages is not)."""
        try:
            self.writer.close()
            if self.messages == 0:
                return False
            source = self.inner
            if self.kind == "mcap":
                source = next(self.inner.glob("*.mcap"))
            safety.check_target(self.path, "bag_out", folder_ok=True)
            if os.path.lexists(self.path):
                raise LogError(f"{self.path} appeared while the bag was written; the bag "
                               "was not put in its place")
            os.replace(source, self.path)
            return True
        finally:
            shutil.rmtree(self.tmp, ignore_errors=True)

    def discard(self):
        """Drop the bag: nothing is left at ``path`` nor beside it."""
        try:
            self.writer.close()
        except Exception:  # noqa: BLE001 (a broken writer: its folder goes anyway)
            pass
        shutil.rmtree(self.tmp, ignore_errors=True)


def image_message(writer, header, image):
    """A sensor_msgs/Image of a mono8, mono16, rgb8 or 32FC1 array."""
    image = np.ascontiguousarray(image)
    if image.dtype == np.float32:
        encoding = "32FC1"
    elif image.ndim == 3:
        encoding = "rgb8"
    else:
        encoding = "mono16" if image.dtype == np.uint16 else "mono8"
    height, width = image.shape[:2]
    return writer.message("sensor_msgs/msg/Image", header=header, height=height,
                          width=width, encoding=encoding, is_bigendian=0,
                          step=image.strides[0],
                          data=image.astype(image.dtype.newbyteorder("<"), copy=False)
                          .view(np.uint8).ravel())


def disparity_message(writer, header, disparity, calibration, settings):
    """stereo_msgs/DisparityImage as stereo_image_proc fills it: the disparities less the
    principal points' offset (so that Z = f T / d), invalid pixels at min_disparity - 1
    (its fixed-point invalid value, converted); f (pixels) and T (metres); the valid
    window where a full window and range fit (stereo_image_proc's formula, csw's window
    and range); the range searched, offset the same way; delta_d, the smallest step
    between two disparities (1/16 with sub-pixel disparities, as OpenCV's, else 1)."""
    offset = float(calibration.doffs)  # csw's d + doffs is stereo_image_proc's d
    dmin, dmax = settings["dmin"], settings["dmax"]
    low = dmin + offset
    values = np.where(np.isfinite(disparity), disparity + np.float32(offset),
                      np.float32(low - 1)).astype(np.float32)
    height, width = disparity.shape
    border = settings["window"] // 2
    left = dmax + border
    right = width - 1 - (border + dmin if dmin >= 0 else max(border, -dmin))
    top, bottom = border, height - 1 - border
    window = writer.message("sensor_msgs/msg/RegionOfInterest", x_offset=max(left, 0),
                            y_offset=top, width=max(right - left, 0),
                            height=max(bottom - top, 0), do_rectify=False)
    step = 1.0 if settings.get("subpixel", "none") == "none" else 1.0 / 16
    return writer.message("stereo_msgs/msg/DisparityImage", header=header,
                          image=image_message(writer, header, values),
                          f=float(calibration.focal),
                          t=float(calibration.baseline * calibration.scale_to("m")),
                          valid_window=window, min_disparity=float(low),
                          max_disparity=float(dmax + offset), delta_d=step)


def cloud_message(writer, header, points, colours):
    """sensor_msgs/PointCloud2 of points float32 (N, 3) in metres and colours uint8 (N,
    3): x, y, z and rgb (float32 fields; rgb packs 0x00RRGGBB as PCL does), 16 bytes a
    point, one row of the valid points (is_dense)."""
    record = np.empty(len(points), [("x", "<f4"), ("y", "<f4"), ("z", "<f4"),
                                    ("rgb", "<u4")])
    for i, axis in enumerate("xyz"):
        record[axis] = points[:, i]
    colours = colours.astype(np.uint32)
    record["rgb"] = colours[:, 0] << 16 | colours[:, 1] << 8 | colours[:, 2]
    fields = [writer.message("sensor_msgs/msg/PointField", name=name, offset=4 * i,
                             datatype=FLOAT32, count=1)
              for i, name in enumerate(("x", "y", "z", "rgb"))]
    return writer.message("sensor_msgs/msg/PointCloud2", header=header, height=1,
                          width=len(points), fields=fields, is_bigendian=False,
                          point_step=16, row_step=16 * len(points),
                          data=record.view(np.uint8).ravel(), is_dense=True)


def stereo_messages(writer, stamp, frame_id, disparity, calibration, settings, colour,
                    depth=False):
    """[(topic suffix, message)] of one matched frame: disparity, points2 and (with
    ``depth``) depth, a 32FC1 Image in metres (NaN invalid, as REP 118 says), each with
    the input's stamp and frame id.  colour: the rectified left frame, gray or RGB."""
    from ..camera.geometry import depth as depth_map
    from ..camera.geometry import point_cloud

    header = writer.header(stamp, frame_id)
    points, colours = point_cloud(disparity, calibration, colour, units="m")
    out = [("disparity", disparity_message(writer, header, disparity, calibration,
                                           settings)),
           ("points2", cloud_message(writer, header, points, colours))]
    if depth:
        out.append(("depth", image_message(writer, header,
                                           depth_map(disparity, calibration, units="m"))))
    return out

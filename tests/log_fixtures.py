"""Robot logs built on the fly: csw's synthetic scenes pushed through a known distorted
rig (as the rectification tests do), written with rosbags' writers (through
csw.robot.bags.BagWriter) as ROS 1 bags, ROS 2 SQLite bags or MCAP files, with a
CameraInfo topic beside each image topic; and KITTI raw drives."""

from pathlib import Path

import numpy as np
from rig_fixtures import random_rig, raw_from_rectified

import csw
from csw.camera.rectify import stereo_rectify
from csw.io.formats import write_png
from csw.robot.bags import BagWriter, image_message

SIZE = (320, 240)
DMAX = 20
STAMP0 = 1_700_000_000_000_000_000  # ns
PERIOD = 33_333_333  # 30 frames a second


def raw_scene(frames=3, seed=3, size=SIZE):
    """(rig, R1, R2, P1, P2, [(raw left, raw right)]): ``frames`` synthetic pairs of
    uint8 (H, W), each a new scene, seen through a random distorted rig."""
    rig = random_rig(np.random.default_rng(seed), size=size)
    r1, r2, p1, p2, _ = stereo_rectify(rig.k1, rig.d1, rig.k2, rig.d2, rig.size, rig.r,
                                       rig.t, alpha=0.0)
    pairs = []
    for k in range(frames):
        left, right, _, _ = csw.synthetic_pair(*size, dmax=DMAX, seed=seed + k)
        pairs.append((raw_from_rectified(left, rig.k1, rig.d1, r1, p1),
                      raw_from_rectified(right, rig.k2, rig.d2, r2, p2)))
    return rig, (r1, r2, p1, p2), pairs


def camera_info(writer, header, k, d, r, p, size):
    return writer.message("sensor_msgs/msg/CameraInfo", header=header, height=size[1],
                          width=size[0], distortion_model="plumb_bob",
                          d=np.asarray(d, np.float64).ravel(),
                          k=np.asarray(k, np.float64).ravel(),
                          r=np.asarray(r, np.float64).ravel(),
                          p=np.asarray(p, np.float64).ravel(), binning_x=0, binning_y=0,
                          roi=writer.message("sensor_msgs/msg/RegionOfInterest",
                                             x_offset=0, y_offset=0, height=0, width=0,
                                             do_rectify=False))


def write_bag(path, pairs, rig=None, rect=None, prefix="/stereo", image="image_raw",
              left_stamps=None, right_stamps=None, infos=True, encode=None):
    """A bag of ``pairs`` on PREFIX/left/IMAGE and PREFIX/right/IMAGE with CameraInfo
    beside (from ``rig`` and ``rect`` = (R1, R2, P1, P2)); stamps default to 30 a
    second; encode(writer, header, image) makes a frame's message (default: mono8)."""
    count = len(pairs)
    left_stamps = left_stamps if left_stamps is not None else \
        [STAMP0 + k * PERIOD for k in range(count)]
    right_stamps = right_stamps if right_stamps is not None else left_stamps
    encode = encode or image_message
    writer = BagWriter(path)
    for side, stamps, k_, d_, which in (("left", left_stamps, "k1", "d1", 0),
                                        ("right", right_stamps, "k2", "d2", 1)):
        for k, (pair, stamp) in enumerate(zip(pairs, stamps, strict=False)):
            if stamp is None:
                continue  # a dropped frame
            header = writer.header(stamp, f"{side}_optical")
            received = STAMP0 + k * PERIOD + 1_000_000  # the log's time: in order
            writer.write(f"{prefix}/{side}/{image}", received, encode(writer, header,
                                                                      pair[which]))
            if infos and rig is not None:
                writer.write(f"{prefix}/{side}/camera_info", received,
                             camera_info(writer, header, getattr(rig, k_),
                                         getattr(rig, d_), rect[which], rect[2 + which],
                                         rig.size))
    writer.close()
    return path


def write_rig_yaml(folder, rig, rect):
    """The rig as ROS camera_info YAML files (left, right)."""
    from rig_fixtures import ros_camera_info

    paths = []
    for side, k, d, which in (("left", rig.k1, rig.d1, 0), ("right", rig.k2, rig.d2, 1)):
        path = folder / f"{side}.yaml"
        path.write_text(ros_camera_info(k, d, rect[which], rect[2 + which], rig.size))
        paths.append(path)
    return paths


def write_pngs(folder, pairs):
    """The pairs as PNGs: folder/left/NNNNNN.png, folder/right/NNNNNN.png."""
    for side in ("left", "right"):
        (folder / side).mkdir(parents=True, exist_ok=True)
    for k, (left, right) in enumerate(pairs):
        write_png(folder / "left" / f"{k:06d}.png", left)
        write_png(folder / "right" / f"{k:06d}.png", right)
    return folder / "left", folder / "right"


def read_bag(path):
    """{topic: [(log time, message)]} of a bag, read with rosbags alone (not csw)."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    out = {}
    with AnyReader([Path(path)], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as r:
        for connection, time, raw in r.messages():
            out.setdefault(connection.topic, []).append(
                (time, r.deserialize(raw, connection.msgtype)))
    return out

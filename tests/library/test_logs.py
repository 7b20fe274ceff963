"""Robot logs in (csw.read_log, csw.match_log) and robot messages out (csw.robot.bags): bags
built on the fly from synthetic scenes pushed through a known distorted rig."""

import json
import re

import numpy as np
import pytest
from log_fixtures import (
    DMAX,
    PERIOD,
    STAMP0,
    camera_info,
    raw_scene,
    read_bag,
    write_bag,
    write_pngs,
)
from rig_fixtures import kitti_text

import csw
from csw.robot.bags import BagWriter, image_message
from csw.robot.logs import LogError, decode, demosaic, pair_stamps, read_log
from csw.scale.stream import match_log

pytest.importorskip("rosbags")


@pytest.fixture(scope="module")
def scene():
    return raw_scene(3)


# ---- pairing ---------------------------------------------------------------------------


def test_exact_pairing_pairs_equal_stamps_only():
    assert pair_stamps([10, 20, 30], [10, 21, 30], 0) == [(0, 0), (2, 2)]
    assert pair_stamps([10, 20, 30], [10, 21, 30], 1) == [(0, 0), (1, 1), (2, 2)]
    assert pair_stamps([], [1], 5) == []


def test_approximate_pairing_finds_every_true_partner_with_drops_and_jitter():
    rng = np.random.default_rng(1)
    count = 3000
    true = STAMP0 + np.arange(count, dtype=np.int64) * PERIOD
    jitter = 3_000_000  # ±3 ms on each side
    left = true + rng.integers(-jitter, jitter + 1, count)
    kept = np.sort(rng.choice(count, count - count // 50, replace=False))  # 2% dropped
    right = true[kept] + rng.integers(-jitter, jitter + 1, kept.size)
    for tolerance in (10_000_000, 30_000_000):  # 10 ms, and nearly a frame period
        pairs = pair_stamps(left, right, tolerance)
        assert len(pairs) == kept.size
        assert all(kept[j] == i for i, j in pairs)


# ---- reading ---------------------------------------------------------------------------


def test_the_three_bag_formats_give_the_same_frames_rectified_as_the_rig_does(tmp_path,
                                                                             scene):
    rig, rect, pairs = scene
    frames = {}
    for name in ("a.bag", "b.mcap", "c_ros2"):
        log = read_log(write_bag(tmp_path / name, pairs, rig, rect))
        assert (log.left_topic, log.right_topic) == ("/stereo/left/image_raw",
                                                    "/stereo/right/image_raw")
        assert not log.rectified and log.rectifier is not None
        assert log.pairs == 3 and log.unpaired == (0, 0) and log.size == rig.size
        assert log.frame_id == "left_optical" and log.calibration.units == "m"
        frames[name] = list(log)
        log.close()
    rectifier = csw.Rectifier(csw.read_rig(*write_rig(tmp_path, rig, rect)))
    for name, got in frames.items():
        assert [stamp for _, _, stamp in got] == [STAMP0 + k * PERIOD for k in range(3)]
        for (left, right, _), raw in zip(got, pairs, strict=True):
            want = rectifier.rectify(*raw)
            np.testing.assert_array_equal(left, want[0], err_msg=name)
            np.testing.assert_array_equal(right, want[1], err_msg=name)


def write_rig(folder, rig, rect):
    from log_fixtures import write_rig_yaml

    return write_rig_yaml(folder, rig, rect)


def test_match_log_gives_the_maps_of_the_pngs_with_the_rig_bit_for_bit(tmp_path, scene):
    rig, rect, pairs = scene
    bag = write_bag(tmp_path / "in.mcap", pairs, rig, rect)
    report = match_log(bag, out_dir=tmp_path / "maps", dmax=DMAX, progress=False)
    assert report["counts"] == {"ok": 3, "skipped": 0, "failed": 0}
    left, right = write_pngs(tmp_path / "png", pairs)
    yaml = write_rig(tmp_path, rig, rect)
    summary = json.loads((tmp_path / "maps" / "summary.json").read_text())
    assert [e["stamp_ns"] for e in summary["pairs"]] == [STAMP0 + k * PERIOD
                                                         for k in range(3)]
    assert summary["log"]["rectified_by_csw"] and summary["log"]["unpaired"] == \
        {"left": 0, "right": 0}
    jobs = csw.jobs_from_folders(left, right)
    csw.match_many(jobs, tmp_path / "png_maps", rig=csw.read_rig(*yaml), dmax=DMAX,
                   progress=False)
    for k in range(3):
        np.testing.assert_array_equal(
            csw.read_disparity(tmp_path / "maps" / f"{k:06d}.pfm"),
            csw.read_disparity(tmp_path / "png_maps" / f"{k:06d}.pfm"))


def test_bag_out_holds_disparity_cloud_and_depth_with_the_input_s_stamps(tmp_path, scene):
    rig, rect, pairs = scene
    bag = write_bag(tmp_path / "in.bag", pairs[:2], rig, rect)
    log = read_log(bag, colour=True)
    # accurate: whole-pixel disparities (delta_d 1) and a 9x9 window's valid window
    match_log(log, out_dir=tmp_path / "maps", bag_out=tmp_path / "out.mcap", depth=True,
              dmax=DMAX, progress=False, preset="accurate")
    topics = read_bag(tmp_path / "out.mcap")
    assert sorted(topics) == ["/stereo/depth", "/stereo/disparity", "/stereo/points2"]
    calibration = log.calibration
    for k in range(2):
        stamp = STAMP0 + k * PERIOD
        disparity = csw.read_disparity(tmp_path / "maps" / f"{k:06d}.pfm")
        time, msg = topics["/stereo/disparity"][k]
        assert time == stamp and msg.header.frame_id == "left_optical"
        assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == stamp
        assert msg.f == pytest.approx(calibration.focal)
        assert msg.t == pytest.approx(calibration.baseline)  # metres
        assert (msg.min_disparity, msg.max_disparity, msg.delta_d) == (0.0, DMAX, 1.0)
        window = msg.valid_window  # stereo_image_proc's: a whole window and range fit
        assert (window.x_offset, window.y_offset) == (DMAX + 4, 4)
        assert (window.width, window.height) == (rig.size[0] - 1 - 4 - DMAX - 4,
                                                 rig.size[1] - 1 - 8)
        image = msg.image
        assert (image.encoding, image.width, image.height) == ("32FC1", *rig.size)
        values = image.data.view("<f4").reshape(rig.size[1], rig.size[0])
        finite = np.isfinite(disparity)
        np.testing.assert_array_equal(values[finite], disparity[finite])
        assert (values[~finite] == -1).all()  # min_disparity - 1, stereo_image_proc's
        _, cloud = topics["/stereo/points2"][k]
        assert [(f.name, f.offset, f.datatype) for f in cloud.fields] == \
            [("x", 0, 7), ("y", 4, 7), ("z", 8, 7), ("rgb", 12, 7)]
        points = cloud.data.view("<f4").reshape(-1, 4)[:, :3]
        want, _ = csw.point_cloud(disparity, calibration, units="m")
        np.testing.assert_array_equal(points, want)
        assert cloud.header.frame_id == "left_optical" and cloud.width == len(want)
        _, depth = topics["/stereo/depth"][k]
        z = depth.data.view("<f4").reshape(rig.size[1], rig.size[0])
        np.testing.assert_array_equal(z, csw.depth(disparity, calibration, units="m"))
    log.close()


def test_rectified_topics_are_matched_as_they_are_with_the_projection_matrices(tmp_path,
                                                                               scene):
    rig, rect, pairs = scene
    bag = write_bag(tmp_path / "in.db3", pairs[:1], rig, rect, image="image_rect")
    log = read_log(bag)
    assert log.rectified and log.rectifier is None
    (left, right, _), = list(log)
    np.testing.assert_array_equal(left, pairs[0][0])  # as it is
    p1, p2 = rect[2], rect[3]
    assert log.calibration.focal == pytest.approx(p1[0, 0])
    assert log.calibration.baseline == pytest.approx(-p2[0, 3] / p2[0, 0])
    log.close()


def test_a_rig_given_replaces_the_log_s_calibration(tmp_path, scene):
    rig, rect, pairs = scene
    bag = write_bag(tmp_path / "in.mcap", pairs[:1], rig, rect, infos=False)
    with pytest.raises(LogError, match="--rig"):
        read_log(bag)
    log = read_log(bag, rig=csw.read_rig(*write_rig(tmp_path, rig, rect)))
    assert log.rectifier is not None and len(list(log)) == 1
    log.close()


# ---- encodings ---------------------------------------------------------------------------


def encoded(encoding):
    """encode(writer, header, gray) for a bag: the gray frame in ``encoding``."""
    def encode(writer, header, gray):
        rgb = np.stack([gray, gray // 2, 255 - gray], axis=2)
        pixels = {"mono8": gray, "mono16": gray.astype(np.uint16) * 257, "rgb8": rgb,
                  "bgr8": rgb[..., ::-1], "rgba8": np.dstack([rgb, gray]),
                  "bgra8": np.dstack([rgb[..., ::-1], gray])}[encoding]
        pixels = np.ascontiguousarray(pixels)
        return writer.message("sensor_msgs/msg/Image", header=header,
                              height=gray.shape[0], width=gray.shape[1], encoding=encoding,
                              is_bigendian=0, step=pixels.strides[0],
                              data=pixels.view(np.uint8).ravel())
    return encode


@pytest.mark.parametrize("encoding", ["mono8", "mono16", "rgb8", "bgr8", "rgba8", "bgra8"])
def test_encodings_decode_to_the_gray_csw_reads_from_files(tmp_path, encoding):
    gray = np.random.default_rng(0).integers(0, 256, (24, 32)).astype(np.uint8)
    bag = write_bag(tmp_path / "e.mcap", [(gray, gray)], image="image_rect",
                    encode=encoded(encoding))
    (left, _, _), = list(read_log(bag))
    rgb = np.stack([gray, gray // 2, 255 - gray], axis=2)
    want = {"mono8": gray, "mono16": gray.astype(np.uint16) * 257}.get(encoding,
                                                                       csw.io.luma(rgb))
    np.testing.assert_array_equal(left, want)


def test_a_bayer_topic_is_demosaiced_and_a_jpeg_topic_decoded(tmp_path):
    import io

    from PIL import Image

    gray = np.random.default_rng(2).integers(0, 256, (24, 32)).astype(np.uint8)

    def bayer(writer, header, image):
        return writer.message("sensor_msgs/msg/Image", header=header, height=24, width=32,
                              encoding="bayer_grbg8", is_bigendian=0, step=32,
                              data=image.ravel())

    bag = write_bag(tmp_path / "bayer.mcap", [(gray, gray)], image="image_rect",
                    encode=bayer)
    (left, _, _), = list(read_log(bag))
    np.testing.assert_array_equal(left, csw.io.luma(demosaic(gray, "grbg")))

    def jpeg(writer, header, image):
        buffer = io.BytesIO()
        Image.fromarray(np.dstack([image, image // 3, 255 - image])).save(buffer, "JPEG")
        return writer.message("sensor_msgs/msg/CompressedImage", header=header,
                              format="rgb8; jpeg compressed bgr8",
                              data=np.frombuffer(buffer.getvalue(), np.uint8))

    bag = write_bag(tmp_path / "jpeg.bag", [(gray, gray)], prefix="/cam",
                    image="image_rect/compressed", encode=jpeg)
    log = read_log(bag)
    assert log.left_topic == "/cam/left/image_rect/compressed" and log.rectified
    (left, _, _), = list(log)
    buffer = io.BytesIO()
    Image.fromarray(np.dstack([gray, gray // 3, 255 - gray])).save(buffer, "JPEG")
    want = np.asarray(Image.open(io.BytesIO(buffer.getvalue())).convert("RGB"))
    np.testing.assert_array_equal(left, csw.io.luma(want))


def test_bayer_frames_are_demosaiced():
    rgb = np.zeros((8, 10, 3), np.uint8)
    rgb[...] = (200, 100, 50)
    for pattern in ("rggb", "bggr", "gbrg", "grbg"):
        mosaic = np.empty((8, 10), np.uint8)
        for k, letter in enumerate(pattern):
            mosaic[k // 2::2, k % 2::2] = rgb[k // 2::2, k % 2::2, "rgb".index(letter)]
        np.testing.assert_array_equal(demosaic(mosaic, pattern), rgb)
    ramp = np.tile(np.arange(0, 200, 10, dtype=np.uint16), (6, 1))  # bilinear keeps a ramp
    out = demosaic(ramp, "rggb")
    np.testing.assert_array_equal(out[:, 1:-1, 0], ramp[:, 1:-1])


def test_compressed_frames_decode_and_an_unknown_encoding_is_one_line(tmp_path):
    import io

    from PIL import Image

    gray = np.random.default_rng(1).integers(0, 256, (24, 32)).astype(np.uint8)
    buffer = io.BytesIO()
    Image.fromarray(gray).save(buffer, format="PNG")
    writer = BagWriter(tmp_path / "unused.mcap")
    header = writer.header(STAMP0, "cam")
    msg = writer.message("sensor_msgs/msg/CompressedImage", header=header,
                         format="mono8; png compressed ",
                         data=np.frombuffer(buffer.getvalue(), np.uint8))
    got, _ = decode(msg)
    np.testing.assert_array_equal(got, gray)
    with pytest.raises(LogError, match="compressed format 'h264'"):
        decode(replace_field(msg, format="h264"))
    raw = image_message(writer, header, gray)
    with pytest.raises(LogError, match="encoding 'yuv422' is not one csw reads"):
        decode(replace_field(raw, encoding="yuv422"), topic="/cam/left/image_raw")
    with pytest.raises(LogError, match="needs 768 bytes"):
        decode(replace_field(raw, data=raw.data[:100]))
    writer.discard()
    assert list(tmp_path.iterdir()) == []


def test_a_compressed_frame_meets_the_pixel_limit_and_damage_says_what(tmp_path,
                                                                       monkeypatch):
    import io

    from PIL import Image

    gray = np.zeros((24, 32), np.uint8)
    buffer = io.BytesIO()
    Image.fromarray(gray).save(buffer, format="PNG")
    writer = BagWriter(tmp_path / "unused.mcap")
    msg = writer.message("sensor_msgs/msg/CompressedImage",
                         header=writer.header(STAMP0, "cam"), format="png",
                         data=np.frombuffer(buffer.getvalue(), np.uint8))
    monkeypatch.setenv("CSW_MAX_PIXELS", str(24 * 32 - 1))  # csw's limit, not Pillow's
    with pytest.raises(LogError, match="32x24, 768 pixels, more than the safety limit"):
        decode(msg)
    monkeypatch.delenv("CSW_MAX_PIXELS")
    with pytest.raises(LogError, match=r"can't be decoded \(its bytes are no png image\)$"):
        decode(replace_field(msg, data=np.frombuffer(b"not a png at all", np.uint8)))
    writer.discard()


def replace_field(msg, **fields):
    from dataclasses import replace

    return replace(msg, **fields)


# ---- bad input ---------------------------------------------------------------------------


def test_stamps_out_of_order_and_no_pairs_fail_before_any_output(tmp_path, scene):
    rig, rect, pairs = scene
    stamps = [STAMP0 + 2 * PERIOD, STAMP0, STAMP0 + PERIOD]
    bag = write_bag(tmp_path / "back.mcap", pairs, rig, rect, left_stamps=stamps,
                    right_stamps=sorted(stamps))
    with pytest.raises(LogError, match="goes back"):
        match_log(bag, out_dir=tmp_path / "maps", dmax=DMAX, progress=False)
    off = [STAMP0 + k * PERIOD + 2_000_000 for k in range(3)]
    bag = write_bag(tmp_path / "off.mcap", pairs, rig, rect, right_stamps=off)
    with pytest.raises(LogError, match="--stamp-tolerance"):
        match_log(bag, out_dir=tmp_path / "maps", dmax=DMAX, progress=False)
    log = read_log(bag, tolerance=0.005)
    assert log.pairs == 3
    log.close()
    assert not (tmp_path / "maps").exists()


def test_a_truncated_bag_and_a_missing_topic_are_one_line(tmp_path, scene):
    rig, rect, pairs = scene
    for name in ("t.bag", "t.mcap"):
        bag = write_bag(tmp_path / name, pairs, rig, rect)
        data = bag.read_bytes()
        bag.write_bytes(data[:len(data) // 2])
        with pytest.raises(LogError) as caught:
            read_log(bag)
        assert "\n" not in str(caught.value) and name in str(caught.value)
    bag = write_bag(tmp_path / "ok.mcap", pairs[:1], rig, rect)
    with pytest.raises(LogError, match="no topic /nope .*image topics: /stereo/left"):
        read_log(bag, "/nope")
    with pytest.raises(LogError, match="holds sensor_msgs/msg/CameraInfo, not images"):
        read_log(bag, "/stereo/left/camera_info")


def test_frames_of_different_sizes_are_refused(tmp_path):
    small, large = np.zeros((20, 30), np.uint8), np.zeros((20, 40), np.uint8)
    bag = write_bag(tmp_path / "s.mcap", [(small, large)], image="image_rect")
    with pytest.raises(LogError, match="differ in size"):
        read_log(bag)


def test_a_bad_frame_is_reported_and_the_rest_go_on_and_nothing_partial_is_left(tmp_path,
                                                                               scene):
    rig, rect, pairs = scene

    def encode(writer, header, gray):  # the second left frame's data cut short
        msg = image_message(writer, header, gray)
        if header.stamp.nanosec == PERIOD and gray is pairs[1][0]:
            msg = replace_field(msg, data=msg.data[:10])
        return msg

    bag = write_bag(tmp_path / "bad.mcap", pairs, rig, rect, encode=encode)
    report = match_log(bag, out_dir=tmp_path / "maps", bag_out=tmp_path / "out",
                       dmax=DMAX, progress=False)
    assert report["counts"] == {"ok": 2, "skipped": 0, "failed": 1}
    assert "frame 1 " in report["failed"][0]["error"]
    assert sorted(p.name for p in (tmp_path / "maps").iterdir()) == \
        ["000000.pfm", "000002.pfm", "summary.json"]
    assert len(read_bag(tmp_path / "out")["/stereo/disparity"]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.mcap", "maps", "out"]


def test_an_interrupted_run_keeps_its_bag_whole_and_says_so(tmp_path, scene):
    rig, rect, pairs = scene
    bag = write_bag(tmp_path / "in.bag", pairs, rig, rect)

    def stop(done, total):
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        match_log(bag, out_dir=tmp_path / "maps", bag_out=tmp_path / "out.bag", dmax=DMAX,
                  progress=stop, in_flight=1)
    summary = json.loads((tmp_path / "maps" / "summary.json").read_text())
    assert summary["interrupted"] and summary["counts"]["ok"] == 2
    assert len(read_bag(tmp_path / "out.bag")["/stereo/points2"]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.bag", "maps", "out.bag"]


def test_an_existing_bag_is_never_written_over(tmp_path, scene):
    rig, rect, pairs = scene
    bag = write_bag(tmp_path / "in.mcap", pairs[:1], rig, rect)
    (tmp_path / "out.mcap").write_bytes(b"mine")
    with pytest.raises(csw.OptionError, match="exists"):
        match_log(bag, bag_out=tmp_path / "out.mcap", dmax=DMAX, progress=False)
    with pytest.raises(csw.OptionError, match="input"):
        match_log(bag, bag_out=bag, dmax=DMAX, progress=False)
    assert (tmp_path / "out.mcap").read_bytes() == b"mine"


# ---- KITTI raw drives --------------------------------------------------------------------


def kitti_drive(tmp_path, rig, rect, pairs, kind="sync", stamps=None):
    date = tmp_path / "2011_09_26"
    drive = date / f"2011_09_26_drive_0001_{kind}"
    date.mkdir()
    r1, r2, p1, p2 = rect
    p2_from_0 = p2.copy()
    (date / "calib_cam_to_cam.txt").write_text(kitti_text(rig, rect=(r1, r2, p1, p2_from_0)))
    lines = stamps or [f"2011-09-26 13:02:25.{k:09d}" for k in range(0, len(pairs) * 10**8,
                                                                       10**8)]
    for camera, which in (("image_02", 0), ("image_03", 1)):
        write_folder = drive / camera / "data"
        write_folder.mkdir(parents=True)
        for k, pair in enumerate(pairs):
            csw.io.write_png(write_folder / f"{k:010d}.png", pair[which])
        (drive / camera / "timestamps.txt").write_text("\n".join(lines) + "\n")
    return drive


def test_a_kitti_drive_reads_its_calibration_and_timestamps(tmp_path, scene):
    rig, rect, pairs = scene
    drive = kitti_drive(tmp_path, rig, rect, pairs, kind="extract")
    log = read_log(drive)
    assert not log.rectified and log.pairs == 3
    got = list(log)
    day = 1316995200  # 2011-09-26 00:00 UTC
    assert got[1][2] == (day + 13 * 3600 + 2 * 60 + 25) * 10**9 + 10**8
    want = log.rectifier.rectify(*pairs[0])
    np.testing.assert_array_equal(got[0][0], want[0])
    report = match_log(drive, out_dir=tmp_path / "maps", dmax=DMAX, progress=False)
    assert report["counts"]["ok"] == 3


def test_a_kitti_sync_drive_is_rectified_already(tmp_path, scene):
    rig, rect, pairs = scene
    drive = kitti_drive(tmp_path, rig, rect, pairs[:1])
    log = read_log(drive)
    assert log.rectified and log.rectifier is None
    assert log.calibration.focal == pytest.approx(rect[2][0, 0])
    np.testing.assert_array_equal(next(iter(log))[0], pairs[0][0])


@pytest.mark.parametrize("second, message", [
    ("9999-12-31 23:59:59.999999999", "line 2's stamp 9999-12-31 is outside 1970-2262"),
    ("2011-99-99 13:02:25.1", "line 2 is not a stamp (time data '2011-99-99'"),
    ("0000-09-26 13:02:25.1", "line 2 is not a stamp (year 0 is out of range"),
])
def test_a_kitti_stamp_that_is_no_time_names_its_file_and_line(tmp_path, scene, second,
                                                               message):
    rig, rect, pairs = scene
    drive = kitti_drive(tmp_path, rig, rect, pairs[:2],
                        stamps=["2011-09-26 13:02:25.0", second])
    with pytest.raises(LogError, match=re.escape(message)) as info:
        list(read_log(drive))
    assert "timestamps.txt" in str(info.value)


def test_camera_info_fields_are_read_from_ros1_and_ros2_alike(tmp_path, scene):
    rig, rect, pairs = scene
    logs = [read_log(write_bag(tmp_path / name, pairs[:1], rig, rect))
            for name in ("a.bag", "b.mcap")]
    for log in logs:
        np.testing.assert_allclose(log.rig.k1, rig.k1)
        np.testing.assert_allclose(log.rig.d2, rig.d2)
        log.close()
    writer = BagWriter(tmp_path / "x.bag")
    msg = camera_info(writer, writer.header(0, "c"), rig.k1, rig.d1, rect[0], rect[2],
                      rig.size)
    assert msg.K.shape == (9,)  # ROS 1's upper-case names
    writer.discard()

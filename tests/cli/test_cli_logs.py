"""``csw match LOG`` and ``csw info LOG``: what a robotics user types, what it writes, and
one line for each bad log."""

import json

import numpy as np
import pytest
from click.testing import CliRunner
from log_fixtures import (
    DMAX,
    PERIOD,
    STAMP0,
    raw_scene,
    read_bag,
    write_bag,
    write_rig_yaml,
)

from csw.robot.bags import image_message
from csw_cli.main import cli

pytest.importorskip("rosbags")  # in the test extras: skipped only outside them


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def one_line_error(result, code=2):
    lines = result.output.strip().splitlines()
    return result.exit_code == code and len(lines) == 1 and \
        lines[0].startswith("Error:") and "Traceback" not in result.output


@pytest.fixture(scope="module")
def scene():
    return raw_scene(2)


def test_info_lists_the_image_topics(tmp_path, scene):
    rig, rect, pairs = scene
    bag = write_bag(tmp_path / "in.bag", pairs, rig, rect)
    result = invoke("info", bag)
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert any(line.split()[:5] == ["/stereo/left/image_raw", "sensor_msgs/Image", "2",
                                    "mono8", "320x240"] for line in lines)
    rows = json.loads(invoke("info", bag, "--format", "json").output)
    assert [r["topic"] for r in rows] == ["/stereo/left/image_raw", "/stereo/right/image_raw"]
    assert rows[0]["rate"] == pytest.approx(1e9 / PERIOD, rel=1e-3)
    assert one_line_error(invoke("info", tmp_path / "none.mcap"))


def test_match_a_bag_writes_maps_a_summary_and_a_bag_of_messages(tmp_path, scene):
    rig, rect, pairs = scene
    bag = write_bag(tmp_path / "in.mcap", pairs, rig, rect)
    result = invoke("match", bag, "-O", tmp_path / "maps", "--dmax", DMAX, "--bag-out",
                    tmp_path / "out.bag", "--bag-depth")
    assert result.exit_code == 0, result.output
    assert "2 pairs (0 left and 0 right frames unpaired; rectified with the rig of" in \
        result.output
    summary = json.loads((tmp_path / "maps" / "summary.json").read_text())
    assert [e["stamp"] for e in summary["pairs"]] == ["1700000000.000000000",
                                                      "1700000000.033333333"]
    assert (tmp_path / "out.bag").is_file() and summary["bag_written"] is True
    assert "wrote" in result.output.splitlines()[-1]
    # The cloud's points are csw cloud's on the same map, with the log's calibration.
    from plyfile import PlyData

    from csw.robot.logs import read_log

    c = read_log(bag).calibration
    result = invoke("cloud", tmp_path / "maps" / "000001.pfm", "-o", tmp_path / "c.ply",
                    "--focal", repr(c.focal), "--baseline", repr(c.baseline), "--cx",
                    repr(c.cx), "--cy", repr(c.cy), "--doffs", repr(c.doffs))
    assert result.exit_code == 0, result.output
    vertex = PlyData.read(tmp_path / "c.ply")["vertex"]
    want = np.stack([vertex["x"], vertex["y"], vertex["z"]], axis=1)
    _, cloud = read_bag(tmp_path / "out.bag")["/stereo/points2"][1]
    np.testing.assert_array_equal(cloud.data.view("<f4").reshape(-1, 4)[:, :3], want)


def test_topics_by_name_a_tolerance_and_a_rig_from_files(tmp_path, scene):
    rig, rect, pairs = scene
    right = [STAMP0 + k * PERIOD + 3_000_000 for k in range(2)]
    bag = write_bag(tmp_path / "in", pairs, rig, rect, prefix="/cam", infos=False,
                    right_stamps=right)
    yaml = write_rig_yaml(tmp_path, rig, rect)
    args = ["match", bag, "-O", tmp_path / "maps", "--dmax", DMAX, "--left-topic",
            "/cam/left/image_raw", "--right-topic", "/cam/right/image_raw"]
    result = invoke(*args, "--rig", yaml[0], "--rig", yaml[1])
    assert one_line_error(result) and "--stamp-tolerance" in result.output
    result = invoke(*args, "--stamp-tolerance", 0.005)
    assert one_line_error(result) and "give the rig with --rig" in result.output
    result = invoke(*args, "--stamp-tolerance", 0.005, "--rig", yaml[0], "--rig", yaml[1])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in (tmp_path / "maps").iterdir()) == \
        ["000000.pfm", "000001.pfm", "summary.json"]


def test_each_bad_log_is_one_line_and_writes_nothing(tmp_path, scene):
    rig, rect, pairs = scene
    bags = {}

    def yuv(writer, header, gray):
        msg = image_message(writer, header, gray)
        from dataclasses import replace
        return replace(msg, encoding="yuv422")

    bags["encoding 'yuv422' is not one csw reads"] = write_bag(
        tmp_path / "yuv.mcap", pairs, rig, rect, encode=yuv)
    bags["goes back"] = write_bag(tmp_path / "back.bag", pairs, rig, rect,
                                  left_stamps=[STAMP0 + PERIOD, STAMP0])
    bags["differ in size"] = write_bag(tmp_path / "size.mcap",
                                       [(pairs[0][0], pairs[0][1][:, :100])], rig, rect)
    damaged = write_bag(tmp_path / "cut.mcap", pairs, rig, rect)
    damaged.write_bytes(damaged.read_bytes()[:5000])
    bags["not a readable log, or damaged"] = damaged
    (tmp_path / "folder").mkdir()
    (tmp_path / "folder" / "metadata.yaml").write_text("not: a bag\n")
    bags["not a readable log"] = tmp_path / "folder"
    for message, bag in bags.items():
        result = invoke("match", bag, "-O", tmp_path / "maps", "--dmax", DMAX, "--bag-out",
                        tmp_path / "out.mcap")
        assert one_line_error(result), (message, result.output)
        assert message in result.output
    result = invoke("match", bags["goes back"], "-O", tmp_path / "maps", "--left-topic",
                    "/stereo/left/image")
    assert one_line_error(result) and "no topic /stereo/left/image" in result.output
    names = {p.name for p in tmp_path.iterdir()}
    assert "maps" not in names and "out.mcap" not in names
    assert not [n for n in names if n.startswith(".")]


def test_log_options_belong_to_logs(tmp_path, scene):
    rig, rect, pairs = scene
    bag = write_bag(tmp_path / "in.mcap", pairs[:1], rig, rect)
    result = invoke("match", bag, "-o", tmp_path / "d.pfm")
    assert result.exit_code == 2 and "not for a log" in result.output
    result = invoke("match", bag)
    assert result.exit_code == 2 and "--bag-out" in result.output
    result = invoke("match", tmp_path / "l.png", tmp_path / "r.png", "-o", tmp_path / "d.pfm",
                    "--bag-out", tmp_path / "o.mcap")
    assert result.exit_code == 2 and "--bag-out is for a log" in result.output
    result = invoke("match", bag, "-O", tmp_path / "maps", "--bag-depth")
    assert result.exit_code == 2 and "--bag-depth needs --bag-out" in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.mcap"]

"""``csw match - --sbs``: a live side-by-side stream fed through a pipe, matched as it
comes, or with --latest matching the newest frame and dropping the rest (a V4L2 camera,
/dev/video0, goes the same way through PyAV's v4l2 input; none is here to test)."""

import json
import statistics
import subprocess

import pytest
from test_cli_video import CSW, invoke, sbs_mjpeg

pytest.importorskip("av")

FRAMES = 12


def run_pipe(video, *args):
    return subprocess.run([*CSW, "match", "-", "--sbs", "--dmax", "15", *map(str, args)],
                          input=video.read_bytes(), capture_output=True, timeout=300)


@pytest.mark.slow
def test_a_stream_on_standard_input_is_matched_frame_by_frame(tmp_path):
    video = sbs_mjpeg(tmp_path / "sbs.mjpeg", FRAMES)
    done = run_pipe(video, "-O", tmp_path / "maps")
    assert done.returncode == 0, done.stderr.decode()
    summary = json.loads((tmp_path / "maps" / "summary.json").read_text())
    assert summary["counts"]["ok"] == FRAMES and "dropped" not in summary
    assert 0 < summary["latency_ms"]["median"] <= summary["latency_ms"]["p99"]
    # Each frame's own, from its arrival to its map written: the run's are their median
    each = [entry["latency_ms"] for entry in summary["pairs"]]
    assert len(each) == FRAMES and min(each) > 0
    assert abs(statistics.median(each) - summary["latency_ms"]["median"]) <= 0.011


@pytest.mark.slow
def test_latest_drops_frames_rather_than_fall_behind(tmp_path):
    video = sbs_mjpeg(tmp_path / "sbs.mjpeg", FRAMES)
    done = run_pipe(video, "-O", tmp_path / "maps", "--latest")
    assert done.returncode == 0, done.stderr.decode()
    summary = json.loads((tmp_path / "maps" / "summary.json").read_text())
    matched = [entry["frame"] for entry in summary["pairs"]]
    # A pipe delivers faster than any camera: frames were dropped, every frame is either
    # matched or counted, the ones matched in order, the last always among them.
    assert summary["dropped"] > 0 and len(matched) + summary["dropped"] == FRAMES
    assert matched == sorted(matched) and matched[-1] == FRAMES - 1
    assert b"dropped to keep up" in done.stderr


def test_a_live_source_needs_sbs_and_latest_needs_a_live_source(tmp_path):
    result = invoke("match", "-", "-O", tmp_path / "maps")
    assert result.exit_code == 2 and "give --sbs" in result.output
    video = sbs_mjpeg(tmp_path / "sbs.mjpeg", 2)
    result = invoke("match", video, "--sbs", "-O", tmp_path / "maps", "--latest")
    assert result.exit_code == 2 and "--latest is for a live source" in result.output
    assert not (tmp_path / "maps").exists()

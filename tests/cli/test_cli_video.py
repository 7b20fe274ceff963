"""``csw match`` on video and ``csw synth --frames``: what a user types, what it writes."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from child import interruptible
from click.testing import CliRunner
from video_fixtures import damage_jpeg_frame, write_frames

import csw
from csw.data.synth import render
from csw_cli.main import cli

av = pytest.importorskip("av")  # in the test extras: skipped only outside them

CSW = [sys.executable, "-c", "from csw_cli.main import main; main()"]


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def sbs_mjpeg(path, count, width=96, height=64, dmax=15, distinct=6):
    """A side-by-side MJPEG video of the moving synthetic scene (``distinct`` frames
    rendered, repeated to ``count``)."""
    pairs = [np.concatenate(render(width, height, dmax, 5, phase=i / distinct)[:2], axis=1)
             for i in range(distinct)]
    return write_frames(path, [pairs[i % distinct] for i in range(count)])


def one_line_error(result, code=2):
    lines = result.output.strip().splitlines()
    return result.exit_code == code and len(lines) == 1 and "Traceback" not in result.output


def test_synth_video_then_match_it(tmp_path):
    result = invoke("synth", tmp_path / "seq", "--size", "128x96", "--dmax", 20, "--frames",
                    5, "--video")
    assert result.exit_code == 0, result.output
    assert sorted(os.listdir(tmp_path / "seq")) == ["calib.txt", "gt", "sbs.mp4"]
    result = invoke("match", tmp_path / "seq" / "sbs.mp4", "--sbs", "-O", tmp_path / "maps",
                    "--dmax", 20, "--preview-video", tmp_path / "view.mp4")
    assert result.exit_code == 0, result.output
    last = [line for line in result.output.splitlines() if "frames/s" in line][-1]
    assert last.startswith("5 frames (128x96, d 0..20): 5 matched, 0 skipped, 0 failed;")
    assert "latency median" in last and "p99" in last
    assert sorted(os.listdir(tmp_path / "maps")) == \
        [f"{i:06d}.pfm" for i in range(5)] + ["summary.json"]
    summary = json.loads((tmp_path / "maps" / "summary.json").read_text())
    assert summary["frames"] == 5 and summary["frames_per_second"] > 0
    assert summary["latency_ms"]["median"] > 0
    assert (tmp_path / "view.mp4").stat().st_size > 0


def test_synth_frames_writes_image_folders_that_match_as_a_batch(tmp_path):
    assert invoke("synth", tmp_path / "seq", "--size", "96x64", "--dmax", 15, "--frames",
                  3).exit_code == 0
    assert sorted(os.listdir(tmp_path / "seq" / "left")) == \
        ["000000.png", "000001.png", "000002.png"]
    result = invoke("match", tmp_path / "seq" / "left", tmp_path / "seq" / "right", "-O",
                    tmp_path / "maps", "--dmax", 15)
    assert result.exit_code == 0, result.output
    assert "3 matched" in result.output


@pytest.mark.parametrize("args, says", [
    (["-o", "d.pfm"], "--output is not for video"),
    (["--cloud", "c.ply"], "--cloud is not for video"),
    ([], "give --output-dir"),
    (["-O", "maps", "--preview-sbs"], "--preview-sbs needs --preview-video"),
    (["-O", "maps", "other.mp4"], "drop RIGHT"),
])
def test_video_usage_errors_are_one_line(tmp_path, args, says):
    video = sbs_mjpeg(tmp_path / "v.avi", 2)
    os.chdir(tmp_path)
    result = invoke("match", video, "--sbs", *args)
    assert result.exit_code == 2 and says in result.output, result.output
    assert sorted(os.listdir(tmp_path)) == ["v.avi"]


def test_two_videos_need_both_and_a_preview_needs_video_input(tmp_path, lr_pngs):
    video = sbs_mjpeg(tmp_path / "v.avi", 2)
    result = invoke("match", video, "-O", tmp_path / "maps")
    assert result.exit_code == 2 and "--sbs" in result.output
    result = invoke("match", lr_pngs / "l.png", lr_pngs / "r.png", "-o", tmp_path / "d.pfm",
                    "--preview-video", tmp_path / "v.mp4")
    assert result.exit_code == 2 and "for video input" in result.output


def test_a_file_that_is_not_a_video_writes_nothing(tmp_path):
    (tmp_path / "fake.mp4").write_text("hello")
    result = invoke("match", tmp_path / "fake.mp4", "--sbs", "-O", tmp_path / "maps",
                    "--preview-video", tmp_path / "v.mp4")
    assert one_line_error(result) and "not a readable video" in result.output
    assert sorted(os.listdir(tmp_path)) == ["fake.mp4"]


def test_a_damaged_frame_fails_alone_and_exits_1(tmp_path):
    video = sbs_mjpeg(tmp_path / "v.avi", 6)
    damage_jpeg_frame(video, 2)
    result = invoke("match", video, "--sbs", "-O", tmp_path / "maps", "--dmax", 15)
    assert result.exit_code == 1, result.output
    assert "5 matched, 0 skipped, 1 failed" in result.output
    assert "failed: frame 2: " in result.output and "Traceback" not in result.output
    assert not (tmp_path / "maps" / "000002.pfm").exists()
    assert (tmp_path / "maps" / "000005.pfm").exists()


def test_a_video_cut_short_says_how_many_frames_its_header_gave(tmp_path):
    video = sbs_mjpeg(tmp_path / "v.avi", 8)
    data = video.read_bytes()
    video.write_bytes(data[:len(data) // 2])
    result = invoke("match", video, "--sbs", "-O", tmp_path / "maps", "--dmax", 15)
    done = len(list((tmp_path / "maps").glob("0*.pfm")))
    assert result.exit_code == 0 and 0 < done < 8, result.output
    assert f"csw: {video}: its header says 8 frames; {done} could be read" in result.output


def test_no_frame_matched_writes_no_preview_and_says_none(tmp_path):
    video = sbs_mjpeg(tmp_path / "v.avi", 3)
    damage_jpeg_frame(video, 0)
    damage_jpeg_frame(video, 0)  # frame 1, now the first with a start-of-image marker
    data = bytearray(video.read_bytes())  # the last frame: up to its end-of-image marker
    last, end = data.rfind(b"\xff\xd8"), data.rfind(b"\xff\xd9")
    data[last:end] = bytes(end - last)
    video.write_bytes(bytes(data))
    result = invoke("match", video, "--sbs", "--preview-video", tmp_path / "p.mp4",
                    "--dmax", 15)
    assert result.exit_code == 1 and "0 matched, 0 skipped, 3 failed" in result.output
    assert "wrote" not in result.output and not (tmp_path / "p.mp4").exists()


@pytest.mark.slow
def test_ctrl_c_keeps_the_frames_written_and_marks_the_summary(tmp_path):
    sbs_mjpeg(tmp_path / "v.avi", 3000, width=320, height=240, dmax=31)
    command = [*CSW, "match", "v.avi", "--sbs", "--dmax", "31", "--threads", "1"]
    # Compiled (or loaded) first, on a short run, so that the run below is matching
    # when the signal comes.
    sbs_mjpeg(tmp_path / "s.avi", 2, width=320, height=240, dmax=31)
    subprocess.run([*command[:4], "s.avi", *command[5:], "-O", "warm"], cwd=tmp_path,
                   check=True, capture_output=True)
    process = interruptible([*command, "-O", "maps", "--preview-video", "view.mp4"],
                            cwd=tmp_path, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while time.time() < deadline and len(os.listdir(tmp_path / "maps")
                                         if (tmp_path / "maps").exists() else []) < 5:
        time.sleep(0.2)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    assert "Traceback" not in stderr
    summary = json.loads((tmp_path / "maps" / "summary.json").read_text())
    assert summary["interrupted"] is True
    done = summary["counts"]["ok"]
    assert 5 <= done < 3000
    maps = sorted(p for p in os.listdir(tmp_path / "maps") if p.endswith(".pfm"))
    assert maps == [f"{i:06d}.pfm" for i in range(done)]
    frames = sum(1 for _ in av.open(str(tmp_path / "view.mp4")).decode(video=0))
    assert frames == done
    temporaries = [p for folder in (tmp_path, tmp_path / "maps")
                   for p in os.listdir(folder) if p.startswith(".csw-tmp")]
    assert temporaries == []


def two_scene_sbs(path, width=192, height=96):
    """A side-by-side MJPEG video cutting between a shallow scene (d up to 12) and a deep
    one (up to 48), two frames each."""
    shallow, deep = (np.concatenate(render(width, height, dmax, 5)[:2], axis=1)
                     for dmax in (12, 48))
    return write_frames(path, [shallow, shallow, deep, deep])


def test_range_each_frame_finds_every_frames_own_range(tmp_path):
    video = two_scene_sbs(tmp_path / "v.avi")
    result = invoke("match", video, "--sbs", "-O", tmp_path / "kept")
    assert result.exit_code == 0, result.output
    kept = json.loads((tmp_path / "kept" / "summary.json").read_text())
    assert all("range" not in entry for entry in kept["pairs"])  # the first frame's, kept
    result = invoke("match", video, "--sbs", "-O", tmp_path / "each", "--range-each-frame",
                    "--preview-video", tmp_path / "each.mp4")
    assert result.exit_code == 0, result.output
    assert "found on each frame" in result.output
    each = json.loads((tmp_path / "each" / "summary.json").read_text())
    ranges = [entry["range"] for entry in sorted(each["pairs"], key=lambda e: e["frame"])]
    assert ranges[0] == ranges[1] == kept["range"] and ranges[2] == ranges[3]
    assert ranges[2][1] > ranges[0][1] + 20  # the deep scene's own, far past the first's
    assert each["range"] == [ranges[0][0], ranges[2][1]]  # the widest, the preview's scale
    # The deep frames' maps reach past the range kept from the first frame.
    frames = [tmp_path / "each" / f"{i:06d}.pfm" for i in range(4)]
    assert np.nanmax(csw_read(frames[2])) > ranges[0][1] + 20
    assert np.nanmax(csw_read(tmp_path / "kept" / "000002.pfm")) <= ranges[0][1]
    result = invoke("match", video, "--sbs", "-O", tmp_path / "x", "--dmax", 20,
                    "--range-each-frame")
    assert result.exit_code == 2 and "for a range 'auto'" in result.output
    assert not (tmp_path / "x").exists()


def csw_read(path):
    from csw.io.formats import read_disparity

    return read_disparity(path)


def test_a_frame_whose_own_range_its_format_cant_hold_fails_alone(tmp_path):
    shallow = render(192, 96, 12, 5)[:2]
    behind = (shallow[0], np.roll(shallow[1], 10, axis=1))  # disparities 10 lower: < 0
    frames = [np.concatenate(pair, axis=1) for pair in (shallow, behind, shallow)]
    video = write_frames(tmp_path / "v.avi", frames)
    result = invoke("match", video, "--sbs", "-O", tmp_path / "maps", "--suffix", ".png",
                    "--dmin", "auto", "--range-each-frame")
    assert result.exit_code == 1, result.output
    assert "2 matched, 0 skipped, 1 failed" in result.output
    assert "failed: frame 1: " in result.output and "negative" in result.output
    assert "Traceback" not in result.output
    assert sorted(os.listdir(tmp_path / "maps")) == ["000000.png", "000002.png",
                                                     "summary.json"]


@pytest.mark.parametrize("given, words", [
    (["--dmin", 20, "--dmax", 10], ["--dmin", "must not exceed dmax (10)"]),
    (["--dmax", 1000000], ["--dmax", "less than the image width (96)"]),
    (["--dmin", -500], ["--dmin", "greater than minus the image width (96)"]),
])
def test_a_range_no_frame_can_take_is_refused_before_decoding(tmp_path, given, words):
    """As a single pair's: exit 2 at once, one line, nothing written (the frames' width
    comes from the video's header), not a failure a frame."""
    video = sbs_mjpeg(tmp_path / "v.avi", 4)
    result = invoke("match", video, "--sbs", "-O", tmp_path / "maps", *given)
    assert one_line_error(result), result.output
    assert all(word in result.output for word in words), result.output
    assert not (tmp_path / "maps").exists()


def test_a_full_disk_stops_the_run_cleanly_with_its_summary_and_preview(tmp_path,
                                                                         monkeypatch):
    """The batch rule: the frame whose map can't be written is reported, and since a full
    disk fails every frame after it, the run stops there, keeping the maps and the
    preview of the frames done and writing its summary (exit 1)."""
    import errno

    from csw.io.outputs import PairOutputs

    real = PairOutputs.write

    def full_from_frame_3(outputs):  # a frame's files: csw.io.outputs, as every pair's
        if outputs.paths["output"].name >= "000003":
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(outputs)

    monkeypatch.setattr(PairOutputs, "write", full_from_frame_3)
    video = sbs_mjpeg(tmp_path / "v.avi", 8)
    result = invoke("match", video, "--sbs", "-O", tmp_path / "maps", "--dmax", 15,
                    "--preview-video", tmp_path / "view.mp4")
    assert result.exit_code == 1 and "Traceback" not in result.output, result.output
    assert "stopped early: frame 3: can't write" in result.output
    assert "No space left on device" in result.output
    summary = json.loads((tmp_path / "maps" / "summary.json").read_text())
    assert summary["counts"] == {"ok": 3, "skipped": 0, "failed": 1}
    assert summary["stopped"].startswith("frame 3: can't write")
    assert sorted(os.listdir(tmp_path / "maps")) == \
        [f"{i:06d}.pfm" for i in range(3)] + ["summary.json"]
    assert sum(1 for _ in av.open(str(tmp_path / "view.mp4")).decode(video=0)) == 3


def test_an_unwritable_output_folder_is_refused_before_decoding(tmp_path, monkeypatch):
    from csw.io.video import VideoReader
    from csw.scale import stream

    (tmp_path / "maps").mkdir()
    real = os.access
    monkeypatch.setattr(stream.os, "access", lambda path, mode, **kw: False if
                        mode == os.W_OK and os.path.realpath(path) == str(tmp_path / "maps")
                        else real(path, mode, **kw))  # as a read-only disk, even for root
    decoded = []
    monkeypatch.setattr(VideoReader, "__iter__", lambda self: decoded.append(1))
    result = invoke("match", sbs_mjpeg(tmp_path / "v.avi", 3), "--sbs", "-O",
                    tmp_path / "maps")
    assert one_line_error(result), result.output
    assert f"the folder {tmp_path / 'maps'} is not writable" in result.output
    assert decoded == [] and os.listdir(tmp_path / "maps") == []


def test_a_second_ctrl_c_waits_for_the_summary(tmp_path, monkeypatch):
    """A Ctrl-C stops the run; a second one, while its summary is being written, waits
    until it is (in a notebook too, where csw's CLI handlers are not in place)."""
    from csw.scale import stream

    real = stream.write_summary

    def ctrl_c_again(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGINT)  # held until the summary is written
        return real(*args, **kwargs)

    def ctrl_c_at_frame_3(done, total):
        if done == 3:
            raise KeyboardInterrupt

    monkeypatch.setattr(stream, "write_summary", ctrl_c_again)
    with pytest.raises(KeyboardInterrupt):
        stream.match_video(sbs_mjpeg(tmp_path / "v.avi", 8), sbs=True,
                           out_dir=tmp_path / "maps", dmax=15, progress=ctrl_c_at_frame_3)
    summary = json.loads((tmp_path / "maps" / "summary.json").read_text())
    assert summary["interrupted"] is True and summary["counts"]["ok"] >= 3


def test_overwrite_redoes_the_maps_of_a_video(tmp_path):
    video = sbs_mjpeg(tmp_path / "v.avi", 3)
    assert invoke("match", video, "--sbs", "-O", tmp_path / "maps", "--dmax", 15)\
        .exit_code == 0
    stale = tmp_path / "maps" / "000001.pfm"
    csw.write_disparity(stale, np.zeros((4, 4), np.float32))
    result = invoke("match", video, "--sbs", "-O", tmp_path / "maps", "--dmax", 15)
    assert "0 matched, 3 skipped" in result.output
    assert csw.read_disparity(stale).shape == (4, 4)  # kept
    result = invoke("match", video, "--sbs", "-O", tmp_path / "maps", "--dmax", 15,
                    "--overwrite")
    assert result.exit_code == 0 and "3 matched, 0 skipped" in result.output, result.output
    assert csw.read_disparity(stale).shape == (64, 96)  # redone: the frame's size


def test_range_each_frame_keeps_the_widest_range_when_a_deep_scene_comes_first(tmp_path):
    shallow, deep = (np.concatenate(render(192, 96, dmax, 5)[:2], axis=1) for dmax in (12, 48))
    video = write_frames(tmp_path / "v.avi", [deep, deep, shallow, shallow])
    result = invoke("match", video, "--sbs", "-O", tmp_path / "each", "--range-each-frame")
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "each" / "summary.json").read_text())
    ranges = [entry["range"] for entry in summary["pairs"]]
    assert ranges[3][1] < ranges[0][1]  # the last frame's own range is the narrower
    assert summary["range"] == [min(r[0] for r in ranges), max(r[1] for r in ranges)]


def test_a_ctrl_c_during_a_frame_s_save_keeps_that_frame_whole(tmp_path, monkeypatch):
    """The frame being saved when Ctrl-C comes is written whole (map and summary entry),
    and so is each frame matched before the Ctrl-C reached the main thread and waiting
    to be written (how many is a race: the matcher may finish the next frames during
    the save); then the run stops, long before the video's end."""
    from csw.io.outputs import PairOutputs
    from csw.scale import stream

    real = PairOutputs.write

    def ctrl_c_while_saving_frame_2(outputs):
        if outputs.paths["output"].name == "000002.pfm":
            os.kill(os.getpid(), signal.SIGINT)
            sum(range(10**5))  # were the save not held, the handler would run here
        return real(outputs)

    monkeypatch.setattr(PairOutputs, "write", ctrl_c_while_saving_frame_2)
    saved = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            stream.match_video(sbs_mjpeg(tmp_path / "v.avi", 40), sbs=True,
                               out_dir=tmp_path / "maps", dmax=15, progress=False,
                               in_flight=1)
    finally:
        signal.signal(signal.SIGINT, saved)
    maps = tmp_path / "maps"
    summary = json.loads((maps / "summary.json").read_text())
    frames = [entry["frame"] for entry in summary["pairs"]]
    # Frame 2 and those before it, then at most the frames waiting to be written when
    # the Ctrl-C came (stream.WRITE_BEHIND of them) and the one being matched.
    assert frames == list(range(len(frames)))
    assert 3 <= len(frames) <= 3 + stream.WRITE_BEHIND + 1
    assert summary["interrupted"] is True and summary["counts"]["ok"] == len(frames)
    assert sorted(p.name for p in maps.glob("*.pfm")) == [f"{f:06d}.pfm" for f in frames]
    assert not [p for p in maps.iterdir() if p.name.startswith(".csw-tmp")]

"""Video in and out: csw.scale.stream.match_video, csw.io.video, csw synth --frames."""

import json
import os

import numpy as np
import pytest
from video_fixtures import damage_jpeg_frame, write_frames

import csw
from csw.data.synth import render, write_sequence
from csw.io.pictures import DisparityColours, bar, disparity_colours
from csw.io.video import VideoError, VideoReader, write_video
from csw.scale.frames import video_frames
from csw.scale.stream import match_video

av = pytest.importorskip("av")  # in the test extras: skipped only outside them

W, H, D = 96, 64, 15


def pair(index, count=6):
    return render(W, H, D, seed=5, phase=index / count)[:2]


def sbs_video(path, count=6):
    return write_frames(path, [np.concatenate(pair(i, count), axis=1) for i in range(count)])


def leftovers(folder):
    return [p for p in os.listdir(folder) if p.startswith(".csw-tmp")]


def decoded_pairs(path):
    """The pairs as csw reads them from a side-by-side video."""
    out = []
    for _, gray, _ in VideoReader(path):
        out.append((gray[:, :gray.shape[1] // 2], gray[:, gray.shape[1] // 2:]))
    return out


def test_each_frames_map_equals_csw_match_on_the_decoded_frames(tmp_path):
    video = sbs_video(tmp_path / "sbs.avi")
    out = tmp_path / "maps"
    report = match_video(video, sbs=True, out_dir=out, progress=False, dmax=D)
    assert report["counts"] == {"ok": 6, "skipped": 0, "failed": 0}
    assert report["frames"] == 6
    assert report["size"] == [W, H] and report["range"] == [0, D]
    assert report["frames_per_second"] > 0 and report["latency_ms"]["p99"] > 0
    for i, (left, right) in enumerate(decoded_pairs(video)):
        written = csw.read_disparity(out / f"{i:06d}.pfm")
        expected = csw.match(left, right, dmax=D).disparity
        np.testing.assert_array_equal(written, expected)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["frames"] == 6 and summary["interrupted"] is False
    assert [p["frame"] for p in summary["pairs"]] == list(range(6))
    assert leftovers(out) == [] and leftovers(tmp_path) == []


def test_the_maps_follow_the_ground_truth_through_an_h264_video(tmp_path):
    write_sequence(tmp_path / "seq", 4, W * 2, H * 2, D * 2, seed=1, video=True)
    out = tmp_path / "maps"
    match_video(tmp_path / "seq" / "sbs.mp4", sbs=True, out_dir=out, progress=False,
                dmax=D * 2)
    for i in range(4):
        gt = csw.read_disparity(tmp_path / "seq" / "gt" / f"{i:06d}.pfm")
        disparity = csw.read_disparity(out / f"{i:06d}.pfm")
        valid = np.isfinite(disparity)
        assert valid.mean() > 0.8
        assert np.mean(np.abs(disparity[valid] - gt[valid]) > 1) < 0.05


def test_two_videos_pair_by_index_and_stop_at_the_shorter(tmp_path):
    lefts = [pair(i)[0] for i in range(6)]
    rights = [pair(i)[1] for i in range(4)]
    left, right = write_frames(tmp_path / "l.avi", lefts), write_frames(tmp_path / "r.avi", rights)
    out = tmp_path / "maps"
    report = match_video(left, right, out_dir=out, progress=False, dmax=D)
    assert report["counts"]["ok"] == 4
    assert len(report["stream_notes"]) == 1
    assert "r.avi ended after 4 frames" in report["stream_notes"][0]
    assert sorted(os.listdir(out)) == [f"{i:06d}.pfm" for i in range(4)] + ["summary.json"]


def test_a_damaged_frame_is_reported_and_the_others_are_matched(tmp_path):
    video = sbs_video(tmp_path / "sbs.avi")
    damage_jpeg_frame(video, 3)
    out = tmp_path / "maps"
    report = match_video(video, sbs=True, out_dir=out, progress=False, dmax=D)
    assert report["counts"] == {"ok": 5, "skipped": 0, "failed": 1}
    (failed,) = report["failed"]
    assert failed["frame"] == 3 and "frame 3 can't be decoded" in failed["error"]
    assert not (out / "000003.pfm").exists() and (out / "000004.pfm").exists()


def test_a_frame_size_that_changes_stops_the_stream_with_one_line(tmp_path, monkeypatch):
    images = [np.zeros((H, 2 * W), np.uint8)] * 3 + [np.zeros((H, 2 * W - 8), np.uint8)]

    class Changing:  # a reader whose fourth frame is narrower (FFmpeg's containers
        # rarely change size mid-stream, but cameras' streams can)
        size, frames, rate, path = (2 * W, H), 4, 25.0, "cam.avi"

        def __init__(self, *args):
            pass

        def __iter__(self):
            for i, image in enumerate(images):
                yield i, image, None

        def close(self):
            pass

    monkeypatch.setattr("csw.scale.frames.VideoReader", Changing)
    frames, _ = video_frames("cam.avi", sbs=True)
    with pytest.raises(VideoError, match=r"frame 3: the size changed from 96x64 to 92x64"):
        list(frames)
    report = match_video("cam.avi", sbs=True, out_dir=tmp_path / "maps", progress=False,
                         dmax=D)
    assert report["counts"]["ok"] == 3 and "size changed" in report["stopped"]
    assert json.loads((tmp_path / "maps" / "summary.json").read_text())["stopped"]


def test_an_odd_side_by_side_width_is_refused_before_any_work(tmp_path):
    video = write_frames(tmp_path / "odd.mkv", [np.full((H, 2 * W + 1), 100, np.uint8)] * 2,
                  codec="ffv1", pix_fmt="gray")
    with pytest.raises(VideoError, match="even width"):
        match_video(video, sbs=True, out_dir=tmp_path / "maps", progress=False, dmax=D)
    assert not (tmp_path / "maps").exists()


def test_a_file_that_is_not_a_video_is_one_line(tmp_path):
    fake = tmp_path / "notes.mp4"
    fake.write_text("not a video\n")
    with pytest.raises(VideoError, match="not a readable video") as info:
        match_video(fake, sbs=True, out_dir=tmp_path / "maps", progress=False, dmax=D)
    assert "\n" not in str(info.value)
    with pytest.raises(VideoError, match="no such file"):
        VideoReader(tmp_path / "missing.mp4")


def test_an_interrupt_keeps_the_frames_done_and_a_whole_preview(tmp_path):
    video = sbs_video(tmp_path / "sbs.avi")
    out, preview = tmp_path / "maps", tmp_path / "view.mp4"

    def stop_after_three(done, total):
        if done == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        match_video(video, sbs=True, out_dir=out, preview_video=preview,
                    progress=stop_after_three, dmax=D, in_flight=1)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["interrupted"] is True and summary["counts"]["ok"] == 3
    assert sorted(p for p in os.listdir(out) if p.endswith(".pfm")) == \
        [f"{i:06d}.pfm" for i in range(3)]
    assert len(list(VideoReader(preview))) == 3
    assert leftovers(out) == [] and leftovers(tmp_path) == []
    # A rerun resumes: the three maps are skipped, the rest matched.
    report = match_video(video, sbs=True, out_dir=out, progress=False, dmax=D)
    assert report["counts"] == {"ok": 3, "skipped": 3, "failed": 0}


def test_the_preview_video_shows_the_map_beside_the_left_frame(tmp_path):
    video = sbs_video(tmp_path / "sbs.avi")
    preview = tmp_path / "view.mp4"
    report = match_video(video, sbs=True, preview_video=preview, preview_sbs=True,
                         progress=False, dmax=D)
    assert report["pairs"] == [] and report["counts"]["ok"] == 6
    assert sorted(os.listdir(tmp_path)) == ["sbs.avi", "view.mp4"]  # nothing else
    frames = list(VideoReader(preview, colour=True))
    assert len(frames) == 6
    rgb = frames[0][2][..., :3]
    strip = bar(W, 0, D, "disparity (pixels)")  # the still previews' bar, under the map
    assert rgb.shape == (H + strip.shape[0] + strip.shape[0] % 2, 2 * W, 3)
    left, right = decoded_pairs(video)[0]
    expected = disparity_colours(csw.match(left, right, dmax=D).disparity, 0, D)[..., :3]
    # H.264 at quality 20: colours within a few levels on average.
    assert np.abs(rgb[:H, W:].astype(int) - expected).mean() < 8
    assert np.abs(rgb[H:H + strip.shape[0], W:].astype(int) - strip).mean() < 8


def test_disparity_colours_are_the_pictures_turbo():
    from csw.io.pictures import colour

    disparity = np.array([[0, 3.5, np.nan], [7.25, 15, 20]], np.float32)
    rgba = disparity_colours(disparity, 0, 15)
    assert rgba.shape == (2, 3, 4) and (rgba[..., 3] == 255).all()
    np.testing.assert_allclose(rgba[..., :3], colour(disparity, 0, 15), atol=1)
    assert (rgba[0, 2, :3] == 0).all()


def test_a_stream_of_colours_reuses_its_arrays_and_equals_fresh_ones():
    rng = np.random.default_rng(4)
    colours = DisparityColours()
    for shape, high in (((6, 9), 15), ((6, 9), 31), ((4, 5), 15)):  # a new size: new arrays
        disparity = (rng.random(shape) * (high + 4) - 2).astype(np.float32)
        disparity[rng.random(shape) < 0.2] = np.nan
        kept = colours(disparity, 0, high)
        np.testing.assert_array_equal(kept, disparity_colours(disparity, 0, high))
    assert colours(disparity, 0, 15) is not colours(disparity, 0, 15)  # views ...
    assert np.shares_memory(colours(disparity, 0, 15), colours(disparity, 0, 15))  # of one


def test_colours_drawn_in_place_equal_the_colourer_s_own():
    rng = np.random.default_rng(5)
    disparity = (rng.random((6, 9)) * 19 - 2).astype(np.float32)
    disparity[rng.random((6, 9)) < 0.2] = np.nan
    canvas = np.zeros((8, 9, 4), np.uint8)  # the rows under the map are left alone
    assert DisparityColours()(disparity, 0, 15, out=canvas[:6]) is not None
    np.testing.assert_array_equal(canvas[:6], disparity_colours(disparity, 0, 15))
    assert (canvas[6:] == 0).all()


@pytest.mark.parametrize("size", [(64, 96), (63, 96), (64, 90)])
def test_a_video_drawn_on_the_writer_s_canvas_is_the_one_written_from_arrays(tmp_path,
                                                                            size):
    """VideoWriter.canvas: written without a copy where FFmpeg's frame allows it (even
    sizes, rows not padded), else a plain array; the file is the same bytes either way."""
    from csw.io.video import VideoWriter

    rng = np.random.default_rng(6)
    pictures = [rng.integers(0, 256, (*size, 4), np.uint8) for _ in range(3)]
    drawn, plain = VideoWriter(tmp_path / "drawn.mp4"), VideoWriter(tmp_path / "plain.mp4")
    canvas = drawn.canvas(*size)
    for picture in pictures:
        assert drawn.canvas(*size) is canvas  # one array, drawn again for each frame
        canvas[:] = picture
        drawn.write(canvas)
        plain.write(picture.copy())
    assert drawn.close() and plain.close()
    assert (tmp_path / "drawn.mp4").read_bytes() == (tmp_path / "plain.mp4").read_bytes()


def test_outputs_must_not_land_on_an_input(tmp_path):
    video = sbs_video(tmp_path / "sbs.avi")
    with pytest.raises(ValueError, match="input"):
        match_video(video, sbs=True, preview_video=video, progress=False, dmax=D)
    with pytest.raises(ValueError, match="video"):
        match_video(video, sbs=True, preview_video=tmp_path / "view.png", progress=False,
                    dmax=D)


def test_synth_frames_move(tmp_path):
    write_sequence(tmp_path, 3, W, H, D, seed=2)
    gts = [csw.read_disparity(tmp_path / "gt" / f"{i:06d}.pfm") for i in range(3)]
    assert not np.array_equal(gts[0], gts[1])
    assert all(0 < g.max() <= D for g in gts)
    left = csw.read_image(tmp_path / "left" / "000001.png")
    np.testing.assert_array_equal(left, render(W, H, D, seed=2, phase=1 / 3)[0])
    assert (tmp_path / "calib.txt").exists()


def test_write_video_leaves_nothing_when_it_fails(tmp_path):
    def frames():
        yield np.zeros((H, W), np.uint8)
        raise RuntimeError("camera unplugged")

    with pytest.raises(RuntimeError):
        write_video(tmp_path / "v.mp4", frames())
    assert os.listdir(tmp_path) == []


def test_two_outputs_that_are_one_file_name_the_option_that_collides(tmp_path):
    """The error names the option given last of the two, with the other's role."""
    from csw.config.params import OptionError, resolve
    from csw.scale.stream import _check_outputs

    with pytest.raises(OptionError, match="summary.json is also the summary") as info:
        _check_outputs(resolve(dmax=15), [], tmp_path / "maps", ".pfm", None,
                       bag_out=tmp_path / "maps" / "summary.json")
    assert info.value.option == "bag_out"
    assert not (tmp_path / "maps").exists()

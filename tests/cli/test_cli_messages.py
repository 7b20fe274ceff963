"""Messages that point the right way (issue 39, items 11 and 16): each refusal says what
is wrong in the user's own terms, in one line, and exits non-zero."""

import json
import warnings

import numpy as np
import pytest
from click.testing import CliRunner
from rig_fixtures import random_rig, ros_camera_info

import csw
from csw.camera.rectify import Rectifier, stereo_rectify
from csw.camera.rig import Rig, read_rig
from csw.io import write_png
from csw_cli.main import cli

SIZE = (64, 48)


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def one_line(result, code=2):
    lines = result.output.strip().splitlines()
    assert result.exit_code == code and "Traceback" not in result.output, result.output
    assert lines[-1].startswith("Error:"), result.output
    return lines[-1]


@pytest.fixture
def ros_files(tmp_path):
    rig = random_rig(np.random.default_rng(5), size=SIZE)
    r1, r2, p1, p2, _ = stereo_rectify(rig.k1, rig.d1, rig.k2, rig.d2, SIZE, rig.r, rig.t)
    (tmp_path / "left.yaml").write_text(ros_camera_info(rig.k1, rig.d1, r1, p1, SIZE))
    (tmp_path / "right.yaml").write_text(ros_camera_info(rig.k2, rig.d2, r2, p2, SIZE))
    return tmp_path / "left.yaml", tmp_path / "right.yaml"


def test_huge_rig_values_are_one_error_and_no_numpy_warning(tmp_path, ros_files):
    rig = random_rig(np.random.default_rng(5), size=SIZE)
    huge = rig.k1.copy()
    huge[0, 0] = huge[1, 1] = 1e308
    p = np.hstack([huge, np.zeros((3, 1))])
    (tmp_path / "huge.yaml").write_text(ros_camera_info(huge, rig.d1, np.eye(3), p, SIZE))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning would fail the test
        with pytest.raises(ValueError, match="1e\\+308, too large for a camera's"):
            read_rig(tmp_path / "huge.yaml", ros_files[1])


def test_swapped_ros_files_say_which_comes_first(ros_files):
    left, right = ros_files
    with pytest.raises(ValueError, match="give the left one first"):
        read_rig(right, left)


@pytest.mark.parametrize("value, says", [("1e308", "too large"), ("1e-320", "too small"),
                                         ("1e-30", "too small")])
def test_depth_from_values_too_large_or_too_small_is_refused(tmp_path, value, says):
    """A product of 1e-60 is 0 in float32 depths; 1e-320's reciprocal (Q's 1 / baseline)
    overflowed, with numpy's RuntimeWarnings on stderr, into a map of zeros."""
    csw.write_disparity(tmp_path / "d.pfm", np.full((8, 8), 4, np.float32))
    result = run("depth", tmp_path / "d.pfm", "--focal", value, "--baseline", value,
                 "-o", tmp_path / "z.pfm")
    assert f"{says} to give a depth" in one_line(result)
    assert not (tmp_path / "z.pfm").exists()


def test_a_rectification_with_no_valid_pixel_is_refused():
    rig = random_rig(np.random.default_rng(5), size=SIZE)
    far = np.array([[50.0, 0, 1e5, 0], [0, 50, 1e5, 0], [0, 0, 1, 0]])  # looks elsewhere
    shifted = far.copy()
    shifted[0, 3] = -5.0
    aside = Rig(rig.k1, rig.d1, rig.k2, rig.d2, rig.r, rig.t, SIZE,
                rectification=(np.eye(3), np.eye(3), far, shifted))
    with pytest.raises(ValueError, match="no pixel of the rectified images has a source"):
        Rectifier(aside)


def test_an_empty_video_stops_with_its_summary_and_exit_1(tmp_path):
    pytest.importorskip("av")
    (tmp_path / "empty.y4m").write_bytes(b"YUV4MPEG2 W64 H48 F30:1 Ip A1:1 C420jpeg\n")
    result = run("match", tmp_path / "empty.y4m", "--sbs", "-O", tmp_path / "maps")
    assert result.exit_code == 1, result.output
    assert "stopped early" in result.output and "holds no frames" in result.output
    summary = json.loads((tmp_path / "maps" / "summary.json").read_text())
    assert summary["frames"] == 0 and "holds no frames" in summary["stopped"]


def y4m(path, frames, tail=b""):
    """A 64x48 4:2:0 YUV4MPEG2 file of ``frames`` grey frames, then ``tail``."""
    frame = b"FRAME\n" + bytes([128]) * (64 * 48 * 3 // 2)
    path.write_bytes(b"YUV4MPEG2 W64 H48 F30:1 Ip A1:1 C420jpeg\n" + frame * frames + tail)
    return path


def test_a_y4m_cut_short_stops_after_its_whole_frames(tmp_path):
    pytest.importorskip("av")
    whole = run("match", y4m(tmp_path / "whole.y4m", 2), "--sbs", "-O", tmp_path / "a",
                "--dmax", 8)
    assert whole.exit_code == 0 and "2 matched" in whole.output, whole.output
    cut = run("match", y4m(tmp_path / "cut.y4m", 2, b"FRAME\n" + bytes(100)), "--sbs",
              "-O", tmp_path / "b", "--dmax", 8)
    assert cut.exit_code == 1 and "2 matched" in cut.output, cut.output
    assert "the file ends inside frame 2 (cut short)" in cut.output


def test_an_unwritable_kernel_cache_names_itself(tmp_path):
    from csw.kernels.store import lock

    (tmp_path / "file").write_text("not a folder")
    with pytest.raises(OSError, match="kernel cache: set CSW_KERNEL_CACHE") as error:
        with lock(tmp_path / "file" / "cpu"):
            pass
    assert error.value.filename == str(tmp_path / "file" / "cpu")


def test_the_auto_range_s_errors_give_the_pair_s_size_and_the_shrunk_one():
    image = np.random.default_rng(0).integers(0, 255, (16, 16)).astype(np.uint8)
    with pytest.raises(ValueError, match=r"16 wide, shrunk 2 times to 8x8") as error:
        csw.match(image, image)
    assert "give --dmin and --dmax" in str(error.value)


def test_a_huge_manifest_name_is_not_echoed_whole(tmp_path, pair_files):
    left, right = pair_files
    (tmp_path / "m.csv").write_text(f"{left.name},{right.name},{'x' * 100_000}\n")
    line = one_line(run("match", "--manifest", tmp_path / "m.csv", "-O", tmp_path / "out"))
    assert "longer than" in line and len(line) < 500


def test_batch_rectify_shows_its_progress(tmp_path, ros_files):
    left, _, _, _ = csw.synthetic_pair(*SIZE, dmax=8, seed=2)
    for side in ("L", "R"):
        (tmp_path / side).mkdir()
        for name in ("a.png", "b.png"):
            write_png(tmp_path / side / name, left)
    result = run("rectify", tmp_path / "L", tmp_path / "R", "--rig", ros_files[0], "--rig",
                 ros_files[1], "-O", tmp_path / "rect")
    assert result.exit_code == 0, result.output
    assert "csw rectify" in result.output and "2/2" in result.output


def test_an_existing_folder_as_o_says_it_is_a_folder(tmp_path, pair_files):
    (tmp_path / "maps").mkdir()
    line = one_line(run("match", *pair_files, "-o", tmp_path / "maps", "--dmax", 8))
    assert "is a folder; give a file name" in line and "extension" not in line


def test_output_dir_with_two_files_says_it_is_for_many_pairs(tmp_path, pair_files):
    line = one_line(run("match", *pair_files, "-O", tmp_path / "maps"))
    assert "is a file: --output-dir is for many pairs" in line and "-o FILE" in line

"""csw calibrate: chessboard folders to a rig file that csw rectify uses; bad input is
one line, exit 2, nothing written."""

import shutil
import sys

import numpy as np
import pytest
from calib_fixtures import known_rig, views, write_views
from click.testing import CliRunner

import csw
from csw.io import write_png
from csw.io.images import read_colour
from csw_cli.main import cli


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture(scope="module")
def boards(tmp_path_factory):
    folder = tmp_path_factory.mktemp("boards")
    write_views(folder, views(known_rig(), 8))
    return folder


def test_calibrate_then_rectify(boards, tmp_path):
    rig, preview = tmp_path / "rig.yml", tmp_path / "check.png"
    done = run("calibrate", boards / "left", boards / "right", "--board", "9x6", "--square",
               "25mm", "-o", rig, "--preview", preview)
    assert done.exit_code == 0, done.output
    assert "view 03: reprojection RMS left" in done.output
    assert "8 view(s) used, 0 rejected; reprojection RMS" in done.output
    assert "rectified row error" in done.output and "baseline 60" in done.output
    assert csw.read_rig(rig).units == "mm"
    picture = read_colour(preview)
    assert picture.shape == (360, 960, 3) and (picture[16] == (0, 200, 0)).all()
    rectified = run("rectify", boards / "left/00.png", boards / "right/00.png", "--rig", rig,
                    "-O", tmp_path / "rect")
    assert rectified.exit_code == 0, rectified.output
    assert " mm, " in rectified.output
    rect = tmp_path / "rect"
    depths = {}
    for units in ("mm", "m"):  # the rig's mm carried to depth; --units m converts
        matched = run("match", rect / "left.png", rect / "right.png", "-o",
                      tmp_path / "d.pfm", "--depth", tmp_path / f"z-{units}.pfm",
                      "--overwrite", "--units", units)
        assert matched.exit_code == 0, matched.output
        assert "baseline 60" in matched.output and " mm," in matched.output, matched.output
        depths[units] = csw.read_disparity(tmp_path / f"z-{units}.pfm")
    found = np.isfinite(depths["mm"])
    assert found.mean() > 0.1  # the board; the flat background has no match
    np.testing.assert_allclose(depths["m"][found] * 1000, depths["mm"][found], rtol=1e-5)
    cloud = run("cloud", tmp_path / "d.pfm", "--calib", rig, "-o", tmp_path / "c.ply",
                "--units", "m")
    assert cloud.exit_code == 0 and "mm" in cloud.output, cloud.output


def test_a_board_not_found_is_reported_and_skipped(boards, tmp_path):
    for side in ("left", "right"):
        shutil.copytree(boards / side, tmp_path / side)
        write_png(tmp_path / side / "blank.png", np.full((360, 480), 128, np.uint8))
    (tmp_path / "pairs.csv").write_text("".join(
        f"left/{p.name},right/{p.name}\n" for p in sorted((tmp_path / "left").iterdir())))
    done = run("calibrate", "--manifest", tmp_path / "pairs.csv", "--board", "9x6",
               "--square", "0.025", "--units", "m", "-o", tmp_path / "rig.yml")
    assert done.exit_code == 0, done.output
    assert "rejected blank: no 9x6 board found in either image" in done.output
    assert csw.read_rig(tmp_path / "rig.yml").baseline == pytest.approx(0.06, rel=0.005)


def _subset(boards, tmp_path, names, swap=False, small=False):
    for side, other in (("left", "right"), ("right", "left")):
        (tmp_path / side).mkdir()
        for name in names:
            shutil.copy(boards / (other if swap else side) / f"{name}.png", tmp_path / side)
    if small:
        image = csw.read_image(tmp_path / "left/03.png")
        write_png(tmp_path / "left/03.png", image[:-2])
    return tmp_path / "left", tmp_path / "right"


@pytest.mark.parametrize("names, options, message", [
    (["00", "01", "02"], {}, "the board was found in both images of 3 pair(s); calibrating "
                             "needs at least 4"),
    ([f"0{i}" for i in range(6)], {"swap": True}, "the left and right images are swapped"),
    ([f"0{i}" for i in range(6)], {"small": True}, "03: the left image is 480x358 but the "
                                                   "first is 480x360"),
])
def test_bad_input_is_one_line_exit_2_nothing_written(boards, tmp_path, names, options,
                                                      message):
    left, right = _subset(boards, tmp_path, names, **options)
    done = run("calibrate", left, right, "--board", "9x6", "--square", "25mm", "-o",
               tmp_path / "rig.yml", "--preview", tmp_path / "p.png")
    assert done.exit_code == 2, done.output
    assert message in done.output and "Traceback" not in done.output
    assert len(done.output.strip().splitlines()) == 1
    assert not (tmp_path / "rig.yml").exists() and not (tmp_path / "p.png").exists()


@pytest.mark.parametrize("args, message", [
    (["--board", "9"], "Invalid value for --board"),
    (["--square", "big"], "Invalid value for --square"),
    (["-o", "{left}/00.png"], "unknown extension '.png'"),
])
def test_bad_options(boards, args, message):
    options = {"--board": "9x6", "--square": "25mm", "-o": "rig.yml"}
    options.update(zip(args[::2], args[1::2], strict=True))
    flat = [str(v).format(left=boards / "left") for kv in options.items() for v in kv]
    done = run("calibrate", boards / "left", boards / "right", *flat)
    assert done.exit_code == 2 and message in done.output, done.output


def test_no_opencv_is_a_one_line_hint(boards, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "cv2", None)
    done = run("calibrate", boards / "left", boards / "right", "--board", "9x6", "--square",
               "25mm", "-o", tmp_path / "rig.yml")
    assert done.exit_code == 1
    assert done.output.strip() == ("Error: csw calibrate needs OpenCV: pip install "
                                   "'csw-stereo[calibrate]'")

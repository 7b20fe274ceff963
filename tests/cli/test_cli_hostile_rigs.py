"""Hostile and careless rig files, and pipes as inputs (issue 39): every one is refused
in one line, exit 2, before anything is allocated for it, with nothing written."""

import os
import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner
from rig_fixtures import kalibr_text, kitti_text, random_rig, ros_camera_info, write_opencv

import csw
from csw.camera.rectify import Rectifier, stereo_rectify
from csw.camera.rig import Rig, read_rig
from csw.io import write_png
from csw_cli.main import cli

SIZE = (64, 48)


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def assert_refused(result, *words):
    """One line, exit 2, no traceback, saying each of ``words``."""
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert lines[0].startswith("Error:") and all(w in lines[0] for w in words), lines[0]


@pytest.fixture
def rig_folder(tmp_path):
    """A raw pair (64x48), its ROS camera_info files left.yaml and right.yaml, and an
    OpenCV stereo.yml of the same rig."""
    rig = random_rig(np.random.default_rng(5), size=SIZE)
    r1, r2, p1, p2, _ = stereo_rectify(rig.k1, rig.d1, rig.k2, rig.d2, SIZE, rig.r, rig.t)
    (tmp_path / "left.yaml").write_text(ros_camera_info(rig.k1, rig.d1, r1, p1, SIZE))
    (tmp_path / "right.yaml").write_text(ros_camera_info(rig.k2, rig.d2, r2, p2, SIZE))
    write_opencv(tmp_path / "stereo.yml", rig)
    left, right, _, _ = csw.synthetic_pair(*SIZE, dmax=8, seed=2)
    write_png(tmp_path / "l.png", left)
    write_png(tmp_path / "r.png", right)
    return tmp_path


def match_with(folder, *rigs):
    return run("match", folder / "l.png", folder / "r.png", "-o", folder / "d.pfm",
               "--dmax", 8, *[a for rig in rigs for a in ("--rig", rig)])


def alias_bomb(key):
    """A kilobyte of YAML whose aliases expand to 10^10 numbers."""
    text = "a0: &a0 [" + ", ".join(["1"] * 10) + "]\n"
    for i in range(1, 10):
        text += f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]\n"
    return text + key + " *a9\n"


@pytest.mark.parametrize("kind", ["ros", "kalibr"])
def test_a_yaml_alias_bomb_is_refused_in_one_line(rig_folder, kind):
    bomb = rig_folder / "bomb.yaml"
    if kind == "ros":
        bomb.write_text(alias_bomb("camera_matrix:") + "projection_matrix: [1]\n")
        result = match_with(rig_folder, bomb, rig_folder / "right.yaml")
    else:
        bomb.write_text(alias_bomb("cam0: {intrinsics:").replace(" *a9\n", " *a9}\n")
                        + "cam1: {T_cn_cnm1: [1]}\n")
        result = match_with(rig_folder, bomb)
    assert_refused(result, "bomb.yaml", "aliases")
    assert not (rig_folder / "d.pfm").exists()


def test_an_alias_bomb_is_read_in_bounded_memory(tmp_path):
    """Under a 500 MB address-space limit, the bomb is a ValueError, not a MemoryError."""
    (tmp_path / "bomb.yaml").write_text(alias_bomb("camera_matrix:")
                                        + "projection_matrix: [1]\n")
    script = ("import resource, sys; resource.setrlimit(resource.RLIMIT_AS, (500 << 20,) * 2)\n"
              "from csw.camera.rig import read_rig\n"
              "try:\n    read_rig(sys.argv[1], sys.argv[1])\n"
              "except ValueError as exc:\n    print(exc)\n")
    out = subprocess.run([sys.executable, "-c", script, str(tmp_path / "bomb.yaml")],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and "aliases" in out.stdout, out.stderr


def test_deep_nesting_is_one_line_not_a_recursion_error(rig_folder):
    deep = rig_folder / "deep.yaml"
    deep.write_text("camera_matrix: " + "[" * 100_000 + "]" * 100_000
                    + "\nprojection_matrix: [1]\n")
    assert_refused(match_with(rig_folder, deep, rig_folder / "right.yaml"), "nests deeper")


@pytest.mark.parametrize("make, words", [
    (lambda p: "/dev/zero", ["/dev/zero is a device"]),
    (lambda p: os.mkfifo(p / "fifo.yaml") or p / "fifo.yaml", ["is a pipe"]),
    (lambda p: (p / "big.yml").write_bytes(b"M1: " + b" " * (2 << 20)) and p / "big.yml",
     ["too large", "1048576"]),
], ids=["device", "fifo", "oversized"])
def test_a_rig_that_is_a_device_a_pipe_or_too_large_is_refused_before_reading(
        rig_folder, make, words):
    assert_refused(match_with(rig_folder, make(rig_folder)), *words)
    assert not (rig_folder / "d.pfm").exists()


def test_a_pipe_as_an_image_is_refused_by_rectify_and_match_rig(rig_folder):
    os.mkfifo(rig_folder / "pipe.png")  # no writer: opening it to read waits for ever
    rig = rig_folder / "stereo.yml"
    result = run("rectify", rig_folder / "pipe.png", rig_folder / "r.png", "--rig", rig,
                 "-O", rig_folder / "rect")
    assert_refused(result, "pipe.png is a pipe")
    result = run("match", rig_folder / "pipe.png", rig_folder / "r.png", "--rig", rig,
                 "-o", rig_folder / "d.pfm")
    assert_refused(result, "pipe.png is a pipe")
    assert not (rig_folder / "d.pfm").exists()


def test_a_pipe_in_a_batch_fails_alone(rig_folder):
    for side, image in (("L", "l.png"), ("R", "r.png")):
        (rig_folder / side).mkdir()
        for name in ("a.png", "c.png"):
            (rig_folder / side / name).write_bytes((rig_folder / image).read_bytes())
    os.mkfifo(rig_folder / "L" / "0.png")  # first by name: the rig's size is not taken from it
    (rig_folder / "R" / "0.png").write_bytes((rig_folder / "r.png").read_bytes())
    result = run("rectify", rig_folder / "L", rig_folder / "R", "--rig",
                 rig_folder / "stereo.yml", "-O", rig_folder / "rect")
    assert result.exit_code == 1, result.output
    assert "2 pair(s) rectified" in result.output and "0.png is a pipe" in result.output
    result = run("match", rig_folder / "L", rig_folder / "R", "--rig",
                 rig_folder / "stereo.yml", "-O", rig_folder / "maps", "--dmax", 8)
    assert result.exit_code == 1, result.output
    assert "2 matched" in result.output and "0.png is a pipe" in result.output


@pytest.mark.parametrize("fmt, change", [
    ("ros", lambda t: t.replace("image_width: 64", "image_width: .inf")),
    ("ros", lambda t: t.replace("image_width: 64", "image_width: [1, 2]")),
    ("kitti", lambda t: t.replace("S_02: 64 48", "S_02: inf 48")),
    ("kalibr", lambda t: t.replace("resolution: [64, 48]", "resolution: [.inf, 48]")),
])
def test_a_size_that_is_no_whole_number_is_one_line(rig_folder, fmt, change):
    rig = random_rig(np.random.default_rng(5), size=SIZE)
    if fmt == "ros":
        for name in ("left.yaml", "right.yaml"):
            path = rig_folder / name
            path.write_text(change(path.read_text()))
        paths = [rig_folder / "left.yaml", rig_folder / "right.yaml"]
    elif fmt == "kitti":
        text = kitti_text(rig)
        paths = [rig_folder / "calib_cam_to_cam.txt"]
        paths[0].write_text(change(text))
    else:
        paths = [rig_folder / "camchain.yaml"]
        paths[0].write_text(change(kalibr_text(rig)))
    assert_refused(match_with(rig_folder, *paths), "whole numbers")


@pytest.mark.parametrize("width", ["999999999999999999999999", "4294967296"])
def test_an_opencv_rig_s_width_past_any_image_is_one_line(rig_folder, width):
    """Its size was taken as it came: a width of 10**24 overflowed the rectification's
    arithmetic into numpy's RuntimeWarnings on stderr, then an error of focal inf."""
    path = rig_folder / "stereo.yml"
    path.write_text(path.read_text().replace("width: 64", f"width: {width}"))
    csw.write_disparity(rig_folder / "d.pfm", np.full((48, 64), 4, np.float32))
    assert_refused(run("depth", rig_folder / "d.pfm", "--calib", path, "-o",
                       rig_folder / "z.pfm"), "whole numbers in 1..2147483647")
    assert_refused(match_with(rig_folder, path), "whole numbers in 1..2147483647")
    assert not (rig_folder / "z.pfm").exists()


@pytest.mark.parametrize("fmt", ["ros", "opencv"])
def test_a_number_of_thousands_of_digits_is_the_file_s_error(rig_folder, fmt):
    """Python reads no whole number of over 4,300 digits; its refusal named no file and
    told the user to call sys.set_int_max_str_digits."""
    huge = "9" * 5001
    if fmt == "ros":
        path = rig_folder / "left.yaml"
        path.write_text(path.read_text().replace("image_width: 64", f"image_width: {huge}"))
        result, says = match_with(rig_folder, path, rig_folder / "right.yaml"), \
            ("left.yaml", "5,001 characters")
    else:
        path = rig_folder / "stereo.yml"
        text = path.read_text().replace("width: 64", "").replace("height: 48", "")
        path.write_text(text + f"image_size: [{huge}, 48]\n")
        result, says = match_with(rig_folder, path), ("stereo.yml", "whole numbers")
    assert_refused(result, *says)
    assert "set_int_max_str_digits" not in result.output
    assert not (rig_folder / "d.pfm").exists()


@pytest.mark.parametrize("size", [(100_000, 100_000), (8000, 6000)])
def test_a_rig_s_declared_size_is_checked_before_its_maps_are_built(rig_folder, size):
    for name in ("left.yaml", "right.yaml"):
        path = rig_folder / name
        path.write_text(path.read_text().replace("image_width: 64", f"image_width: {size[0]}")
                        .replace("image_height: 48", f"image_height: {size[1]}"))
    rigs = [rig_folder / "left.yaml", rig_folder / "right.yaml"]
    words = [f"{size[0]}x{size[1]} images", "left image is 64x48", "--rig"]
    assert_refused(match_with(rig_folder, *rigs), *words)
    result = run("rectify", rig_folder / "l.png", rig_folder / "r.png", "--rig", rigs[0],
                 "--rig", rigs[1], "-O", rig_folder / "rect")
    assert_refused(result, *words[:2])
    assert not (rig_folder / "rect").exists() or not any((rig_folder / "rect").iterdir())


def test_a_rectifier_holds_a_rig_s_size_to_the_pixel_limit():
    rig = random_rig(np.random.default_rng(5), size=(100_000, 100_000))
    with pytest.raises(csw.ImageError, match="safety limit"):
        Rectifier(rig)


def test_rig_reading_refuses_what_is_not_a_rig_file(tmp_path):
    with pytest.raises(ValueError, match="no such file"):
        read_rig(tmp_path / "missing.yml")
    with pytest.raises(ValueError, match="is a folder"):
        read_rig(tmp_path)
    rig = random_rig(np.random.default_rng(5))
    with pytest.raises(ValueError, match="two whole numbers"):
        Rig(rig.k1, rig.d1, rig.k2, rig.d2, rig.r, rig.t, (640,))


def test_16_bit_colour_goes_through_rectification_single_and_batch(rig_folder):
    """Pillow can't write 16-bit RGB: the rectified images are written with pypng, as
    16-bit RGB, and a batch holding such a pair does every pair."""
    from csw.io.images import read_colour

    rng = np.random.default_rng(3)
    colour = rng.integers(0, 65536, (SIZE[1], SIZE[0], 3)).astype(np.uint16)
    write_png(rig_folder / "c.png", colour)
    np.testing.assert_array_equal(read_colour(rig_folder / "c.png"), colour)
    rig = rig_folder / "stereo.yml"
    result = run("rectify", rig_folder / "c.png", rig_folder / "c.png", "--rig", rig,
                 "-O", rig_folder / "rect")
    assert result.exit_code == 0, result.output
    rectified = read_colour(rig_folder / "rect" / "left.png")
    assert rectified.dtype == np.uint16 and rectified.shape == colour.shape
    result = run("match", rig_folder / "c.png", rig_folder / "c.png", "--rig", rig, "-o",
                 rig_folder / "d.pfm", "--dmax", 8, "--rectified-left", rig_folder / "rl.png")
    assert result.exit_code == 0, result.output
    assert read_colour(rig_folder / "rl.png").dtype == np.uint16
    for side in ("L", "R"):
        (rig_folder / side).mkdir()
        for name in ("a.png", "b.png"):
            (rig_folder / side / name).write_bytes((rig_folder / "c.png").read_bytes()
                                                   if name == "a.png" else
                                                   (rig_folder / "l.png").read_bytes())
    result = run("rectify", rig_folder / "L", rig_folder / "R", "--rig", rig, "-O",
                 rig_folder / "batch")
    assert result.exit_code == 0 and "2 pair(s) rectified" in result.output, result.output


R_BLOCK = r"R: !!opencv-matrix\n(?:   .*\n|       .*\n)+"


@pytest.mark.parametrize("r, expected", [
    ("R: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n", np.eye(3)),
    ("R: [0, 0, 0]\n", np.eye(3)),  # a rotation vector
    ("R: [1, 0,\n   0, 0, 1, 0, 0, 0, 1]\n", np.eye(3)),  # a list over two lines
    ("R: [1, 0, 0, 0]\n", None),
])
def test_r_as_a_plain_list_is_read_as_that_list(rig_folder, r, expected):
    """A plain list is R's own numbers (9: a matrix, 3: a rotation vector, else an
    error), never the next matrix's data."""
    import re

    path = rig_folder / "stereo.yml"
    path.write_text(re.sub(R_BLOCK, r, path.read_text()))
    if expected is None:
        with pytest.raises(ValueError, match="R must be a 3x3 matrix or a rotation vector"):
            read_rig(path)
    else:
        np.testing.assert_array_equal(read_rig(path).r, expected)


def test_rectification_given_as_plain_lists_is_used_as_given(rig_folder):
    rig = read_rig(rig_folder / "stereo.yml")
    r1, r2, p1, p2, _ = stereo_rectify(rig.k1, rig.d1, rig.k2, rig.d2, SIZE, rig.r, rig.t)

    def listed(name, m):
        return f"{name}: [{', '.join(f'{v:.17g}' for v in np.ravel(m))}]\n"

    path = rig_folder / "stereo.yml"
    path.write_text(path.read_text() + "".join(
        listed(n, m) for n, m in (("R1", r1), ("R2", r2), ("P1", p1), ("P2", p2))))
    given = read_rig(path).rectification
    for read, made in zip(given, (r1, r2, p1, p2), strict=True):
        np.testing.assert_array_equal(read, made)


@pytest.mark.parametrize("scale, says", [(0.0, "is singular"), (1e300, "is not finite")])
def test_a_given_rectification_that_cannot_be_inverted_is_one_line(rig_folder, scale, says):
    """The maps invert P x R: zeros gave numpy's "Singular matrix" without the file's
    name, 1e300 an overflow's RuntimeWarning on stderr before the error."""
    rig = read_rig(rig_folder / "stereo.yml")
    r1, r2, p1, p2, _ = stereo_rectify(rig.k1, rig.d1, rig.k2, rig.d2, SIZE, rig.r, rig.t)
    path = rig_folder / "stereo.yml"
    path.write_text(path.read_text() + "".join(
        f"{n}: [{', '.join(f'{v * scale:.17g}' for v in np.ravel(m))}]\n"
        for n, m in (("R1", r1), ("R2", r2), ("P1", p1), ("P2", p2))))
    assert_refused(match_with(rig_folder, path), "stereo.yml", "left camera's", says)
    result = run("rectify", rig_folder / "l.png", rig_folder / "r.png", "--rig", path,
                 "-O", rig_folder / "new" / "rect")
    assert_refused(result, says)
    assert not (rig_folder / "new").exists()  # the folders it made for -O: gone again

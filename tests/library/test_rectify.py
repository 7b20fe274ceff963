"""Rectifying a calibrated rig's raw pairs (csw.camera.rectify, csw.camera.rig,
kernels/remap.py): the matrices and maps equal OpenCV's, the remap equals cv2.remap's
to a gray level, the rig files of each format read back to one rig, and a raw pair made
through a known rig matches to the truth's depth."""

import re

import cv2
import numpy as np
import pytest
from rig_fixtures import (
    SIZE,
    kalibr_text,
    kitti_text,
    random_rig,
    raw_from_rectified,
    ros_camera_info,
    write_opencv,
)

import csw
from csw.camera.rectify import Rectifier, rectify_maps, stereo_rectify
from csw.camera.rectify_files import rectify_files
from csw.camera.rig import Rig, read_rig
from csw.kernels.remap import remap


def opencv_rectify(rig, alpha):
    return cv2.stereoRectify(rig.k1, rig.d1, rig.k2, rig.d2, rig.size, rig.r,
                             rig.t.reshape(3, 1), flags=cv2.CALIB_ZERO_DISPARITY,
                             alpha=alpha)[:5]


@pytest.mark.parametrize("model", ["plumb_bob", "rational_polynomial"])
@pytest.mark.parametrize("alpha", [0.0, 0.5, 1.0])
def test_rectification_equals_opencv(model, alpha):
    rng = np.random.default_rng(hash((model, alpha)) % 2**32)
    for _ in range(4):
        rig = random_rig(rng, model)
        ours = stereo_rectify(rig.k1, rig.d1, rig.k2, rig.d2, rig.size, rig.r, rig.t, alpha)
        for name, a, b in zip(("R1", "R2", "P1", "P2", "Q"), ours, opencv_rectify(rig, alpha),
                              strict=True):
            assert np.max(np.abs(a - b)) <= 1e-6 * np.max(np.abs(b)), name


@pytest.mark.parametrize("balance", [0.0, 0.5, 1.0])
def test_fisheye_rectification_and_maps_equal_opencv(balance):
    from csw.camera.rectify import fisheye_rectify_maps, fisheye_stereo_rectify

    rng = np.random.default_rng(int(balance * 10) + 40)
    for _ in range(4):
        rig = random_rig(rng, "equidistant")
        d1, d2 = rig.d1.reshape(4, 1), rig.d2.reshape(4, 1)
        theirs = cv2.fisheye.stereoRectify(rig.k1, d1, rig.k2, d2, rig.size, rig.r,
                                           rig.t.reshape(3, 1),
                                           flags=cv2.CALIB_ZERO_DISPARITY, balance=balance)
        ours = fisheye_stereo_rectify(rig.k1, rig.d1, rig.k2, rig.d2, rig.size, rig.r,
                                      rig.t, balance)
        for name, a, b in zip(("R1", "R2", "P1", "P2", "Q"), ours, theirs[:5], strict=True):
            assert np.max(np.abs(a - b)) <= 1e-6 * np.max(np.abs(b)), name
        maps = fisheye_rectify_maps(rig.k1, rig.d1, ours[0], ours[2], rig.size)
        reference = cv2.fisheye.initUndistortRectifyMap(rig.k1, d1, ours[0], ours[2],
                                                        rig.size, cv2.CV_32FC1)
        inside = (reference[0] >= 0) & (reference[0] <= SIZE[0] - 1) & \
            (reference[1] >= 0) & (reference[1] <= SIZE[1] - 1)
        assert inside.mean() > 0.5
        for a, b in zip(maps, reference, strict=True):
            assert np.abs(a - b)[inside].max() <= 0.01


def test_undistorted_points_equal_opencv_where_the_model_folds_over_too():
    from csw.camera.rectify import undistort_points

    rng = np.random.default_rng(31)
    grid = np.array([(x, y) for x in np.linspace(0, 639, 9) for y in np.linspace(0, 479, 7)])
    for _ in range(6):  # a wide view: the corners of some rigs fold over (OpenCV gives up)
        rig = random_rig(rng, size=(640, 480))
        for k, d in ((rig.k1, rig.d1), (rig.k2, rig.d2)):
            theirs = cv2.undistortPoints(grid.reshape(-1, 1, 2), k, d).reshape(-1, 2)
            np.testing.assert_allclose(undistort_points(grid, k, d), theirs, rtol=1e-9,
                                       atol=1e-12)
    rig = random_rig(np.random.default_rng(31), size=(640, 480))
    for alpha in (0.0, 1.0):
        ours = stereo_rectify(rig.k1, rig.d1, rig.k2, rig.d2, rig.size, rig.r, rig.t, alpha)
        for a, b in zip(ours, opencv_rectify(rig, alpha), strict=True):
            assert np.max(np.abs(a - b)) <= 1e-6 * np.max(np.abs(b))


def test_maps_equal_opencv_where_inside():
    rig = random_rig(np.random.default_rng(3), "rational_polynomial")
    r1, _, p1, _, _ = stereo_rectify(rig.k1, rig.d1, rig.k2, rig.d2, rig.size, rig.r,
                                     rig.t, 0.5)
    ours = rectify_maps(rig.k1, rig.d1, r1, p1, rig.size)
    theirs = cv2.initUndistortRectifyMap(rig.k1, rig.d1, r1, p1, rig.size, cv2.CV_32FC1)
    inside = (theirs[0] >= 0) & (theirs[0] <= SIZE[0] - 1) & (theirs[1] >= 0) & \
        (theirs[1] <= SIZE[1] - 1)
    for a, b in zip(ours, theirs, strict=True):
        assert a.dtype == np.float32 and np.abs(a - b)[inside].max() <= 0.01


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_remap_equals_opencv_to_a_level_and_marks_what_has_no_source(dtype):
    rng = np.random.default_rng(5)
    rig = random_rig(rng)
    r1, _, p1, _, _ = stereo_rectify(rig.k1, rig.d1, rig.k2, rig.d2, rig.size, rig.r,
                                     rig.t, 1.0)  # alpha 1: a border without a source
    map_x, map_y = rectify_maps(rig.k1, rig.d1, r1, p1, rig.size)
    top = np.iinfo(dtype).max
    image = cv2.GaussianBlur((rng.random(SIZE[::-1]) * top).astype(dtype), (5, 5), 1.2)
    out, valid = remap(image, map_x, map_y, threads=2)
    reference = cv2.remap(image, map_x, map_y, cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_CONSTANT)
    inside = (map_x >= 0) & (map_x <= SIZE[0] - 1) & (map_y >= 0) & (map_y <= SIZE[1] - 1)
    np.testing.assert_array_equal(valid, inside)
    assert 0.5 < valid.mean() < 1.0
    close = np.abs(out.astype(np.int64) - reference)[valid] <= (1 if dtype == np.uint8
                                                                 else top // 255)
    assert close.mean() >= 0.999
    assert (out[~valid] == 0).all()


# ---------------------------------------------------------------- rig files, each format


def test_opencv_files_one_or_two_yaml_or_xml(tmp_path):
    rig = random_rig(np.random.default_rng(7))
    write_opencv(tmp_path / "stereo.yml", rig)
    write_opencv(tmp_path / "intrinsics.xml", rig, keys=("M1", "D1", "M2", "D2"))
    write_opencv(tmp_path / "extrinsics.xml", rig, keys=("R", "T"))
    text = (tmp_path / "stereo.yml").read_text()  # OpenCV 5 writes "%YAML 1.2"; 4 "%YAML:1.0"
    (tmp_path / "stereo4.yml").write_text(text.replace("%YAML 1.2", "%YAML:1.0"))
    for paths in ([tmp_path / "stereo.yml"], [tmp_path / "stereo4.yml"],
                  [tmp_path / "intrinsics.xml", tmp_path / "extrinsics.xml"]):
        read = read_rig(*paths, size=SIZE)
        for name in ("k1", "d1", "k2", "d2", "r", "t"):
            np.testing.assert_allclose(getattr(read, name), getattr(rig, name), rtol=1e-12)
        assert read.size == SIZE and read.rectification is None


def test_a_file_s_own_rectification_is_used_as_given(tmp_path):
    rig = random_rig(np.random.default_rng(8))
    r1, r2, p1, p2, q = opencv_rectify(rig, 0.3)
    write_opencv(tmp_path / "s.yml", rig, {"R1": r1, "R2": r2, "P1": p1, "P2": p2},
                 keys=("M1", "D1", "M2", "D2", "R", "T", "R1", "R2", "P1", "P2"))
    rect = Rectifier(read_rig(tmp_path / "s.yml", size=SIZE), alpha=0)  # alpha ignored
    np.testing.assert_allclose(rect.p1, p1)
    assert rect.calibration.baseline == pytest.approx(0.12, rel=0.05)


def test_ros_camera_info_gives_back_r_and_t(tmp_path):
    rig = random_rig(np.random.default_rng(9))
    r1, r2, p1, p2, _ = opencv_rectify(rig, 0.0)
    (tmp_path / "left.yaml").write_text(ros_camera_info(rig.k1, rig.d1, r1, p1, SIZE))
    (tmp_path / "right.yaml").write_text(ros_camera_info(rig.k2, rig.d2, r2, p2, SIZE))
    read = read_rig(tmp_path / "left.yaml", tmp_path / "right.yaml")
    np.testing.assert_allclose(read.r, rig.r, atol=1e-9)
    np.testing.assert_allclose(read.t, rig.t, atol=1e-9)
    assert read.rectification is not None


def test_kitti_and_kalibr(tmp_path):
    rig = random_rig(np.random.default_rng(10))
    # KITTI: camera 0 is the left one here (R_02 = I, T_02 = 0).
    (tmp_path / "calib_cam_to_cam.txt").write_text(kitti_text(rig))
    kitti = read_rig(tmp_path / "calib_cam_to_cam.txt")
    np.testing.assert_allclose(kitti.r, rig.r, atol=1e-12)
    np.testing.assert_allclose(kitti.t, rig.t, atol=1e-12)
    (tmp_path / "camchain.yaml").write_text(kalibr_text(rig))
    kalibr = read_rig(tmp_path / "camchain.yaml")
    np.testing.assert_allclose(kalibr.r, rig.r, atol=1e-12)
    np.testing.assert_allclose(kalibr.t, rig.t, atol=1e-12)  # not negated
    assert kalibr.units == "m" and kalibr.size == SIZE


@pytest.mark.parametrize("broken, message", [
    (lambda t: t.replace("M2", "X2"), "no M2"),
    (lambda t: re.sub(r"(D1:.*?data: \[ *)([-+\d.e]+)", r"\1.nan", t, count=1,
                      flags=re.DOTALL), "NaN"),
    (lambda t: re.sub(r"(D2:.*?data: \[ *)([-+\d.e]+)", r"\1 1, 2,", t, count=1,
                      flags=re.DOTALL), "4, 5, 8, 12 or 14 coefficients"),
])
def test_a_broken_rig_file_is_one_line(tmp_path, broken, message):
    rig = random_rig(np.random.default_rng(11))
    write_opencv(tmp_path / "s.yml", rig)
    path = tmp_path / "s.yml"
    path.write_text(broken(path.read_text()))
    with pytest.raises(ValueError, match=message) as error:
        Rectifier(read_rig(path, size=SIZE))
    assert "\n" not in str(error.value) and "s.yml" in str(error.value)


def test_rigs_that_can_t_be_rectified_say_why():
    rig = random_rig(np.random.default_rng(12))
    with pytest.raises(ValueError, match="no baseline"):
        Rig(rig.k1, rig.d1, rig.k2, rig.d2, rig.r, np.zeros(3), SIZE)
    with pytest.raises(ValueError, match="unknown distortion model"):
        Rig(rig.k1, rig.d1, rig.k2, rig.d2, rig.r, rig.t, SIZE, "division")
    with pytest.raises(ValueError, match="singular"):
        Rig(np.zeros((3, 3)), rig.d1, rig.k2, rig.d2, rig.r, rig.t, SIZE)
    with pytest.raises(ValueError, match="is for 320x240"):
        Rectifier(rig).rectify(np.zeros((10, 10), np.uint8), np.zeros((10, 10), np.uint8))


# ------------------------------------------------------------------------- the chain


def test_a_raw_pair_through_a_known_rig_matches_to_the_truth_s_depth(tmp_path):
    """csw synth's scene moved 40 disparities nearer (d 41..80: 1% of depth is 0.4 px
    and more, where subpixel matching is good to 0.16 px on 95% of pixels), made raw
    through a distorted, rotated rig, rectified, matched: depth within 1% on 95% of the
    valid pixels, and disparities as good as matching the rectified pair itself."""
    shift = 40
    rig = random_rig(np.random.default_rng(13), size=(480, 360))
    r1, r2, p1, p2, _ = stereo_rectify(rig.k1, rig.d1, rig.k2, rig.d2, rig.size, rig.r,
                                       rig.t, 0.0)
    left, right, gt, _ = csw.synthetic_pair(480, 360, dmax=40, seed=4)
    right = np.pad(right[:, shift:], ((0, 0), (0, shift)), mode="edge")  # d + shift
    gt = gt + shift
    raw_left = raw_from_rectified(left, rig.k1, rig.d1, r1, p1)
    raw_right = raw_from_rectified(right, rig.k2, rig.d2, r2, p2)
    rect = Rectifier(rig, alpha=0.0)
    options = dict(dmax=48 + shift, subpixel="parabola")
    result = csw.match(*rect.rectify(raw_left, raw_right), **options)
    depth = csw.depth(result.disparity, rect.calibration)
    truth = rect.calibration.focal * rect.calibration.baseline / gt
    both = np.isfinite(depth) & np.isfinite(truth)
    assert both.mean() > 0.8
    assert np.mean(np.abs(depth[both] / truth[both] - 1) <= 0.01) >= 0.95
    direct = csw.match(left, right, **options).disparity
    errors = [np.nanpercentile(np.abs(d - gt), 95) for d in (result.disparity, direct)]
    assert errors[0] <= errors[1] + 0.03


def test_rectify_files_writes_a_pair_csw_match_reads_with_its_calibration(tmp_path):
    from csw.io import write_png

    rig = random_rig(np.random.default_rng(14))
    left, right, _, _ = csw.synthetic_pair(*SIZE, dmax=20, seed=2)
    write_png(tmp_path / "l.png", left)
    write_png(tmp_path / "r.png", right)
    write_opencv(tmp_path / "stereo.yml", rig)
    rect = rectify_files(tmp_path / "l.png", tmp_path / "r.png",
                         read_rig(tmp_path / "stereo.yml", size=SIZE), tmp_path / "out")
    calib = csw.read_calibration(tmp_path / "out" / "calib.txt")
    assert calib.focal == pytest.approx(rect.calibration.focal)
    assert calib.baseline == pytest.approx(rect.calibration.baseline)
    np.testing.assert_array_equal(csw.read_image(tmp_path / "out" / "left.png"),
                                  rect.rectify(left, right)[0])


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_remap_equals_the_oracle_bit_for_bit(dtype):
    from oracle import remap_bilinear

    rng = np.random.default_rng(17)
    image = rng.integers(0, np.iinfo(dtype).max + 1, (23, 31), dtype=dtype)
    map_x = rng.uniform(-2, 33, (17, 29)).astype(np.float32)
    map_y = rng.uniform(-2, 25, (17, 29)).astype(np.float32)
    map_x[0, :4] = [0, 30, np.nan, 29.999998]  # the edges, and a NaN
    map_y[0, :4] = [0, 22, 5, 22]
    out, valid = remap(image, map_x, map_y, threads=2)
    expected, expected_valid = remap_bilinear(image, map_x, map_y)
    np.testing.assert_array_equal(valid, expected_valid)
    np.testing.assert_array_equal(out, expected)


@pytest.mark.slow
def test_chessboard_corners_land_on_the_same_rows_as_with_opencv_s_rectification():
    """A chessboard at 30 disparities seen raw through a distorted, rotated rig, then
    rectified by csw and by OpenCV's own chain (stereoRectify, initUndistortRectifyMap,
    remap): the corners found in the two rectified images lie on the same rows as well
    with csw's as with OpenCV's (RMS row difference at most 0.03 px above it), and far
    better than unrectified."""
    size = (640, 480)
    rig = random_rig(np.random.default_rng(31), size=size)
    board = np.kron((np.indices((8, 11)).sum(axis=0) % 2) * 200 + 28,
                    np.ones((36, 36))).astype(np.uint8)
    left = np.full(size[::-1], 128, np.uint8)
    left[96:96 + board.shape[0], 120:120 + board.shape[1]] = board
    left = cv2.GaussianBlur(left, (5, 5), 1.0)
    right = np.roll(left, -30, axis=1)  # d = 30 everywhere on the board
    r1, r2, p1, p2, _ = opencv_rectify(rig, 0.0)
    raw = (raw_from_rectified(left, rig.k1, rig.d1, r1, p1),
           raw_from_rectified(right, rig.k2, rig.d2, r2, p2))

    def row_rms(pair):
        found = [cv2.findChessboardCorners(image, (10, 7))[1] for image in pair]
        assert all(f is not None for f in found)
        refined = [cv2.cornerSubPix(image, f, (5, 5), (-1, -1), (3, 30, 1e-3))
                   for image, f in zip(pair, found, strict=True)]
        rows = [r.reshape(-1, 2)[:, 1] for r in refined]
        return float(np.sqrt(np.mean((rows[0] - rows[1]) ** 2)))

    ours = row_rms(Rectifier(rig, alpha=0.0).rectify(*raw))
    maps = [cv2.initUndistortRectifyMap(k, d, r, p, size, cv2.CV_32FC1)
            for k, d, r, p in ((rig.k1, rig.d1, r1, p1), (rig.k2, rig.d2, r2, p2))]
    theirs = row_rms([cv2.remap(image, *m, cv2.INTER_LINEAR)
                      for image, m in zip(raw, maps, strict=True)])
    print(f"row RMS: csw {ours:.3f} px, OpenCV {theirs:.3f} px, raw {row_rms(raw):.2f} px")
    assert ours <= theirs + 0.03
    assert ours < 0.25 * row_rms(raw)


@pytest.mark.parametrize("model", ["plumb_bob", "equidistant"])
def test_rectified_images_equal_cv2_remap_with_opencv_s_fixed_maps(model):
    """The maps rounded to 1/32 pixel from their doubles as initUndistortRectifyMap's
    CV_16SC2 maps are: csw rectify equals cv2.remap on every pixel with a source, sharp
    edges included (rounding float32 maps instead left 0.01-0.15% of pixels 2-6 levels
    off)."""
    rng = np.random.default_rng(11)
    rig = random_rig(rng, model)
    rect = Rectifier(rig)
    blocks = (rng.random((SIZE[1] // 6, SIZE[0] // 6)) > 0.5).astype(np.uint8) * 255
    image = cv2.GaussianBlur(cv2.resize(blocks, SIZE, interpolation=cv2.INTER_NEAREST),
                             (3, 3), 0.6)
    make = cv2.fisheye.initUndistortRectifyMap if model == "equidistant" else \
        cv2.initUndistortRectifyMap
    maps = make(rig.k1, rig.d1, rect.r1, rect.p1, rig.size, cv2.CV_16SC2)
    theirs = cv2.remap(image, *maps, cv2.INTER_LINEAR)
    ours = rect.rectify_one(image, 0)
    same = (ours == theirs)[rect.valid[0]]
    assert same.mean() >= 0.9999, same.mean()


# ------------------------------------------- details a one-line change would break (issue 39)


def test_a_non_zero_ninth_distortion_coefficient_is_refused():
    from csw.camera.rectification import coefficients

    tilted = np.zeros(12)
    tilted[8] = 0.01  # s1, the thin-prism model's first: csw's model stops at k6
    with pytest.raises(ValueError, match="coefficients"):
        coefficients(tilted)
    assert coefficients(np.r_[np.arange(1, 9) * 0.01, np.zeros(4)])[7] == pytest.approx(0.08)


def test_invalidate_drops_exactly_the_pixels_whose_match_has_no_source():
    """The left pixel's own validity, and its match x - d in the right image's: checked
    against a brute-force loop, on a rig whose two cameras' valid areas differ."""
    rig = random_rig(np.random.default_rng(14))
    rect = Rectifier(rig, alpha=1.0)
    valid_left, valid_right = rect.valid
    assert not valid_left.all() and not (valid_left == valid_right).all()
    rng = np.random.default_rng(1)
    disparity = rng.uniform(0, 40, SIZE[::-1]).astype(np.float32)
    disparity[rng.random(disparity.shape) < 0.1] = np.nan
    expected = disparity.copy()
    for y, x in zip(*np.nonzero(np.isfinite(disparity)), strict=True):
        column = int(np.round(x - disparity[y, x]))
        if not valid_left[y, x] or not (0 <= column < SIZE[0] and valid_right[y, column]):
            expected[y, x] = np.nan
    rect.invalidate(disparity)
    np.testing.assert_array_equal(np.isnan(disparity), np.isnan(expected))


@pytest.mark.parametrize("raw", [(10, 1), (1, 10)])
def test_the_remap_refuses_a_raw_image_under_2x2(raw):
    from csw.kernels.remap import fixed_maps

    maps = np.zeros((4, 4), np.float32)
    with pytest.raises(ValueError, match="at least 2x2"):
        fixed_maps(maps, maps, raw)


def test_a_point_on_the_last_column_or_row_blends_from_the_pixel_before_it():
    """offset is kept one short of the last column and row: the point takes weight 32
    on the next pixel, never a pixel past the row's end."""
    from csw.kernels.remap import fixed_maps

    height, width = 5, 7
    map_x = np.array([[width - 1, 0.0]], np.float32)
    map_y = np.array([[0.0, height - 1]], np.float32)
    fixed = fixed_maps(map_x, map_y, (height, width))
    assert fixed.offset[0, 0] == width - 2 and fixed.weights[0, 0] & 63 == 32
    assert fixed.offset[0, 1] == (height - 2) * width and fixed.weights[0, 1] >> 6 == 32
    image = np.arange(height * width, dtype=np.uint8).reshape(height, width)
    out, valid = remap(image, fixed, None)
    assert valid.all() and out.tolist() == [[width - 1, (height - 1) * width]]


def test_a_vertical_rig_is_refused():
    rig = random_rig(np.random.default_rng(12))
    with pytest.raises(ValueError, match="vertical rig"):
        Rig(rig.k1, rig.d1, rig.k2, rig.d2, rig.r, np.array([0.001, 0.12, 0.0]), SIZE)
    forward = Rig(rig.k1, rig.d1, rig.k2, rig.d2, rig.r, np.array([-0.12, 0.01, 0.3]), SIZE)
    assert forward.baseline > 0.3  # a large Tz is no vertical rig


def test_kitti_with_camera_0_elsewhere_and_its_own_rectification(tmp_path):
    """R_02, T_02 not the identity and zero: left to right is R3 R2^T and T3 - R T2; the
    file's R_rect and P_rect are used as given, P_rect's offsets made relative."""
    rig = random_rig(np.random.default_rng(10))
    r02 = csw.camera.rectify.rodrigues(np.array([0.02, -0.05, 0.01]))
    r1, r2, p1, p2, _ = opencv_rectify(rig, 0.0)
    p2_kitti, p3_kitti = p1.copy(), p2.copy()
    p2_kitti[:, 3] += [4.5, 0.1, 0.002]  # camera 2's own offset from camera 0
    p3_kitti[:, 3] += [4.5, 0.1, 0.002]
    (tmp_path / "calib_cam_to_cam.txt").write_text(
        kitti_text(rig, r02, np.array([0.06, -0.01, 0.02]), (r1, r2, p2_kitti, p3_kitti)))
    kitti = read_rig(tmp_path / "calib_cam_to_cam.txt")
    np.testing.assert_allclose(kitti.r, rig.r, atol=1e-12)
    np.testing.assert_allclose(kitti.t, rig.t, atol=1e-12)
    given = kitti.rectification
    np.testing.assert_allclose(given[0], r1, atol=1e-12)
    np.testing.assert_allclose(given[1], r2, atol=1e-12)
    np.testing.assert_allclose(given[2], np.c_[p1[:, :3], np.zeros(3)], atol=1e-9)
    np.testing.assert_allclose(given[3], p2, atol=1e-9)

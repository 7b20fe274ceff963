"""From disparity to 3-D: calibrations read from what people have, depth from
Z = f B / (d + doffs), points as OpenCV's reprojectImageTo3D gives them, binary PLY."""

import numpy as np
import pytest

import csw
from csw.camera.calibration import from_q, read_calibration
from csw.camera.geometry import depth, point_cloud, write_ply

cv2 = pytest.importorskip("cv2")
plyfile = pytest.importorskip("plyfile")

MIDDLEBURY = """cam0=[3997.684 0 1176.728; 0 3997.684 1011.728; 0 0 1]
cam1=[3997.684 0 1307.839; 0 3997.684 1011.728; 0 0 1]
doffs=131.111
baseline=193.001
width=60
height=40
ndisp=280
isint=0
vmin=31
vmax=257
"""
KITTI_OBJECT = """P0: 7.215377e+02 0.000000e+00 6.095593e+02 0.000000e+00 0.000000e+00 7.215377e+02 1.728540e+02 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00
P1: 7.215377e+02 0.000000e+00 6.095593e+02 -3.875744e+02 0.000000e+00 7.215377e+02 1.728540e+02 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00
P2: 7.215377e+02 0.000000e+00 6.095593e+02 4.485728e+01 0.000000e+00 7.215377e+02 1.728540e+02 2.163791e-01 0.000000e+00 0.000000e+00 1.000000e+00 2.745884e-03
P3: 7.215377e+02 0.000000e+00 6.095593e+02 -3.395242e+02 0.000000e+00 7.215377e+02 1.728540e+02 2.199936e+00 0.000000e+00 0.000000e+00 1.000000e+00 2.729905e-03
"""
KITTI_CAM_TO_CAM = """calib_time: 09-Jan-2012 13:57:47
S_rect_02: 6.000000e+01 4.000000e+01
P_rect_02: 7.215377e+02 0.000000e+00 6.095593e+02 4.485728e+01 0.000000e+00 7.215377e+02 1.728540e+02 2.163791e-01 0.000000e+00 0.000000e+00 1.000000e+00 2.745884e-03
P_rect_03: 7.215377e+02 0.000000e+00 6.095593e+02 -3.395242e+02 0.000000e+00 7.215377e+02 1.728540e+02 2.199936e+00 0.000000e+00 0.000000e+00 1.000000e+00 2.729905e-03
"""
Q = np.array([[1, 0, 0, -30.5], [0, 1, 0, -19.5], [0, 0, 0, 700.0],
              [0, 0, 1 / 0.12, -1.5 / 0.12]])


def q_yaml(q):
    data = ", ".join(f"{v:.17g}" for v in q.ravel())
    return f"%YAML:1.0\n---\nQ: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n   data: [ {data} ]\n"


def q_xml(q):
    data = " ".join(f"{v:.17g}" for v in q.ravel())
    return ('<?xml version="1.0"?>\n<opencv_storage>\n<Q type_id="opencv-matrix">\n'
            f"  <rows>4</rows>\n  <cols>4</cols>\n  <dt>d</dt>\n  <data>{data}</data></Q>\n"
            "</opencv_storage>\n")


@pytest.fixture
def disparity():
    rng = np.random.default_rng(3)
    disp = rng.uniform(1, 60, (40, 60)).astype(np.float32)
    disp[rng.random(disp.shape) < 0.1] = np.nan
    return disp


def test_middlebury_calib_txt(tmp_path, disparity):
    (tmp_path / "calib.txt").write_text(MIDDLEBURY)
    calib = read_calibration(tmp_path / "calib.txt")
    assert (calib.focal, calib.baseline, calib.doffs, calib.units, calib.ndisp) == \
        (3997.684, 193.001, 131.111, "mm", 280)
    want = 3997.684 * 193.001 / (disparity.astype(np.float64) + 131.111)
    np.testing.assert_allclose(depth(disparity, calib), want.astype(np.float32), rtol=1e-6)
    np.testing.assert_allclose(depth(disparity, calib, units="m"), want / 1000, rtol=1e-6)


@pytest.mark.parametrize("text", [KITTI_OBJECT, KITTI_CAM_TO_CAM])
def test_kitti_p2_p3(tmp_path, text, disparity):
    (tmp_path / "calib.txt").write_text(text)
    calib = read_calibration(tmp_path / "calib.txt")
    baseline = (4.485728e+01 + 3.395242e+02) / 7.215377e+02
    assert calib.units == "m" and abs(calib.baseline - baseline) < 1e-12 and calib.doffs == 0
    want = 7.215377e+02 * baseline / disparity.astype(np.float64)
    np.testing.assert_allclose(depth(disparity, calib), want.astype(np.float32), rtol=1e-6)


@pytest.mark.parametrize("write", ["yaml", "xml", "npy"])
def test_opencv_q_equals_reproject_image_to_3d(tmp_path, write, disparity):
    path = tmp_path / f"stereo.{write if write != 'yaml' else 'yml'}"
    if write == "npy":
        np.save(path, Q)
    else:
        path.write_text(q_yaml(Q) if write == "yaml" else q_xml(Q))
    calib = read_calibration(path)
    opencv = cv2.reprojectImageTo3D(np.nan_to_num(disparity, nan=-1), Q)
    z = depth(disparity, calib)
    finite = np.isfinite(z)
    np.testing.assert_allclose(z[finite], opencv[..., 2][finite], rtol=1e-6)
    points, colours = point_cloud(disparity, calib)
    assert colours is None and len(points) == finite.sum()
    np.testing.assert_allclose(points, opencv[finite], rtol=1e-5, atol=1e-5)


def test_a_cloud_has_one_point_per_valid_pixel_within_max_depth(tmp_path, disparity):
    calib = from_q(Q)
    rng = np.random.default_rng(4)
    image = rng.integers(0, 255, (40, 60, 3)).astype(np.uint8)
    points, colours = point_cloud(disparity, calib, image, max_depth=10.0)
    z = depth(disparity, calib)
    kept = np.isfinite(z) & (z <= 10.0)
    assert 0 < len(points) == kept.sum() < np.isfinite(z).sum()
    np.testing.assert_array_equal(colours, image[kept])
    write_ply(tmp_path / "c.ply", points, colours)
    vertices = plyfile.PlyData.read(str(tmp_path / "c.ply"))["vertex"]
    assert vertices.count == len(points)
    got = np.stack([vertices[a] for a in "xyz"], axis=1)
    np.testing.assert_array_equal(got, points)
    np.testing.assert_array_equal(np.stack([vertices[c] for c in ("red", "green", "blue")],
                                           axis=1), colours)
    header = (tmp_path / "c.ply").read_bytes()[:200]
    assert b"format binary_little_endian 1.0" in header


@pytest.mark.parametrize("text, message", [
    ("cam0=[1 0 2; 0 1 3; 0 0 1]\nwidth=4\n", "without baseline"),
    ("cam0=[1 0 2; 0 1 3; 0 0 1]\nbaseline=0\ndoffs=0\n", "baseline is 0"),
    ("cam0=[0 0 2; 0 0 3; 0 0 1]\nbaseline=5\ndoffs=0\n", "focal length is 0"),
    ("P2: 1 0 0 0 0 1 0 0 0 0 1 0\n", "without P3"),
    (q_yaml(np.zeros((4, 4))), "not invertible"),
    ("Q: !!opencv-matrix\n   data: [ 1, 2, 3 ]\n", "4x4"),
    ("hello\n", "not a calibration"),
])
def test_bad_calibrations_say_what_is_wrong(tmp_path, text, message):
    (tmp_path / "c.txt").write_text(text)
    with pytest.raises(ValueError, match=message):
        read_calibration(tmp_path / "c.txt")


def test_a_calibration_for_another_size_is_refused(tmp_path, disparity):
    (tmp_path / "calib.txt").write_text(MIDDLEBURY.replace("width=60", "width=2964"))
    with pytest.raises(ValueError, match="2964x40 images but the disparity map is 60x40"):
        depth(disparity, read_calibration(tmp_path / "calib.txt"))


def test_the_library_entry_names(disparity):
    calib = csw.Calibration(focal=100.0, baseline=0.5)  # principal point: the centre
    z = csw.depth(disparity, calib)
    np.testing.assert_allclose(z, 50.0 / disparity, rtol=1e-6)
    points, _ = csw.point_cloud(disparity, calib)
    assert np.isclose(points[:, 0].mean(), 0, atol=1.0)  # centred on the optical axis

"""csw.camera.calibrate: chessboard pairs made through a known rig give that rig back,
in a file that csw's reader and OpenCV's FileStorage both read; bad sets of views are
refused with one reason."""

import cv2
import numpy as np
import pytest
from calib_fixtures import BOARD, SQUARE, known_rig, views

from csw.camera import calibrate as cal
from csw.camera.rig import read_rig


@pytest.fixture(scope="module")
def pinhole_views():
    return views(known_rig(), 8)


@pytest.mark.parametrize("model, rig_model", [("radtan", "plumb_bob"),
                                              ("fisheye", "equidistant")])
def test_known_rig_comes_back(model, rig_model, pinhole_views):
    truth = known_rig(rig_model)
    pairs = pinhole_views if model == "radtan" else views(truth, 8)
    result = cal.calibrate(pairs, BOARD, SQUARE, "mm", model)
    rig = result.rig
    assert result.rejected == [] and len(result.views) == 8
    assert rig.model == rig_model and rig.units == "mm" and rig.size == truth.size
    assert rig.baseline == pytest.approx(truth.baseline, rel=0.005)
    for got, want in ((rig.k1, truth.k1), (rig.k2, truth.k2)):
        assert got[0, 0] == pytest.approx(want[0, 0], rel=0.01)
        assert got[:2, 2] == pytest.approx(want[:2, 2], abs=3)
    assert result.rms < 0.25 and result.row_error < 0.25


def test_the_file_reads_in_csw_and_in_opencv(tmp_path, pinhole_views):
    result = cal.calibrate(pinhole_views, BOARD, SQUARE, "mm")
    path = tmp_path / "rig.yml"
    path.write_text(cal.rig_text(result))
    rig = read_rig(path)
    assert rig.units == "mm" and rig.size == result.rig.size and rig.model == "plumb_bob"
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    for key, value in (("M1", result.rig.k1), ("D1", result.rig.d1), ("M2", result.rig.k2),
                       ("D2", result.rig.d2), ("R", result.rig.r), ("T", result.rig.t)):
        np.testing.assert_array_equal(storage.getNode(key).mat().ravel(), value.ravel())
        np.testing.assert_array_equal(getattr(rig, {"M1": "k1", "D1": "d1", "M2": "k2",
                                                    "D2": "d2", "R": "r", "T": "t"}[key])
                                      .ravel(), value.ravel())
    assert storage.getNode("units").string() == "mm"
    assert int(storage.getNode("width").real()) == result.rig.size[0]
    storage.release()
    path.write_text(cal.rig_text(cal.calibrate(pinhole_views, BOARD, 1.0)))
    assert read_rig(path).units is None  # "units: none": never invented


def test_views_without_the_board_are_rejected_and_said(pinhole_views):
    blank = np.full_like(pinhole_views[0][1], 128)
    pairs = [*pinhole_views, ("blank", blank, pinhole_views[0][2]),
             ("mixed", pinhole_views[1][1], pinhole_views[0][2])]
    result = cal.calibrate(pairs, BOARD, SQUARE, "mm")
    reasons = dict(result.rejected)
    assert reasons["blank"] == "no 9x6 board found in the left image"
    assert "far above the other views'" in reasons["mixed"]
    assert result.rig.baseline == pytest.approx(60.0, rel=0.005)


@pytest.mark.parametrize("change, message", [
    (lambda p: p[:3], r"found in both images of 3 pair\(s\); calibrating needs at least 4"),
    (lambda p: [(n, b, a) for n, a, b in p], "the left and right images are swapped"),
    (lambda p: [*p, ("small", p[0][1][:-2], p[0][2][:-2])], "small: the left image is "
                                                            "480x358 but the first is 480x360"),
])
def test_bad_sets_of_views_are_refused(pinhole_views, change, message):
    with pytest.raises(ValueError, match=message):
        cal.calibrate(change(pinhole_views), BOARD, SQUARE, "mm")


@pytest.mark.parametrize("text, units, want", [
    ("25mm", None, (25.0, "mm")), ("25mm", "m", (0.025, "m")), ("0.025", "m", (0.025, "m")),
    ("2.5", None, (2.5, None)), ("1in", "mm", (25.4, "mm")),
])
def test_square_sizes(text, units, want):
    size, got = cal.parse_square(text, units)
    assert (size, got) == (pytest.approx(want[0]), want[1])


@pytest.mark.parametrize("text", ["0mm", "-3mm", "25 furlongs", "mm", ""])
def test_bad_square_sizes(text):
    with pytest.raises(ValueError):
        cal.parse_square(text)


@pytest.mark.parametrize("text", ["9", "9x1", "ax6", "9x6x2", "9" * 5000 + "x6"])
def test_bad_boards(text):
    """The board's own message, whatever the text: Python's about its 4,300-digit limit
    on whole numbers named no option, and the value is not repeated at length."""
    with pytest.raises(ValueError, match="inner corners") as caught:
        cal.parse_board(text)
    assert len(str(caught.value)) < 200

"""Stereo calibration from chessboard pairs: OpenCV finds the corners
(findChessboardCorners, cornerSubPix) and solves (calibrateCamera for each camera, then
stereoCalibrate refining both; cv2.fisheye for fisheye lenses); csw checks the result
with its own rectification and writes it as OpenCV's stereo YAML (M1 D1 M2 D2 R T, the
image size and the units of T), which :func:`csw.read_rig` and cv2.FileStorage read.

>>> result = calibrate(csw.jobs_from_folders("left", "right"), (9, 6), 25, "mm")
>>> result.rms, result.row_error, result.rejected
>>> write_rig_file("rig.yml", result)

OpenCV is an optional extra (``pip install 'csw-stereo[calibrate]'``): a chessboard detector is
not this project's job.
"""

import re
from dataclasses import dataclass

import numpy as np

from .calibration import UNITS
from .rig import Rig

MODELS = {"radtan": "plumb_bob", "rational": "rational_polynomial", "fisheye": "equidistant"}
MIN_VIEWS = 4  # pairs with the board found in both images, at the least
# A view whose reprojection RMS is above both of these (px, times the other views'
# median) is left out, and the solve made again.
OUTLIER_PX, OUTLIER_TIMES = 1.0, 3.0
CRITERIA = (3, 30, 0.01)  # cv2.TERM_CRITERIA_EPS | COUNT, as OpenCV's stereo sample


def _cv2():
    try:
        import cv2
    except ImportError:
        raise ImportError("csw calibrate needs OpenCV: "
                          "pip install 'csw-stereo[calibrate]'") from None
    return cv2


def parse_board(text):
    """(columns, rows) of inner corners from "9x6"; ValueError otherwise."""
    found = re.fullmatch(r"\s*(\d{1,9})\s*[xX]\s*(\d{1,9})\s*", str(text))
    if not found or min(int(found.group(1)), int(found.group(2))) < 2:
        raise ValueError(f"the board is its inner corners, COLUMNSxROWS (e.g. 9x6), each at "
                         f"least 2, not {str(text)[:40]!r}")
    return int(found.group(1)), int(found.group(2))


def parse_square(text, units=None):
    """(size, units) of a board's square from "25mm" or "0.025" (units None, or ``units``
    when given): the size in ``units`` where both are given (25mm with units m: 0.025).
    ValueError for a size that is not a positive number or an unknown unit."""
    found = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][-+]?\d+)?)\s*([a-z]*)\s*", str(text))
    if not found or not float(found.group(1)) > 0:
        raise ValueError(f"the square is a size > 0 with its units, e.g. 25mm or 0.025 "
                         f"(with --units m), not {text!r}")
    size, given = float(found.group(1)), found.group(2) or None
    for unit in (given, units):
        if unit is not None and unit not in UNITS:
            raise ValueError(f"unknown units {unit!r}; use {', '.join(UNITS)}")
    if given is not None and units is not None:
        size *= UNITS[given] / UNITS[units]
    return size, units or given


def find_corners(gray, board):
    """The board's inner corners (n, 2) float32 in ``gray`` (uint8 (H, W)), refined to
    sub-pixel as OpenCV's stereo sample does, or None when the board isn't found."""
    cv2 = _cv2()
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    found, points = cv2.findChessboardCorners(gray, board, flags=flags)
    if not found:
        return None
    return cv2.cornerSubPix(gray, points, (11, 11), (-1, -1), CRITERIA).reshape(-1, 2)


def board_points(board, square):
    """The board's corners (n, 3) float32 in its own plane, ``square`` apart, in the order
    findChessboardCorners gives them."""
    points = np.zeros((board[0] * board[1], 3), np.float32)
    points[:, :2] = np.indices(board).T.reshape(-1, 2) * square
    return points


@dataclass
class Result:
    """A calibration: the rig; rms: the stereo reprojection RMS (px); views: [(name,
    left RMS, right RMS)] of the views used; rejected: [(name, why)]; row_error: the RMS
    of |y_left - y_right| of the corners once rectified by csw (px); board, square."""

    rig: Rig
    rms: float
    views: list
    rejected: list
    row_error: float
    board: tuple
    square: float


def _gray(image):
    image = np.asarray(image)
    if image.ndim == 3:
        image = image[..., :3].astype(np.float64) @ np.array([0.299, 0.587, 0.114])
        image = np.round(image)
    if image.dtype != np.uint8:
        top = 255.0 if image.dtype.kind == "f" else float(np.iinfo(image.dtype).max)
        image = np.clip(np.round(image.astype(np.float64) * (255.0 / top)), 0, 255)
    return np.ascontiguousarray(image, np.uint8)


def detect(pairs, board):
    """Corners of every pair (name, left image, right image) whose board is found in
    both: ([(name, left (n, 2), right (n, 2))], [(name, why)], size).  A pair that can't
    be read is rejected too; ValueError for images of other sizes than the first's."""
    used, rejected, size = [], [], None
    for name, left, right in pairs:
        if isinstance(left, str):  # why the pair can't be had
            rejected.append((name, left))
            continue
        left, right = _gray(left), _gray(right)
        for image, side in ((left, "left"), (right, "right")):
            shape = image.shape[::-1]
            if size is None:
                size = shape
            if shape != size:
                raise ValueError(f"{name}: the {side} image is {shape[0]}x{shape[1]} but the "
                                 f"first is {size[0]}x{size[1]}; calibrate one size at a time")
        a, b = find_corners(left, board), find_corners(right, board)
        if a is None or b is None:
            which = "either image" if a is None and b is None else \
                ("the left image" if a is None else "the right image")
            rejected.append((name, f"no {board[0]}x{board[1]} board found in {which}"))
            continue
        used.append((name, a, b))
    return used, rejected, size


def solve(used, board, square, size, model="radtan"):
    """OpenCV's calibration of the corners ``used``: (rms, K1, D1, K2, D2, R, T,
    [(left RMS, right RMS)] per view).  Each camera alone first, then both refined
    together with R and T (the intrinsics are not held fixed: held, the rows stay apart)."""
    cv2 = _cv2()
    obj = board_points(board, square)
    lefts, rights = [a for _, a, _ in used], [b for _, _, b in used]
    if model == "fisheye":
        return _solve_fisheye(cv2, obj, lefts, rights, size)
    flags = cv2.CALIB_RATIONAL_MODEL if model == "rational" else 0
    cams = [cv2.calibrateCamera([obj] * len(pts), pts, size, None, None, flags=flags)[1:3]
            for pts in (lefts, rights)]
    (k1, d1), (k2, d2) = cams
    rms, k1, d1, k2, d2, r, t, _, _, _, _, per_view = cv2.stereoCalibrateExtended(
        [obj] * len(used), lefts, rights, k1, d1, k2, d2, size, None, None,
        flags=flags | cv2.CALIB_USE_INTRINSIC_GUESS,
        criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-6))
    return rms, k1, d1, k2, d2, r, t, [tuple(map(float, v)) for v in per_view]


def _solve_fisheye(cv2, obj, lefts, rights, size):
    obj = obj.reshape(-1, 1, 3).astype(np.float64)
    lefts = [a.reshape(-1, 1, 2).astype(np.float64) for a in lefts]
    rights = [b.reshape(-1, 1, 2).astype(np.float64) for b in rights]
    flags = cv2.fisheye.CALIB_RECOMPUTE_EXTRINSIC | cv2.fisheye.CALIB_FIX_SKEW
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-9)
    cams = [cv2.fisheye.calibrate([obj] * len(pts), pts, size, None, None, flags=flags,
                                  criteria=criteria) for pts in (lefts, rights)]
    (_, k1, d1, rv, tv), (_, k2, d2, _, _) = cams
    out = cv2.fisheye.stereoCalibrate(
        [obj] * len(lefts), lefts, rights, k1, d1, k2, d2, size,
        flags=cv2.fisheye.CALIB_USE_INTRINSIC_GUESS | cv2.fisheye.CALIB_FIX_SKEW,
        criteria=criteria)
    rms, k1, d1, k2, d2, r, t = out[:7]
    if len(out) > 7:  # OpenCV 4.9 and later give the views' poses too
        rv, tv = out[7], out[8]
    r, t = np.asarray(r, np.float64), np.asarray(t, np.float64).reshape(3, 1)
    views = []
    for a, b, rvec, tvec in zip(lefts, rights, rv, tv, strict=True):
        errs = []
        for pts, k, d, (rot, move) in ((a, k1, d1, (np.asarray(rvec), np.asarray(tvec))),
                                       (b, k2, d2, _compose(rvec, tvec, r, t))):
            found = cv2.fisheye.projectPoints(obj, rot.reshape(3, 1), move.reshape(3, 1),
                                              k, d)[0]
            errs.append(float(np.sqrt(np.mean(np.sum((found - pts) ** 2, axis=2)))))
        views.append(tuple(errs))
    return rms, k1, d1, k2, d2, r, t, views


def _compose(rvec, tvec, r, t):
    """The right camera's pose of a view (rvec, tvec: the left's)."""
    from .rectification import rodrigues

    rot = r @ rodrigues(np.asarray(rvec, np.float64).ravel())
    return rodrigues(rot).reshape(3, 1), r @ np.asarray(tvec, np.float64).reshape(3, 1) + t


def row_error(rig, used, alpha=0.0):
    """RMS of |y_left - y_right| (px) of the corners ``used`` once rectified by csw's
    own rectification of ``rig`` (alpha as csw rectify's)."""
    from . import rectification as rx

    r1, r2, p1, p2 = rx.rectification(rig, alpha)
    move = rx.fisheye_undistort_points if rig.model == "equidistant" else \
        rx.undistort_points
    rows = [(move(a, rig.k1, rig.d1, r1, p1), move(b, rig.k2, rig.d2, r2, p2))
            for _, a, b in used]
    diffs = np.concatenate([a[:, 1] - b[:, 1] for a, b in rows])
    # Points the lens model can't undo come out at -1e6 (OpenCV's and csw's way).
    undone = np.concatenate([(a[:, 0] > -1e5) & (b[:, 0] > -1e5) for a, b in rows])
    return float(np.sqrt(np.mean(diffs[undone] ** 2))) if undone.any() else float("nan")


def calibrate(pairs, board, square=1.0, units=None, model="radtan", min_views=MIN_VIEWS):
    """Calibrate a stereo rig from chessboard ``pairs``: csw.Job records (name, left,
    right: image files, as csw.jobs_from_folders or csw.jobs_from_manifest give them) or
    (name, left, right) with images as arrays.  board: (columns, rows) of inner corners;
    square: the side of a square, in ``units`` (None: not stated, and T is in squares of
    that size); model: "radtan" (5 coefficients), "rational" (8) or "fisheye".  A pair
    whose board isn't found in both images is rejected (Result.rejected says why).
    ValueError for fewer than ``min_views`` usable pairs, images of several sizes, or
    left and right swapped."""
    if model not in MODELS:
        raise ValueError(f"unknown model {model!r}; use {', '.join(MODELS)}")
    _cv2()
    used, rejected, size = detect(_images(pairs), board)
    if len(used) < min_views:
        raise ValueError(f"the board was found in both images of {len(used)} pair(s); "
                         f"calibrating needs at least {min_views} (check --board: "
                         f"{board[0]}x{board[1]} inner corners)")
    rms, k1, d1, k2, d2, r, t, per_view = solve(used, board, square, size, model)
    while len(used) > min_views:  # the worst view out while it is far off the others
        worst = [max(errs) for errs in per_view]
        i = int(np.argmax(worst))
        others = float(np.median(worst[:i] + worst[i + 1:]))
        if worst[i] <= max(OUTLIER_PX, OUTLIER_TIMES * others):
            break
        rejected.append((used[i][0], f"reprojection RMS {worst[i]:.2f} px, far above the "
                                     f"other views' (median {others:.2f} px): a mismatched "
                                     "pair, or the board moved between the shots"))
        del used[i]
        rms, k1, d1, k2, d2, r, t, per_view = solve(used, board, square, size, model)
    t = np.asarray(t, np.float64).reshape(3)
    if t[0] > 0:
        raise ValueError(f"the right camera is to the left of the left one (T[0] = "
                         f"{t[0]:.4g} > 0): the left and right images are swapped; give "
                         "them the other way round")
    try:
        rig = Rig(np.asarray(k1, np.float64), np.asarray(d1, np.float64).ravel(),
                  np.asarray(k2, np.float64), np.asarray(d2, np.float64).ravel(),
                  np.asarray(r, np.float64), t, (int(size[0]), int(size[1])), MODELS[model],
                  None, units, "the calibration")
    except ValueError as exc:
        raise ValueError(f"the calibration failed: {exc}") from None
    views = [(name, *errs) for (name, _, _), errs in zip(used, per_view, strict=True)]
    return Result(rig, float(rms), views, rejected, row_error(rig, used), tuple(board),
                  float(square))


def _images(pairs):
    """(name, left image, right image) for every pair; a Job's files read as they come."""
    from ..io.images import ImageError, read_colour

    for pair in pairs:
        if not hasattr(pair, "left"):
            yield pair
        elif pair.problem:
            yield pair.name, pair.problem, None
        else:
            try:
                yield pair.name, read_colour(pair.left), read_colour(pair.right)
            except ImageError as exc:
                yield pair.name, str(exc).splitlines()[0], None


def _matrix(name, values):
    values = np.atleast_2d(np.asarray(values, np.float64))
    data = ", ".join(f"{v:.17g}" for v in values.ravel())
    return (f"{name}: !!opencv-matrix\n   rows: {values.shape[0]}\n   cols: {values.shape[1]}"
            f"\n   dt: d\n   data: [ {data} ]\n")


def rig_text(result):
    """The rig as OpenCV's stereo YAML (FileStorage's YAML 1.0): width, height, units (of
    T; "none" when not stated), distortion_model, M1 D1 M2 D2 R T."""
    rig = result.rig
    text = (f"%YAML:1.0\n---\nwidth: {rig.size[0]}\nheight: {rig.size[1]}\n"
            f"units: {rig.units or 'none'}\ndistortion_model: {rig.model}\n"
            f"board: \"{result.board[0]}x{result.board[1]}\"\nsquare: {result.square!r}\n"
            f"rms: {result.rms!r}\nrow_error: {result.row_error!r}\n")
    for name, value in (("M1", rig.k1), ("D1", rig.d1.reshape(1, -1)), ("M2", rig.k2),
                        ("D2", rig.d2.reshape(1, -1)), ("R", rig.r),
                        ("T", rig.t.reshape(3, 1))):
        text += _matrix(name, value)
    return text


def preview_image(rig, pair, step=32):
    """A rectified pair (raw uint8/uint16 images) side by side, RGB uint8, with a
    horizontal line every ``step`` rows: the check that a point sits on one row in both."""
    from .rectify import Rectifier

    left, right = (_gray(image) for image in pair)
    both = np.concatenate(Rectifier(rig).rectify(left, right), axis=1)
    out = np.repeat(both[..., None], 3, axis=2)
    out[step // 2::step] = (0, 200, 0)
    return out


def summary_lines(result):
    """The calibration as lines for a person: per view, rejected views, totals."""
    rig = result.rig
    units = rig.units or "(no units: --square gave none)"
    lines = [f"view {name}: reprojection RMS left {a:.3f} px, right {b:.3f} px"
             for name, a, b in result.views]
    lines += [f"rejected {name}: {why}" for name, why in result.rejected]
    lines.append(f"{len(result.views)} view(s) used, {len(result.rejected)} rejected; "
                 f"reprojection RMS {result.rms:.4f} px; rectified row error "
                 f"{result.row_error:.4f} px RMS")
    lines.append(f"f {rig.k1[0, 0]:.6g} / {rig.k2[0, 0]:.6g} px, baseline "
                 f"{rig.baseline:.6g} {units}, {rig.model}, {rig.size[0]}x{rig.size[1]}")
    return lines


__all__ = ["MIN_VIEWS", "MODELS", "Result", "board_points", "calibrate", "find_corners",
           "parse_board", "parse_square", "preview_image", "rig_text", "row_error",
           "summary_lines"]

"""Real chessboard pairs, rectified by csw and by OpenCV's own chain: after rectification
the same corners should lie on the same row in both images.  Reads OpenCV's stereo
calibration sample (left01..14.jpg, right01..14.jpg, a 9x6 board, 640x480) from the
folder CSW_CHESSBOARD_DIR names (nothing is downloaded or committed), calibrates the rig
with cv2.stereoCalibrate, writes it as OpenCV's sample writes it, reads it back with
csw.read_rig, and compares, for alpha 0 and 1, the RMS row difference of the corners
found in csw's rectified pairs, in OpenCV's, and in the raw ones: a markdown section
(make bench-rectify puts it in reports/rectify.md)."""

import os
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np

import csw

sys.path.insert(0, str(Path(__file__).resolve().parent))
from report_common import fill_template  # noqa: E402

BOARD = (9, 6)


def corners(image):
    found, points = cv2.findChessboardCorners(image, BOARD)
    if not found:
        return None
    return cv2.cornerSubPix(image, points, (11, 11), (-1, -1),
                            (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01)
                            ).reshape(-1, 2)


def row_rms(pairs):
    """RMS of the row differences of the corners found in both images of every pair."""
    diffs = []
    for left, right in pairs:
        a, b = corners(left), corners(right)
        if a is not None and b is not None:
            diffs.append(a[:, 1] - b[:, 1])
    return float(np.sqrt(np.mean(np.concatenate(diffs) ** 2))), len(diffs)


def section():
    """The report's section, as markdown text."""
    folder = os.environ.get("CSW_CHESSBOARD_DIR")
    if not folder or not Path(folder, "left01.jpg").is_file():
        return markdown(None)
    names = sorted(p.name[4:] for p in Path(folder).glob("left*.jpg"))
    raw = [(cv2.imread(str(Path(folder, "left" + n)), cv2.IMREAD_GRAYSCALE),
            cv2.imread(str(Path(folder, "right" + n)), cv2.IMREAD_GRAYSCALE)) for n in names]
    board = np.zeros((BOARD[0] * BOARD[1], 3), np.float32)
    board[:, :2] = np.indices(BOARD).T.reshape(-1, 2)
    found = [(corners(a), corners(b)) for a, b in raw]
    used = [(a, b) for a, b in found if a is not None and b is not None]
    size = raw[0][0].shape[::-1]
    _, k1, d1, _, _ = cv2.calibrateCamera([board] * len(used), [a for a, _ in used], size,
                                          None, None)
    _, k2, d2, _, _ = cv2.calibrateCamera([board] * len(used), [b for _, b in used], size,
                                          None, None)
    _, k1, d1, k2, d2, r, t, _, _ = cv2.stereoCalibrate(
        [board] * len(used), [a for a, _ in used], [b for _, b in used], k1, d1, k2, d2,
        size, flags=cv2.CALIB_FIX_INTRINSIC)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp, "stereo.yml")
        storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
        for key, value in (("M1", k1), ("D1", d1), ("M2", k2), ("D2", d2), ("R", r),
                           ("T", t)):
            storage.write(key, value)
        storage.release()
        rig = csw.read_rig(path, size=size)
    raw_rms, _ = row_rms(raw)
    rows = []
    for alpha in (0.0, 1.0):
        rect = csw.Rectifier(rig, alpha=alpha)
        ours, n_ours = row_rms([rect.rectify(a, b) for a, b in raw])
        r1, r2, p1, p2, _, _, _ = cv2.stereoRectify(k1, d1, k2, d2, size, r, t,
                                                    flags=cv2.CALIB_ZERO_DISPARITY,
                                                    alpha=alpha)
        maps = [cv2.initUndistortRectifyMap(k, d, rr, p, size, cv2.CV_32FC1)
                for k, d, rr, p in ((k1, d1, r1, p1), (k2, d2, r2, p2))]
        theirs, n_theirs = row_rms([tuple(cv2.remap(img, *m, cv2.INTER_LINEAR)
                                          for img, m in zip(pair, maps, strict=True))
                                    for pair in raw])
        rows.append((alpha, ours, n_ours, theirs, n_theirs))
    return markdown(dict(pairs=len(raw), size=size, used=len(used), raw_rms=raw_rms,
                         rows=rows))


def markdown(figures):
    """The section's text (scripts/templates/chessboard.md) from its figures: pairs, size,
    used, raw_rms and rows of (alpha, csw rms, its pairs, OpenCV rms, its pairs); None
    when the sample is not there."""
    if figures is None:
        return fill_template("chessboard", [("not_run", {})])
    table = ["| alpha | csw (px) | OpenCV's own chain (px) | raw (px) |", "|---|---|---|---|"]
    table += [f"| {alpha:g} | {ours:.3f} ({n_ours} pairs) | {theirs:.3f} "
              f"({n_theirs} pairs) | {figures['raw_rms']:.2f} |"
              for alpha, ours, n_ours, theirs, n_theirs in figures["rows"]]
    width, height = figures["size"]
    return fill_template("chessboard", [("report", dict(
        pairs=figures["pairs"], width=width, height=height, board_columns=BOARD[0],
        board_rows=BOARD[1], used=figures["used"], table="\n".join(table)))])


if __name__ == "__main__":
    print(section())

"""csw calibrate on real chessboard pairs, against OpenCV's own calibrate-and-rectify
chain: the reprojection RMS against cv2.stereoCalibrate's with the same flags, the
corners' row error after csw rectify against after cv2.stereoRectify + remap (both found
again in the rectified images), and how far csw's rectified images are from cv2.remap's
with OpenCV's maps.  Reads a folder in the layout of OpenCV's stereo sample
(leftNN.jpg, rightNN.jpg; nothing is downloaded or committed): the first argument, else
CSW_CHESSBOARD_DIR; --swap for a set whose left and right names are the other way
round.  Writes reports/calibrate.md (make bench-calibrate).

    python scripts/calibrate_report.py FOLDER [--board 9x6] [--swap] [--model radtan]
"""

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np

import csw
from csw.camera import calibrate as cal

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
from report_common import fill_template, now_utc  # noqa: E402

FLAGS = {"radtan": 0, "rational": cv2.CALIB_RATIONAL_MODEL}


def pairs_of(folder, swap):
    """[(name, left path, right path)] of leftNN / rightNN files in ``folder``."""
    out = []
    for left in sorted(Path(folder).glob("left*.jpg")) + sorted(Path(folder).glob("left*.png")):
        right = left.with_name("right" + left.name[4:])
        if right.is_file():
            out.append((left.stem[4:], *((right, left) if swap else (left, right))))
    return out


def row_rms(images, board):
    """RMS of the corners' row differences in rectified pairs, and how many pairs."""
    diffs = []
    for left, right in images:
        a, b = cal.find_corners(left, board), cal.find_corners(right, board)
        if a is not None and b is not None:
            diffs.append(a[:, 1] - b[:, 1])
    return float(np.sqrt(np.mean(np.concatenate(diffs) ** 2))), len(diffs)


def opencv_chain(used, board, size, model):
    """OpenCV's calibrate-and-rectify with csw calibrate's flags, on the same corners:
    (rms, K1, D1, K2, D2, R, T)."""
    obj = [cal.board_points(board, 1.0)] * len(used)
    lefts, rights = [a for _, a, _ in used], [b for _, _, b in used]
    flags = FLAGS[model]
    k1, d1 = cv2.calibrateCamera(obj, lefts, size, None, None, flags=flags)[1:3]
    k2, d2 = cv2.calibrateCamera(obj, rights, size, None, None, flags=flags)[1:3]
    return cv2.stereoCalibrate(obj, lefts, rights, k1, d1, k2, d2, size,
                               flags=flags | cv2.CALIB_USE_INTRINSIC_GUESS,
                               criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS,
                                         100, 1e-6))[:7]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", default=os.environ.get("CSW_CHESSBOARD_DIR"))
    parser.add_argument("--board", default="9x6")
    parser.add_argument("--model", default="radtan", choices=sorted(FLAGS))
    parser.add_argument("--swap", action="store_true")
    parser.add_argument("--label", default="the chessboard pairs")
    parser.add_argument("--output", default=str(ROOT / "reports" / "calibrate.md"))
    args = parser.parse_args()
    if not args.folder or not pairs_of(args.folder, args.swap):
        sys.exit("give a folder of leftNN.jpg / rightNN.jpg pairs (or CSW_CHESSBOARD_DIR)")
    board = cal.parse_board(args.board)
    pairs = pairs_of(args.folder, args.swap)
    with tempfile.TemporaryDirectory() as tmp:
        manifest = Path(tmp, "pairs.csv")
        manifest.write_text("".join(f"{left},{right},{name}\n" for name, left, right in pairs))
        rig_file = Path(tmp, "rig.yml")
        command = ["csw", "calibrate", "--manifest", str(manifest), "--board", args.board,
                   "--square", "1", "--model", args.model, "-o", str(rig_file)]
        done = subprocess.run(command, capture_output=True, text=True, check=True)
        rig = csw.read_rig(rig_file)
        said = done.stderr.replace(str(manifest), "pairs.csv").replace(str(rig_file), "rig.yml")
    said = said.strip().splitlines()
    raw = [(cv2.imread(str(left), cv2.IMREAD_GRAYSCALE), cv2.imread(str(right),
                                                                     cv2.IMREAD_GRAYSCALE))
           for _, left, right in pairs]
    used, _, size = cal.detect([(n, a, b) for (n, _, _), (a, b) in zip(pairs, raw,
                                                                        strict=True)], board)
    result_rms = float(next(line for line in said if "reprojection RMS" in line and
                            "view(s) used" in line).split("reprojection RMS ")[1].split()[0])
    used_names = {line.split(":")[0][5:] for line in said if line.startswith("view ")}
    used = [u for u in used if u[0] in used_names]
    rms, k1, d1, k2, d2, r, t = opencv_chain(used, board, size, args.model)
    rows = []
    for alpha in (0.0, 1.0):
        rect = csw.Rectifier(rig, alpha=alpha)
        ours = [rect.rectify(a, b) for a, b in raw]
        r1, r2, p1, p2 = cv2.stereoRectify(k1, d1, k2, d2, size, r, t,
                                           flags=cv2.CALIB_ZERO_DISPARITY, alpha=alpha)[:4]
        maps = [cv2.initUndistortRectifyMap(k, d, rr, p, size, cv2.CV_16SC2)
                for k, d, rr, p in ((k1, d1, r1, p1), (k2, d2, r2, p2))]
        theirs = [tuple(cv2.remap(img, *m, cv2.INTER_LINEAR)
                        for img, m in zip(pair, maps, strict=True)) for pair in raw]
        # The same rig's maps from OpenCV: how far csw's remap is from cv2.remap's.
        same = [cv2.initUndistortRectifyMap(rig_k, rig_d, rr, p, size, cv2.CV_16SC2)
                for rig_k, rig_d, rr, p in ((rig.k1, rig.d1, rect.r1, rect.p1),
                                            (rig.k2, rig.d2, rect.r2, rect.p2))]
        close = []
        for pair, got in zip(raw, ours, strict=True):
            for img, m, mine, valid in zip(pair, same, got, rect.valid, strict=True):
                diff = np.abs(cv2.remap(img, *m, cv2.INTER_LINEAR).astype(int) - mine)
                close.append(((diff <= 1) & valid).sum() / valid.sum())
        rows.append((alpha, *row_rms(ours, board), *row_rms(theirs, board),
                     100 * float(np.mean(close)), 100 * float(np.min(close))))
    text = markdown(dict(
        date=now_utc(), opencv=cv2.__version__, label=args.label, pairs=len(pairs), size=size,
        board=args.board, model=args.model, said=said, result_rms=result_rms, rms=rms,
        baseline=rig.baseline, opencv_baseline=np.linalg.norm(t), rows=rows))
    Path(args.output).write_text(text)
    print(text)


def markdown(figures):
    """The report's text (scripts/templates/calibrate.md) from its figures; rows are
    (alpha, csw row RMS, its pairs, OpenCV's, its pairs, mean and worst share of pixels
    within 1 gray level of cv2.remap's)."""
    result_rms, rms = figures["result_rms"], figures["rms"]
    gap = abs(result_rms - rms)
    calibration = [
        "| | csw calibrate | cv2.stereoCalibrate, same flags, same corners | difference |",
        "|---|---|---|---|",
        f"| reprojection RMS (px) | {result_rms:.4f} | {rms:.4f} | {gap:.4f} "
        f"(target <= 0.05: **{'met' if gap <= 0.05 else 'not met'}**) |",
        f"| baseline (squares) | {figures['baseline']:.4f} | "
        f"{figures['opencv_baseline']:.4f} | |"]
    rectify = ["| alpha | csw (px, pairs) | OpenCV (px, pairs) | csw - OpenCV | within 1 gray "
               "level: mean, worst image |", "|---|---|---|---|---|"]
    for alpha, ours, n_ours, theirs, n_theirs, mean_close, worst_close in figures["rows"]:
        gap = ours - theirs
        rectify.append(f"| {alpha:g} | {ours:.3f} ({n_ours}) | {theirs:.3f} ({n_theirs}) | "
                       f"{gap:+.3f} (target <= 0.03: **{'met' if gap <= 0.03 else 'not met'}**)"
                       f" | {mean_close:.3f}%, {worst_close:.3f}% |")
    width, height = figures["size"]
    # The said lines are never empty: the reprojection RMS is read from them.
    return fill_template("calibrate", [("report", dict(
        date=figures["date"], opencv=figures["opencv"], label=figures["label"],
        pairs=figures["pairs"], width=width, height=height, board=figures["board"],
        model=figures["model"], said="\n".join(figures["said"]),
        calibration_table="\n".join(calibration), rectify_table="\n".join(rectify)))])


if __name__ == "__main__":
    main()

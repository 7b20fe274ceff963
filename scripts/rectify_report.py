"""Rectification against OpenCV, timed in one process (1 thread each, interleaved, median
of repeats after a warm-up): the remap of a 1920-pixel-wide gray pair against cv2.remap
on the same maps, building the maps against cv2.initUndistortRectifyMap, and matching a
raw 1080p pair with the rig against matching the already rectified pair.  Writes
reports/rectify.md (make bench-rectify)."""

import json
import statistics
import sys
import time
from pathlib import Path

import cv2
import numpy as np

import csw
from csw.camera.rectify import Rectifier, rectify_maps, stereo_rectify
from csw.kernels.remap import fixed_maps, remap

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from rig_fixtures import random_rig, raw_from_rectified  # noqa: E402

from report_common import fill_template, now_utc  # noqa: E402

SIZE = (1920, 1080)
REPEAT = 7


def timed(functions):
    """{name: [seconds...]}: each function run REPEAT times, interleaved, after one
    warm-up run each."""
    for f in functions.values():
        f()
    times = {name: [] for name in functions}
    for _ in range(REPEAT):
        for name, f in functions.items():
            start = time.perf_counter()
            f()
            times[name].append(time.perf_counter() - start)
    return times


def _scaled(k):
    """A camera matrix with a focal length six times as long (1800 px at 1920 wide)."""
    k = k.copy()
    k[0, 0] *= 6
    k[1, 1] *= 6
    return k


def met(ok):
    return "**met**" if ok else "**not met**"


def spread(values):
    # Not report_common.spread: reports/rectify.json keeps the three figures as numbers.
    return min(values), statistics.median(values), max(values)


def markdown(rows, ratio, date, chessboard):
    """The report's text (scripts/templates/rectify.md) from its figures, as
    reports/rectify.json keeps them (rows: name -> min, median, max seconds; ratios), and
    the chessboard section after it."""
    table = ["| step | min (ms) | median (ms) | max (ms) |", "|---|---|---|---|"]
    table += [f"| {name} | {lo * 1e3:.1f} | {mid * 1e3:.1f} | {hi * 1e3:.1f} |"
              for name, (lo, mid, hi) in rows.items()]
    return fill_template("rectify", [("report", dict(
        date=date, width=SIZE[0], height=SIZE[1], repeat=REPEAT, table="\n".join(table),
        remap=ratio["remap"], remap_met=met(ratio["remap"] <= 1.5), maps=ratio["maps"],
        maps_met=met(ratio["maps"] <= 2), match=ratio["match"],
        match_met=met(ratio["match"] <= 1.10)))]) + chessboard


def main():
    cv2.setNumThreads(1)
    rig = random_rig(np.random.default_rng(1), size=SIZE)
    rig = csw.Rig(_scaled(rig.k1), rig.d1, _scaled(rig.k2), rig.d2, rig.r, rig.t, SIZE,
                  source="a 1080p rig")
    r1, r2, p1, p2, _ = stereo_rectify(rig.k1, rig.d1, rig.k2, rig.d2, SIZE, rig.r, rig.t,
                                       0.0)
    left, right, _, _ = csw.synthetic_pair(*SIZE, dmax=120, seed=1)
    raw_left = raw_from_rectified(left, rig.k1, rig.d1, r1, p1)
    raw_right = raw_from_rectified(right, rig.k2, rig.d2, r2, p2)
    map_x, map_y = rectify_maps(rig.k1, rig.d1, r1, p1, SIZE)
    fixed = fixed_maps(map_x, map_y, raw_left.shape)  # made once per rig, as Rectifier does
    rect = Rectifier(rig, threads=1)
    rectified = rect.rectify(raw_left, raw_right)
    options = dict(dmax=128, threads=1)
    times = timed({
        "csw remap": lambda: remap(raw_left, fixed, None, threads=1),
        "cv2.remap": lambda: cv2.remap(raw_left, map_x, map_y, cv2.INTER_LINEAR,
                                       borderMode=cv2.BORDER_CONSTANT),
        "csw maps": lambda: fixed_maps(*rectify_maps(rig.k1, rig.d1, r1, p1, SIZE,
                                                     dtype=np.float64), raw_left.shape),
        "cv2 maps": lambda: cv2.initUndistortRectifyMap(rig.k1, rig.d1, r1, p1, SIZE,
                                                        cv2.CV_32FC1),
        "match with --rig": lambda: csw.match(*rect.rectify(raw_left, raw_right),
                                              **options),
        "match rectified": lambda: csw.match(*rectified, **options),
    })
    rows = {name: spread(v) for name, v in times.items()}
    ratio = {
        "remap": rows["csw remap"][1] / rows["cv2.remap"][1],
        "maps": rows["csw maps"][1] / rows["cv2 maps"][1],
        "match": rows["match with --rig"][1] / rows["match rectified"][1],
    }
    from chessboard_report import section

    text = markdown(rows, ratio, now_utc(), section())
    (ROOT / "reports" / "rectify.md").write_text(text)
    (ROOT / "reports" / "rectify.json").write_text(json.dumps(
        {"rows_seconds": rows, "ratios": ratio}, indent=1) + "\n")
    print(text)


if __name__ == "__main__":
    main()

"""A new user's first photos: three pairs no test uses, made photograph-like, matched as
the README says (`csw match L R -o d.pfm --preview p.png`, no range given) and with the
ground truth's range, scored with the same code.  Writes reports/first-photo.md.

The pairs are the registered scenes' other views: the right image as the reference
(both images and the right view's ground truth mirrored, so that it becomes a left
view), the right-hand image 6% brighter, both saved as JPEG at quality 90.
"""

import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import imageio.v3 as iio
import numpy as np

from csw.eval.scoring import score
from report_common import fill_template, now_utc

ROOT = Path(__file__).resolve().parents[1]

# (name, folder under the data, left view, right view, its ground truth, scale)
PAIRS = [
    ("teddy, view 6", "teddy", "im2.png", "im6.png", "disp6.png", 4),
    ("wood1 third size, view 5", "wood1/thirdsize", "view1.png", "view5.png", "disp5.png", 3),
    ("bowling1 half size, view 5", "bowling1/halfsize", "view1.png", "view5.png",
     "disp5.png", 2),
]
BRIGHTER = 1.06
QUALITY = 90


def make_pair(folder, left_name, right_name, gt_name, scale, out):
    """Write out/left.jpg, out/right.jpg; return the ground truth (float, NaN unknown)."""
    left = iio.imread(folder / left_name)
    right = iio.imread(folder / right_name)
    gt = iio.imread(folder / gt_name).astype(np.float64)
    reference, other = np.fliplr(right), np.fliplr(left)  # the right view, as a left one
    other = np.clip(np.round(other * BRIGHTER), 0, 255).astype(np.uint8)
    iio.imwrite(out / "left.jpg", reference, quality=QUALITY)
    iio.imwrite(out / "right.jpg", other, quality=QUALITY)
    truth = np.fliplr(gt) / scale
    return np.where(truth > 0, truth, np.nan)


def run_csw(out, name, *extra):
    """`csw match` as a user types it; returns (map, its summary line)."""
    done = subprocess.run([sys.executable, "-m", "csw_cli", "match", "left.jpg", "right.jpg",
                           "-o", f"{name}.pfm", "--preview", f"{name}.png", *extra],
                          cwd=out, capture_output=True, text=True, check=True)
    from csw.io import read_pfm

    return read_pfm(out / f"{name}.pfm"), done.stderr.strip().splitlines()


def markdown(records, date):
    """The report's text (scripts/templates/first-photo.md) from its figures, the records
    reports/first-photo.json keeps."""
    header = ["pair", "size", "GT range", "range found", "density found (%)",
              "density GT range (%)", "diff", "bad-2 valid found (%)",
              "bad-2 valid GT range (%)", "diff"]
    table = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in records:
        cells = [r["pair"], r["size"], r["gt_range"], r["found_range"],
                 f"{r['density_found']:.2f}", f"{r['density_given']:.2f}",
                 f"{r['density_found'] - r['density_given']:+.2f}",
                 f"{r['bad2_found']:.2f}", f"{r['bad2_given']:.2f}",
                 f"{r['bad2_found'] - r['bad2_given']:+.2f}"]
        table.append("| " + " | ".join(cells) + " |")
    return fill_template("first-photo", [("report", dict(
        date=date, brighter=round((BRIGHTER - 1) * 100), quality=QUALITY,
        table="\n".join(table)))])


def main():
    import os

    root = Path(os.environ.get("CSW_DATA_DIR") or ROOT.parent / "shared" / "datasets")
    records = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, sub, left_name, right_name, gt_name, scale in PAIRS:
            out = Path(tmp) / sub.replace("/", "-")
            out.mkdir()
            gt = make_pair(root / sub, left_name, right_name, gt_name, scale, out)
            top = math.ceil(np.nanmax(gt))
            found, said = run_csw(out, "found")
            given, _ = run_csw(out, "given", "--dmin", "0", "--dmax", str(top))
            region = {"all": np.isfinite(gt)}
            a, b = (score(m, gt, region, (2.0,))["all"] for m in (found, given))
            summary = next(line for line in said if " d " in line)
            searched = summary.split(" d ")[1].split(" ")[0]
            record = {"pair": label, "size": f"{gt.shape[1]}x{gt.shape[0]}",
                      "gt_range": f"0..{top}", "found_range": searched,
                      "density_found": a["density"], "density_given": b["density"],
                      "bad2_found": a["bad_valid"][2.0], "bad2_given": b["bad_valid"][2.0],
                      "notes": [line for line in said if line.startswith("csw: ")]}
            records.append(record)
    text = markdown(records, now_utc())
    (ROOT / "reports" / "first-photo.md").write_text(text)
    (ROOT / "reports" / "first-photo.json").write_text(json.dumps(records, indent=1) + "\n")
    print(text)


if __name__ == "__main__":
    main()

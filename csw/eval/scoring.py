"""Scoring disparity maps the Middlebury way, and KITTI's.

A pixel is bad-t when its disparity is invalid or differs from the ground truth by more
than t pixels.  Invalid predictions count as bad, and are also reported on their own.
MAE and RMS are over the valid predictions of the region.  KITTI's D1 counts a pixel as
bad when its error is over 3 px and over 5% of the true disparity (:func:`summary`).
"""

import numpy as np

from ..io.formats import as_float_disparity

THRESHOLDS = (0.5, 1.0, 2.0, 4.0)


def score_region(disp, gt, region, thresholds=THRESHOLDS):
    """Metrics of a float disparity map (nan invalid) over one bool region mask.

    Returns a dict: pixels, density (% valid), bad (dict threshold -> %, invalid pixels
    counting as bad), bad_valid (threshold -> % of the valid pixels), invalid (%), mae,
    rms, and the
    counts and sums behind them (bad_count per threshold, invalid_count, err_sum,
    sq_err_sum) so that scenes can be pooled.
    """
    d, g = disp[region], gt[region]
    n = int(region.sum())
    if n == 0:
        return {"pixels": 0, "density": float("nan"),
                "bad_valid": {t: float("nan") for t in thresholds},
                "bad": {t: float("nan") for t in thresholds},
                "bad_count": {t: 0 for t in thresholds}, "invalid_count": 0, "err_sum": 0.0,
                "sq_err_sum": 0.0, "invalid": float("nan"), "mae": float("nan"),
                "rms": float("nan")}
    valid = np.isfinite(d)
    err = np.abs(d[valid] - g[valid])
    bad_count = {t: int((~valid).sum() + (err > t).sum()) for t in thresholds}
    n_valid = int(valid.sum())
    return {
        "pixels": n,
        "density": 100.0 * n_valid / n,
        "bad_valid": {t: 100.0 * (err > t).sum() / n_valid if n_valid else float("nan")
                      for t in thresholds},
        "bad": {t: 100.0 * count / n for t, count in bad_count.items()},
        "bad_count": bad_count,
        "invalid_count": int((~valid).sum()),
        "err_sum": float(err.sum()),
        "sq_err_sum": float((err ** 2).sum()),
        "invalid": 100.0 * (~valid).sum() / n,
        "mae": float(err.mean()) if err.size else float("nan"),
        "rms": float(np.sqrt((err ** 2).mean())) if err.size else float("nan"),
    }


def score(disp, gt, regions, thresholds=THRESHOLDS):
    """Score ``disp`` against ``gt`` (float, nan unknown) over named bool regions.

    Every region is intersected with known ground truth. Returns region -> metrics.
    """
    disp = as_float_disparity(disp)
    gt = np.asarray(gt, dtype=np.float64)
    if disp.shape != gt.shape:
        raise ValueError(f"disparity map is {disp.shape[1]}x{disp.shape[0]} but the ground "
                         f"truth is {gt.shape[1]}x{gt.shape[0]}")
    known = np.isfinite(gt)
    return {name: score_region(disp, gt, mask & known, thresholds)
            for name, mask in regions.items()}


# KITTI's D1 (its devkit's ABS_THRESH and REL_THRESH): bad when both are exceeded.
D1_PIXELS, D1_SHARE = 3.0, 0.05


def metric_for(layout):
    """The error measure a benchmark publishes for its pairs: KITTI's D1 for the KITTI
    layouts, bad-2 for every other (Middlebury's, quarter-size 2014 included)."""
    return "D1" if layout.startswith("kitti") else "bad-2"


def errors(disp, gt, metric):
    """Bool map: where ``disp`` is wrong under ``metric``, 'D1' or 'bad-T' (error over T
    px).  NaN on either side compares False: the caller decides what invalid means."""
    err = np.abs(disp - gt)
    if metric == "D1":
        return (err > D1_PIXELS) & (err > D1_SHARE * gt)
    if metric.startswith("bad-"):
        return err > float(metric[4:])
    raise ValueError(f"unknown metric {metric!r}: use 'D1' or 'bad-T' (for example bad-2)")


def summary(disp, gt, region, metric="bad-2"):
    """One map's figures over ``region`` and known ground truth, in %: density (valid
    share), bad_valid (bad among the valid), bad_all (invalid counting as bad) and filled
    (bad_all after the evaluation kits' background fill, csw.matching.pipeline's
    fill="background", the same for every method).  The one scoring csw bench and make
    quality share, so every method is scored by the same code."""
    from ..kernels.filters import fill_background

    # float64 errors, as score() takes them; the fill works on float32 maps.
    filled = fill_background(as_float_disparity(disp, np.float32)).astype(np.float64)
    disp = as_float_disparity(disp)
    gt = np.asarray(gt, dtype=np.float64)
    known = region & np.isfinite(gt)
    n = int(known.sum())
    if n == 0:
        return dict.fromkeys(("density", "bad_valid", "bad_all", "filled"), float("nan"))
    valid = np.isfinite(disp) & known
    bad = errors(disp, gt, metric) & known
    n_valid = int(valid.sum())
    return {"density": 100.0 * n_valid / n,
            "bad_valid": 100.0 * bad.sum() / n_valid if n_valid else float("nan"),
            "bad_all": 100.0 * (bad.sum() + n - n_valid) / n,
            "filled": 100.0 * (errors(filled, gt, metric) | ~np.isfinite(filled))[known].sum()
            / n}


def filled_bad(disp, gt, region, threshold=2.0):
    """bad-t (%) over ``region`` after the evaluation kits' background fill: invalid pixels
    take the smaller nearest valid disparity on their row (see :func:`summary`)."""
    return summary(disp, gt, region, f"bad-{threshold:g}")["filled"]


def bad1_all(disp, pair):
    """The paper's error rate: bad-1 (%) over all known ground truth of a loaded Pair."""
    return score(disp, pair.gt, {"all": pair.masks["all"]}, (1.0,))["all"]["bad"][1.0]


def metric_rows(metrics, **extra):
    """Table rows (one per region) from :func:`score`'s result, with ``extra`` keys."""
    rows = []
    for region, m in metrics.items():
        row = dict(extra, region=region, pixels=m["pixels"], invalid=m["invalid"],
                   mae=m["mae"], rms=m["rms"], bad={f"{t:g}": v for t, v in m["bad"].items()},
                   bad_count={f"{t:g}": v for t, v in m["bad_count"].items()},
                   invalid_count=m["invalid_count"], err_sum=m["err_sum"],
                   sq_err_sum=m["sq_err_sum"])
        row.update({f"bad_{t:g}": v for t, v in m["bad"].items()})
        rows.append(row)
    return rows


def pooled_rows(rows, **extra):
    """Per region, the metrics of every row's pixels taken together (not a mean of
    per-scene percentages, which would weigh a small scene like a large one)."""
    out = []
    for region in dict.fromkeys(r["region"] for r in rows):
        group = [r for r in rows if r["region"] == region]
        n = sum(r["pixels"] for r in group)
        invalid = sum(r["invalid_count"] for r in group)
        valid = n - invalid
        bad = {t: 100.0 * sum(r["bad_count"][t] for r in group) / n if n else float("nan")
               for t in group[0]["bad_count"]}
        err, sq = sum(r["err_sum"] for r in group), sum(r["sq_err_sum"] for r in group)
        row = dict(extra, region=region, pixels=n, bad=bad,
                   invalid=100.0 * invalid / n if n else float("nan"),
                   mae=err / valid if valid else float("nan"),
                   rms=float(np.sqrt(sq / valid)) if valid else float("nan"))
        row.update({f"bad_{t}": v for t, v in bad.items()})
        out.append(row)
    return out

"""Scoring disparity maps the Middlebury way.

A pixel is bad-t when its disparity is invalid or differs from the ground truth by more
than t pixels.  Invalid predictions count as bad, and are also reported on their own.
MAE and RMS are over the valid predictions of the region.
"""

import numpy as np

THRESHOLDS = (0.5, 1.0, 2.0, 4.0)


def as_float_disparity(disp):
    """int maps with -1 invalid, or float maps with inf/nan invalid -> float, nan invalid."""
    disp = np.asarray(disp)
    out = disp.astype(np.float64)
    out[~np.isfinite(out) | (out < 0)] = np.nan
    return out


def score_region(disp, gt, region, thresholds=THRESHOLDS):
    """Metrics of a float disparity map (nan invalid) over one bool region mask.

    Returns a dict: pixels, bad (dict threshold -> %), invalid (%), mae, rms.
    """
    d, g = disp[region], gt[region]
    n = int(region.sum())
    if n == 0:
        return {"pixels": 0, "bad": {t: float("nan") for t in thresholds},
                "invalid": float("nan"), "mae": float("nan"), "rms": float("nan")}
    valid = np.isfinite(d)
    err = np.abs(d[valid] - g[valid])
    bad = {t: 100.0 * ((~valid).sum() + (err > t).sum()) / n for t in thresholds}
    return {
        "pixels": n,
        "bad": bad,
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


def bad1_all(disp, pair):
    """The paper's error rate: bad-1 (%) over all known ground truth of a loaded Pair."""
    return score(disp, pair.gt, {"all": pair.masks["all"]}, (1.0,))["all"]["bad"][1.0]

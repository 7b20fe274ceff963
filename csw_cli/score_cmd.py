"""``csw score``: Middlebury-style error metrics of a disparity map."""

import click
import numpy as np

from . import options as opt
from .datasets import DataError, load, region_masks, scaled_gt
from .imageio_utils import ImageError, read_disparity, read_image
from .report import emit
from .scoring import THRESHOLDS, score

COLUMNS = [("region", "Region", 0), ("pixels", "Pixels", 0)] + [
    (f"bad_{t:g}", f"bad-{t:g} (%)", 2) for t in THRESHOLDS] + [
    ("invalid", "Invalid (%)", 2), ("mae", "MAE", 3), ("rms", "RMS", 3)]


def _read(reader, path, hint, *args):
    try:
        return reader(path, *args)
    except ImageError as exc:
        raise click.BadParameter(str(exc), param_hint=hint) from None


@click.command(short_help="Score a disparity map against ground truth.")
@click.argument("disp", type=click.Path(dir_okay=False))
@click.option("--gt", type=click.Path(dir_okay=False),
              help="Ground-truth file (or use --dataset).")
@click.option("--gt-scale", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Divide stored GT values by this (tsukuba 16, venus 8, cones 4, "
                   "2006 third size 3) [default: the dataset's, 256 for 16-bit PNG, 1 else].")
@click.option("--mask", "masks", multiple=True, type=click.Path(dir_okay=False),
              help="Extra region mask, scored where the mask is 255 (NAME=FILE or FILE).")
@click.option("--border", type=click.IntRange(min=0), default=None,
              help="Pixels excluded on every side [default: the dataset's, else 0].")
@opt.dataset_option(multiple=False, required=False)
@opt.format_option
@opt.data_dir_option
@opt.download_option
def score_cmd(disp, gt, gt_scale, masks, border, dataset, fmt, data_dir, download):
    """Score DISP (PFM, PNG d*256, or NPY) with bad-0.5/1/2/4, invalid, MAE and RMS.

    Invalid predictions count as bad. Regions: all known ground truth, plus nonocc and
    disc where the dataset has those masks.

    \b
    Examples:
      csw score disp.pfm --dataset tsukuba
      csw score disp.pfm --gt truedisp.row3.col3.pgm --gt-scale 16 --border 18
    """
    if (gt is None) == (dataset is None):
        raise click.UsageError("give either --gt FILE or --dataset NAME")
    if dataset is not None:
        if gt_scale is not None or masks:
            raise click.UsageError("--gt-scale and --mask go with --gt; a --dataset brings "
                                   "its own scale and masks")
        try:
            pair = load(dataset, data_dir, allow_download=download)
        except DataError as exc:
            raise click.ClickException(str(exc)) from None
        truth = pair.gt
        regions = dict(pair.masks)
        if border is not None:
            regions = region_masks(np.isfinite(truth), border, {})
            regions.update({k: v & regions["all"] for k, v in pair.masks.items() if k != "all"})
    else:
        if str(gt).lower().endswith((".pfm", ".npy")):
            truth = _read(read_disparity, gt, "--gt", gt_scale)
        else:
            raw = _read(read_image, gt, "--gt")
            default = 256.0 if raw.dtype == np.uint16 else 1.0
            truth = scaled_gt(raw, gt_scale or default)
        mask_images = {}
        for i, spec in enumerate(masks):
            name, _, path = spec.rpartition("=")
            mask_images[name or f"mask{i + 1}"] = _read(read_image, path, "--mask")
        regions = region_masks(np.isfinite(truth), border or 0, mask_images)
    pred = _read(read_disparity, disp, "DISP")
    for name, region in regions.items():
        if region.shape != truth.shape:
            raise click.BadParameter(f"mask {name!r} is not the ground truth's size",
                                     param_hint="--mask")
    try:
        metrics = score(pred, truth, regions)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None
    rows = []
    for region, m in metrics.items():
        row = {"region": region, "pixels": m["pixels"], "invalid": m["invalid"],
               "mae": m["mae"], "rms": m["rms"], "bad": {f"{t:g}": v for t, v in m["bad"].items()}}
        row.update({f"bad_{t:g}": v for t, v in m["bad"].items()})
        rows.append(row)
    emit(rows, COLUMNS, fmt)

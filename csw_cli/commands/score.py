"""``csw score``: Middlebury-style error metrics of a disparity map, or of a folder of maps."""

import os
from pathlib import Path

import click
import numpy as np

from csw.data import layouts
from csw.data.datasets import region_masks
from csw.eval.scoring import THRESHOLDS, metric_rows, pooled_rows
from csw.eval.scoring import score as score_map
from csw.io import read_disparity, read_image

from .. import options as opt
from ..report import emit

COLUMNS = [("scene", "Scene", 0), ("region", "Region", 0), ("pixels", "Pixels", 0)] + [
    (f"bad_{t:g}", f"bad-{t:g} (%)", 2) for t in THRESHOLDS] + [
    ("invalid", "Invalid (%)", 2), ("mae", "MAE", 3), ("rms", "RMS", 3)]


def _read(reader, path, hint, *args):
    with opt.library_errors(hint):
        return reader(path, *args)


def truth_from_files(gt, gt_scale, masks, border):
    """(gt, regions) from --gt, --gt-scale, --mask and --border."""
    truth = _read(read_disparity, gt, "--gt", gt_scale)
    mask_images = {}
    for i, spec in enumerate(masks):
        name, _, path = spec.rpartition("=")
        mask_images[name or f"mask{i + 1}"] = _read(read_image, path, "--mask")
    with opt.library_errors("--mask"):
        return truth, region_masks(np.isfinite(truth), border or 0, mask_images)


@click.command()
@click.argument("disp", type=click.Path(exists=False))
@click.option("--gt", type=click.Path(dir_okay=False),
              help="Ground-truth file (or use --dataset / --dataset-dir).")
@click.option("--gt-scale", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Divide stored GT values by this (tsukuba 16, venus 8, cones 4, "
                   "2006 third size 3) [default: the dataset's, 256 for 16-bit PNG, 1 else].")
@click.option("--mask", "masks", multiple=True, type=click.Path(dir_okay=False),
              help="Extra region mask, scored where the mask is 255 (NAME=FILE or FILE).")
@click.option("--border", type=click.IntRange(min=0), default=None,
              help="Pixels excluded on every side [default: the dataset's, else 0].")
@opt.dataset_option(multiple=False, required=False)
@click.option("--dataset-dir", type=click.Path(file_okay=False),
              help="A benchmark folder as published (Middlebury 2014/2021 scene or folder "
                   "of scenes, KITTI training folder): scales and masks come from it.")
@click.option("--scene", help="With --dataset-dir holding several scenes and one DISP file: "
                              "the scene it belongs to.")
@opt.format_option
@opt.data_dir_option
@opt.download_option
@opt.verify_option
def score(disp, gt, gt_scale, masks, border, dataset, dataset_dir, scene, fmt, data_dir,
              download, verify):
    """Score DISP (PFM, PNG d*256, or NPY) with bad-0.5/1/2/4, invalid, MAE and RMS.

    Invalid predictions count as bad. Regions: all known ground truth, plus nonocc and
    disc where the dataset has those masks.  With --dataset-dir, DISP may be a folder of
    maps named after the scenes (SCENE.pfm, as 'csw match' writes them into
    --output-dir): each scene is scored, then all of them pooled.

    \b
    Examples:
      csw score disp.pfm --dataset tsukuba
      csw score disp.pfm --gt truedisp.row3.col3.pgm --gt-scale 16 --border 18
      csw score maps/ --dataset-dir MiddEval3/trainingQ
    """
    sources = [s for s in (gt, dataset, dataset_dir) if s is not None]
    if len(sources) != 1:
        raise click.UsageError("give one of --gt FILE, --dataset NAME or --dataset-dir PATH")
    if (dataset or dataset_dir) and (gt_scale is not None or masks):
        raise click.UsageError("--gt-scale and --mask go with --gt; a dataset brings its own "
                               "scale and masks")
    if scene and not dataset_dir:
        raise click.UsageError("--scene goes with --dataset-dir")
    if os.path.isdir(disp) and Path(disp).suffix.lower() != ".zarr":  # a store is one map
        if not dataset_dir:
            raise click.UsageError("a folder of maps is scored against --dataset-dir")
        return score_folder(Path(disp), dataset_dir, border, fmt)
    if dataset_dir:
        with opt.library_errors("--dataset-dir"):
            pair = layouts.find_scene(dataset_dir, scene).load()
        truth, regions = pair.gt, pair.regions(border)
    elif dataset:
        pair = next(opt.pairs([dataset], [], data_dir, download, verify))
        truth, regions = pair.gt, pair.regions(border)
    else:
        truth, regions = truth_from_files(gt, gt_scale, masks, border)
    pred = _read(read_disparity, disp, "DISP")
    with opt.library_errors("DISP"):
        metrics = score_map(pred, truth, regions)
    emit(metric_rows(metrics), COLUMNS[1:], fmt)


def score_folder(maps, dataset_dir, border, fmt):
    """Every scene of DATASET_DIR that has a map in MAPS, then the pooled total."""
    with opt.library_errors("--dataset-dir"):
        scenes = layouts.scan(dataset_dir)
    rows, missing = [], []
    for scene in scenes:
        path = layouts.map_for(maps, scene.name)
        if path is None:
            missing.append(scene.name)
            continue
        with opt.library_errors():
            pair = scene.load()
        pred = _read(read_disparity, path, "DISP")
        with opt.library_errors("DISP"):
            metrics = score_map(pred, pair.gt, pair.regions(border))
        rows += metric_rows(metrics, scene=scene.name)
    if not rows:
        raise click.ClickException(f"{maps} has no map named after a scene of {dataset_dir} "
                                   f"(e.g. {scenes[0].name}.pfm)")
    if missing:
        click.echo(f"score: no map for {len(missing)} scene(s): {', '.join(missing[:8])}"
                   + (" ..." if len(missing) > 8 else ""), err=True)
    emit(rows + pooled_rows(rows, scene=f"total ({len(scenes) - len(missing)} scenes)"),
         COLUMNS, fmt)

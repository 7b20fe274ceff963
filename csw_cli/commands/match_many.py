"""``csw match`` on many pairs: two folders of images (pairs by file name) or a manifest,
a map per pair into --output-dir; a pair that fails is reported and the others go on."""

import os
from pathlib import Path

import click

from .. import options as opt


def many_mode(ctx, settings, three_d):
    """``csw match`` on many pairs: its options checked, then match_batch.  settings:
    the matching options given; three_d: the depth, cloud and depth preview options."""
    from csw.config import params

    p = ctx.params
    left, right, manifest = p["left"], p["right"], p["manifest"]
    if p["rectified_left"]:
        raise click.UsageError("--rectified-left is for one pair; csw rectify writes "
                               "a folder's rectified images")
    if p["output"] or p["cost_map"] or p["memory_limit"]:
        raise click.UsageError("-o, --cost-map and --memory-limit are for one pair; many "
                               "pairs write into --output-dir")
    if bool(manifest) == (left is not None):
        raise click.UsageError("give either LEFT_DIR RIGHT_DIR or --manifest, not both")
    if left is not None and not os.path.isdir(left):
        raise click.UsageError(f"{left} is a file: --output-dir is for many pairs (LEFT "
                               "and RIGHT folders, or --manifest); for one pair give "
                               "-o FILE")
    if left is not None and (right is None or not os.path.isdir(right)):
        raise click.UsageError("with a LEFT folder, RIGHT must be a folder too")
    with opt.library_errors():
        config = params.resolve(**settings)  # before the manifest is read, and once
    calibration = opt.calibration(p)
    outputs = dict(three_d, preview=p["preview"], confidence=p["confidence"])
    if p["rigs"]:
        outputs.update(rig=batch_rig(p["rigs"], left, manifest), alpha=p["alpha"])
    return match_batch(left, right, manifest, p["output_dir"], p["suffix"], p["overwrite"],
                       p["summary"], config, p["workers"], p["scheduler"], calibration,
                       outputs)


def batch_rig(rigs, left_dir, manifest):
    """The rig of a batch of raw pairs, checked against (and its image size, when the
    file doesn't give it, taken from) the first pair's left image that can be read."""
    from csw import jobs_from_folders, jobs_from_manifest
    from csw.camera.rig import read_rig
    from csw.scale.jobs import first_size

    with opt.library_errors("--manifest" if manifest else "LEFT"):
        jobs = jobs_from_manifest(manifest) if manifest else jobs_from_folders(left_dir,
                                                                               left_dir)
        size = first_size(jobs)
    with opt.library_errors("--rig"):
        rig = read_rig(*rigs, size=size)
        if size is not None:  # before the maps are built for the rig's size
            rig.check_size(size, "the batch's first left image")
        return rig


def match_batch(left, right, manifest, output_dir, suffix, overwrite, summary, config,
                workers=None, scheduler=None, calibration=None, outputs=None):
    """The batch form: pairs from two folders or a manifest, into OUTPUT_DIR, with the
    resolved ``config``; ``outputs``: each pair's other outputs' formats, and the 3-D
    options."""
    from csw import jobs_from_folders, jobs_from_manifest, match_many
    from csw.scale.distributed import cluster

    if output_dir is None:
        raise click.UsageError("matching many pairs needs --output-dir DIR")
    out = Path(output_dir)
    with opt.library_errors("--manifest" if manifest else "LEFT"):
        jobs = jobs_from_manifest(manifest) if manifest else jobs_from_folders(left, right)
    try:
        with opt.library_errors(), cluster(workers, scheduler) as client:
            report = match_many(jobs, out, suffix=suffix, overwrite=overwrite, progress=True,
                                summary=summary, client=client, calib=calibration,
                                config=config, **(outputs or {}))
    except OSError as exc:
        raise opt.write_error(exc) from None
    counts = report["counts"]
    summary_path = summary or out / "summary.json"
    click.echo(f"{counts['ok']} matched, {counts['skipped']} skipped (output exists; "
               f"--overwrite redoes them), {counts['failed']} failed; summary in "
               f"{summary_path}", err=True)
    for entry in report["failed"]:
        click.echo(f"failed: {entry['name']}: {entry['error']}", err=True)
    for name, note in report["noted"]:
        click.echo(f"csw: {name}: {note}", err=True)
    if report["notes"] > len(report["noted"]):
        click.echo(f"csw: {report['notes'] - len(report['noted'])} more note(s) in "
                   f"{summary_path}", err=True)
    if counts["failed"]:
        raise SystemExit(1)


# Options that name one pair's outputs, or that only batches and single pairs take.

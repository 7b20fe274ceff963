"""``csw rectify``: a raw pair from a calibrated rig, undistorted and rectified."""

import click

from .. import options as opt


@click.command()
@click.argument("left", type=click.Path(), required=False)
@click.argument("right", type=click.Path(), required=False)
@click.option("--manifest", type=click.Path(dir_okay=False, exists=True),
              help="Many pairs: a CSV file of left,right[,name] lines (paths relative to "
                   "it).")
@click.option("--rig", "rigs", multiple=True, required=True,
              type=click.Path(dir_okay=False, exists=True),
              help="The rig's calibration: OpenCV YAML/XML (M1 D1 M2 D2 R T, one file or "
                   "intrinsics and extrinsics), ROS camera_info (left, then right), KITTI "
                   "calib_cam_to_cam.txt, or a Kalibr camchain. Repeat for two files.")
@click.option("--output-dir", "-O", required=True, type=click.Path(file_okay=False),
              help="Where to write left.png, right.png and calib.txt (created if missing). "
                   "Many pairs: left/NAME.png, right/NAME.png and left/calib.txt.")
@click.option("--alpha", type=click.FloatRange(-1, 1), default=0.0, show_default=True,
              help="0: only pixels with a source, no black border; 1: every raw pixel "
                   "kept; between, in proportion (ignored when the file gives R1 R2 P1 "
                   "P2).")
@opt.option("threads", short="-j")
def rectify(left, right, manifest, rigs, output_dir, alpha, threads):
    """Undistort and rectify LEFT and RIGHT, raw images of a calibrated rig, into
    OUTPUT_DIR: left.png, right.png, and calib.txt, the rectified pair's calibration, so
    that csw match finds it beside the left image.

    Many pairs: LEFT and RIGHT folders (pairs by file name) or --manifest, rectified with
    maps built once; a pair that fails is reported and the others go on (exit 1).

    \b
    Examples:
      csw rectify raw_left.png raw_right.png --rig stereo.yml -O rect/
      csw rectify l.png r.png --rig intrinsics.yml --rig extrinsics.yml -O rect/ --alpha 1
      csw match rect/left.png rect/right.png -o disp.pfm --depth depth.pfm
      csw rectify raw_lefts/ raw_rights/ --rig stereo.yml -O rect/
      csw match rect/left rect/right -O maps/ --depth .pfm
    """
    import os

    if manifest is not None or (left is not None and os.path.isdir(left)):
        return rectify_batch(left, right, manifest, rigs, output_dir, alpha, threads)
    if left is None or right is None:
        raise click.UsageError("give LEFT and RIGHT images (or folders, or --manifest)")
    from csw.camera.rectify_files import rectify_files
    from csw.camera.rig import read_rig
    from csw.io.images import image_header

    with opt.library_errors("LEFT"):
        height, width = image_header(left)[2]
    with opt.library_errors("--rig"):
        rig = read_rig(*rigs, size=(width, height))
    with opt.library_errors():
        rect = rectify_files(left, right, rig, output_dir, alpha, threads)
    c = rect.calibration
    click.echo(f"wrote {output_dir}/left.png, right.png, calib.txt: {c.width}x{c.height}, "
               f"f {c.focal:.6g} px, baseline {c.baseline:.6g}"
               f"{' ' + c.units if c.units else ''}, {100 * rect.valid[0].mean():.1f}% of "
               "the left image with a source", err=True)


def rectify_batch(left, right, manifest, rigs, output_dir, alpha, threads):
    """The batch form: pairs from two folders or a manifest."""
    from csw import jobs_from_folders, jobs_from_manifest
    from csw.camera.rectify_files import rectify_many
    from csw.camera.rig import read_rig
    from csw.scale.jobs import first_size

    if bool(manifest) == (left is not None):
        raise click.UsageError("give either LEFT_DIR RIGHT_DIR or --manifest, not both")
    with opt.library_errors("--manifest" if manifest else "LEFT"):
        jobs = jobs_from_manifest(manifest) if manifest else jobs_from_folders(left, right)
    size = first_size(jobs)
    with opt.library_errors("--rig"):
        rig = read_rig(*rigs, size=size)
        if size is not None:  # before the maps are built for the rig's size
            rig.check_size(size, "the batch's first left image")
    with opt.library_errors():
        report = rectify_many(jobs, rig, output_dir, alpha, threads, progress=True)
    click.echo(f"{report['ok']} pair(s) rectified into {output_dir}/left and "
               f"{output_dir}/right (calib.txt in {output_dir}/left), "
               f"{len(report['failed'])} failed", err=True)
    for name, error in report["failed"]:
        click.echo(f"failed: {name}: {error}", err=True)
    if report["failed"]:
        raise SystemExit(1)

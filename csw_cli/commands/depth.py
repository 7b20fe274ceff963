"""``csw depth`` and ``csw cloud``: a disparity map to depth, or to a point cloud, with
the pair's calibration."""

import click

from .. import options as opt


def from_disparity(output_help):
    """What csw depth and csw cloud both take: the disparity map, the output, and the
    calibration."""
    def decorate(function):
        function = opt.calibration_options()(function)
        function = click.option("--output", "-o", required=True,
                                type=click.Path(dir_okay=False), help=output_help)(function)
        return click.argument("disparity", type=click.Path())(function)  # a .zarr: a folder
    return decorate


@click.command()
@from_disparity("The depth map: .pfm or .npy (inf where unknown), .tif (NaN).")
@click.option("--preview", type=click.Path(dir_okay=False),
              help="Also write a colour PNG of the depth (near warm, far cool), with its "
                   "range on a bar below.")
@click.pass_context
def depth(ctx, disparity, output, preview, **_):
    """Turn DISPARITY (PFM, NPY, TIFF or KITTI PNG) into depth, Z = f B / (d + doffs),
    in the calibration's units (mm for Middlebury, m for KITTI) or --units.

    \b
    Examples:
      csw depth disp.pfm --calib calib.txt -o depth.pfm --units m
      csw depth disp.pfm --calib calib_cam_to_cam.txt -o depth.tif --preview depth.png
      csw depth disp.pfm --focal 721.5 --baseline 0.537 -o depth.npy
    """
    from csw.camera.geometry import DEPTH_SUFFIXES, depth_file
    from csw.io.safety import check_outputs

    calibration = require(opt.calibration(ctx.params))
    with opt.library_errors():
        check_outputs({"disparity": disparity, "calib": ctx.params["calib"]},
                      {"output": output, "preview": preview},
                      {"output": DEPTH_SUFFIXES, "preview": (".png",)})
    with opt.library_errors("DISPARITY"):
        z = depth_file(disparity, output, calibration, ctx.params["units"], preview)
    units = ctx.params["units"] or calibration.units or "the baseline's units"
    valid = z[z == z]
    span = f", {valid.min():.4g}..{valid.max():.4g} {units}" if valid.size else ""
    click.echo(f"depth of {valid.size} of {z.size} pixels{span}, from "
               f"{calibration.describe()}", err=True)


@click.command()
@from_disparity("The point cloud: binary little-endian PLY.")
@click.option("--image", type=click.Path(dir_okay=False),
              help="The left image, to colour the points.")
@click.option("--max-depth", type=click.FloatRange(min=0, min_open=True),
              help="Leave out points farther than this (in the output's units).")
@click.pass_context
def cloud(ctx, disparity, output, image, max_depth, **_):
    """Turn DISPARITY into a point cloud in the left camera's frame (x right, y down, z
    forward), as OpenCV's reprojectImageTo3D gives it: one point per valid pixel.

    \b
    Examples:
      csw cloud disp.pfm --calib calib.txt --image im0.png -o cloud.ply --units m
      csw cloud disp.pfm --calib stereo.yml --max-depth 20 -o cloud.ply
    """
    from csw.camera.geometry import CLOUD_SUFFIXES, cloud_file
    from csw.io.safety import check_outputs

    calibration = require(opt.calibration(ctx.params))
    with opt.library_errors():
        check_outputs({"disparity": disparity, "image": image, "calib": ctx.params["calib"]},
                      {"output": output}, {"output": CLOUD_SUFFIXES})
    with opt.library_errors("DISPARITY"):
        count = cloud_file(disparity, output, calibration, image, max_depth,
                           ctx.params["units"])
    click.echo(f"{count} points written to {output}, from {calibration.describe()}",
               err=True)


def require(calibration):
    if calibration is None:
        raise click.UsageError("give the calibration: --calib FILE, or --focal and "
                               "--baseline")
    return calibration

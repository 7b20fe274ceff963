"""``csw synth``: write the built-in synthetic scene."""

import click

from csw.data.synth import write_scene, write_tiff_scene

PNG_MAX_PIXELS = 50_000_000  # rendered whole in memory
TIFF_MAX_PIXELS = 4_000_000_000  # rendered by row bands


def parse_size(ctx, param, value):
    try:
        width, height = (int(v) for v in value.lower().split("x"))
    except ValueError:
        raise click.BadParameter(f"{value!r} is not WIDTHxHEIGHT, e.g. 450x375") from None
    if width < 8 or height < 8 or width * height > TIFF_MAX_PIXELS:
        raise click.BadParameter("size must be at least 8x8 and at most 4 gigapixels")
    return width, height


@click.command()
@click.argument("directory", type=click.Path(file_okay=False))
@click.option("--size", default="450x375", show_default=True, callback=parse_size,
              help="WIDTHxHEIGHT.")
@click.option("--dmax", type=click.IntRange(min=1), default=64, show_default=True,
              help="Largest disparity in the scene.")
@click.option("--seed", type=click.IntRange(0, 2**32 - 1), default=0, show_default=True,
              help="Scene seed.")
@click.option("--tiff", is_flag=True,
              help="Write left.tif, right.tif and gt.tif as tiled (Big)TIFFs, rendered by "
                   "row bands on every core: for pairs bigger than memory.")
@click.option("--frames", type=click.IntRange(1, 100_000), default=None,
              help="Write a moving scene of N frames (boxes and discs that move across and "
                   "in depth): left/, right/ and gt/ folders of NNNNNN files, and calib.txt.")
@click.option("--video", is_flag=True,
              help="With --frames: write the pair side by side as sbs.mp4 (H.264) instead "
                   "of the left/ and right/ images (gt/ and calib.txt still).")
@click.option("--rate", type=click.FloatRange(1, 1000), default=30.0, show_default=True,
              help="With --video: frames a second.")
def synth(directory, size, dmax, seed, tiff, frames, video, rate):
    """Write left.png, right.png, gt.pfm, nonocc.png and calib.txt into DIRECTORY.

    The scene is deterministic: a slanted textured background and fronto-parallel boxes
    and discs in front of it, rendered with exact occlusion.  gt.pfm holds the left
    disparity of every pixel; nonocc.png is 255 where the pixel is visible in the right
    image.

    \b
    With --frames N, a moving scene instead: frame i in left/, right/ (or the
    side-by-side sbs.mp4 with --video) and gt/, as NNNNNN.png and NNNNNN.pfm.

    \b
    Examples:
      csw synth out/scene --size 640x480 --dmax 64
      csw synth out/big --size 20000x20000 --dmax 64 --tiff
      csw synth out/seq --size 320x240 --dmax 31 --frames 100
      csw synth out/video --size 640x480 --dmax 63 --frames 300 --video
    """
    width, height = size
    if video and frames is None:
        raise click.UsageError("--video writes a sequence: give --frames N too")
    if frames is not None and tiff:
        raise click.UsageError("--tiff is for one big pair, not --frames")
    if dmax >= width:
        raise click.BadParameter(f"must be less than the width ({width})", param_hint="--dmax")
    if not tiff and width * height > PNG_MAX_PIXELS:
        raise click.BadParameter("over 50 megapixels needs --tiff (rendered by row bands)",
                                 param_hint="--size")
    from csw.io.safety import check_space

    from .. import options as opt

    with opt.library_errors():  # left, right (1 byte a pixel), gt (4), the mask (1)
        check_space([(f"{directory}/left.tif", 7 * width * height)])
    if frames is not None:
        return _sequence(directory, frames, width, height, dmax, seed, video, rate)
    try:
        if tiff:
            write_tiff_scene(directory, width, height, dmax, seed)
        else:
            write_scene(directory, width, height, dmax, seed)
    except OSError as exc:
        raise click.ClickException(f"can't write the scene to {directory}: "
                                   f"{exc.strerror or exc}") from None
    names = "left.tif, right.tif, gt.tif" if tiff else \
        "left.png, right.png, gt.pfm, nonocc.png, calib.txt"
    click.echo(f"wrote {directory}/{names} ({width}x{height}, d up to {dmax})", err=True)


def _sequence(directory, frames, width, height, dmax, seed, video, rate):
    from csw.data.synth import write_sequence

    from .. import options as opt

    try:
        with opt.library_errors():
            write_sequence(directory, frames, width, height, dmax, seed, video,
                                     rate)
    except OSError as exc:
        raise click.ClickException(f"can't write the sequence to {directory}: "
                                   f"{exc.strerror or exc}") from None
    what = "sbs.mp4" if video else "left/, right/"
    click.echo(f"wrote {frames} frames into {directory}/ ({what}, gt/, calib.txt; "
               f"{width}x{height}, d up to {dmax})", err=True)

"""``csw synth``: write the built-in synthetic scene."""

import click

from csw.synth import write_scene


def parse_size(ctx, param, value):
    try:
        width, height = (int(v) for v in value.lower().split("x"))
    except ValueError:
        raise click.BadParameter(f"{value!r} is not WIDTHxHEIGHT, e.g. 450x375") from None
    if width < 8 or height < 8 or width * height > 50_000_000:
        raise click.BadParameter("size must be at least 8x8 and at most 50 megapixels")
    return width, height


@click.command(short_help="Write a synthetic stereo pair with exact ground truth.")
@click.argument("directory", type=click.Path(file_okay=False))
@click.option("--size", default="450x375", show_default=True, callback=parse_size,
              help="WIDTHxHEIGHT.")
@click.option("--dmax", type=click.IntRange(min=1), default=64, show_default=True,
              help="Largest disparity in the scene.")
@click.option("--seed", type=click.IntRange(0, 2**32 - 1), default=0, show_default=True,
              help="Scene seed.")
def synth(directory, size, dmax, seed):
    """Write left.png, right.png, gt.pfm and nonocc.png into DIRECTORY.

    The scene is deterministic: a slanted textured background and fronto-parallel boxes
    and discs in front of it, rendered with exact occlusion.  gt.pfm holds the left
    disparity of every pixel; nonocc.png is 255 where the pixel is visible in the right
    image.

    \b
    Example:
      csw synth out/scene --size 640x480 --dmax 64
    """
    width, height = size
    if dmax >= width:
        raise click.BadParameter(f"must be less than the width ({width})", param_hint="--dmax")
    try:
        write_scene(directory, width, height, dmax, seed)
    except OSError as exc:
        raise click.ClickException(f"can't write the scene to {directory}: "
                                   f"{exc.strerror or exc}") from None
    click.echo(f"wrote {directory}/left.png, right.png, gt.pfm, nonocc.png "
               f"({width}x{height}, d up to {dmax})", err=True)

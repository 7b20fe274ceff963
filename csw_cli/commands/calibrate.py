"""``csw calibrate``: chessboard pairs to a rig file that csw and OpenCV both read."""

import click

from csw.camera.calibration import UNITS

from .. import options as opt


@click.command()
@click.argument("left", type=click.Path(file_okay=False, exists=True), required=False)
@click.argument("right", type=click.Path(file_okay=False, exists=True), required=False)
@click.option("--manifest", type=click.Path(dir_okay=False, exists=True),
              help="The pairs as a CSV file of left,right[,name] lines (paths relative to "
                   "it), instead of LEFT and RIGHT folders.")
@click.option("--board", required=True,
              help="The chessboard's inner corners, COLUMNSxROWS (OpenCV's sample: 9x6).")
@click.option("--square", required=True,
              help="The side of a square with its units (25mm), or a bare number with "
                   "--units; a bare number alone leaves the rig without units.")
@click.option("--units", type=click.Choice(list(UNITS)),
              help="The rig's units: a bare --square is in them, a --square with units is "
                   "converted to them.")
@click.option("--model", type=click.Choice(["radtan", "rational", "fisheye"]),
              default="radtan", show_default=True,
              help="The lens model: pinhole with 5 (radtan) or 8 (rational) coefficients, "
                   "or fisheye (equidistant, 4).")
@click.option("--output", "-o", required=True, type=click.Path(dir_okay=False),
              help="The rig file: OpenCV YAML (M1 D1 M2 D2 R T, the size, the units), "
                   "for --rig.")
@click.option("--preview", type=click.Path(dir_okay=False),
              help="Also write a PNG of the first pair rectified, side by side, with "
                   "horizontal lines: a point should sit on one line in both.")
@click.option("--min-views", type=click.IntRange(min=1), default=4, show_default=True,
              help="Pairs with the board found in both images needed, at the least.")
def calibrate(left, right, manifest, board, square, units, model, output, preview,
              min_views):
    """Calibrate a stereo rig from chessboard pairs: LEFT and RIGHT folders (paired by
    file name, as csw match pairs them) or --manifest.  OpenCV finds the corners and
    solves (pip install 'csw-stereo[calibrate]'); csw rectifies the corners with the result
    and reports how far apart their rows stay.  Pairs whose board isn't found are
    reported and left out.

    \b
    Examples:
      csw calibrate left/ right/ --board 9x6 --square 25mm -o rig.yml --preview check.png
      csw calibrate --manifest pairs.csv --board 9x6 --square 0.025 --units m -o rig.yml
      csw rectify raw_l.png raw_r.png --rig rig.yml -O rect/
    """
    from csw import jobs_from_folders, jobs_from_manifest
    from csw.camera import calibrate as cal
    from csw.io.atomic import atomic_write_all
    from csw.io.formats import png_writer
    from csw.io.safety import check_outputs

    if bool(manifest) == (left is not None) or (left is None) != (right is None):
        raise click.UsageError("give LEFT and RIGHT folders, or --manifest")
    with opt.library_errors("--board"):
        board_size = cal.parse_board(board)
    with opt.library_errors("--square"):
        size, rig_units = cal.parse_square(square, units)
    with opt.library_errors("--manifest" if manifest else "LEFT"):
        jobs = jobs_from_manifest(manifest) if manifest else jobs_from_folders(left, right)
    inputs = {"manifest": manifest}
    for job in jobs:
        inputs.update({f"{job.name} left": job.left, f"{job.name} right": job.right})
    with opt.library_errors():
        check_outputs(inputs, {"output": output, "preview": preview},
                      {"output": (".yml", ".yaml"), "preview": (".png",)})
    with opt.library_errors():
        result = cal.calibrate(jobs, board_size, size, rig_units, model, min_views)
        writes = [(output, _text_writer(cal.rig_text(result)))]
        if preview is not None:
            from csw.io.images import read_colour

            first = next(job for job in jobs if job.name == result.views[0][0])
            image = cal.preview_image(result.rig, (read_colour(first.left),
                                                   read_colour(first.right)))
            writes.append((preview, png_writer(image)))
        atomic_write_all(writes)
    for line in cal.summary_lines(result):
        click.echo(line, err=True)
    click.echo(f"wrote {output}" + (f" and {preview}" if preview else ""), err=True)


def _text_writer(text):
    from pathlib import Path

    return lambda tmp: Path(tmp).write_text(text)

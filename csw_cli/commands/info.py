"""``csw info``: what a robot's log holds: its image topics, counts, encodings, sizes and
rates."""

import click

from .. import options as opt
from ..report import emit

COLUMNS = [("topic", "Topic", 0), ("type", "Type", 0), ("count", "Messages", 0),
           ("encoding", "Encoding", 0), ("size", "Size", 0), ("rate", "Rate (Hz)", 1)]


@click.command()
@click.argument("log", type=click.Path())
@opt.format_option
def info(log, fmt):
    """List the image topics of LOG (a ROS 1 bag, a ROS 2 bag folder, an .mcap or .db3
    file, or a KITTI raw drive folder): messages, encoding, size and rate, to choose
    --left-topic and --right-topic for csw match.

    \b
    Examples:
      csw info drive.mcap
      csw info 2011_09_26/2011_09_26_drive_0001_sync --format json
    """
    from csw.robot.logs import describe_log

    with opt.library_errors("LOG"):
        topics = describe_log(log)
    rows = [{"topic": t.name, "type": t.msgtype.replace("/msg/", "/"), "count": t.count,
             "encoding": t.encoding, "size": f"{t.size[0]}x{t.size[1]}" if t.size else "",
             "width": t.size[0] if t.size else None,
             "height": t.size[1] if t.size else None, "rate": t.rate} for t in topics]
    if not rows:
        click.echo(f"{log}: no image topics", err=True)
    emit(rows, COLUMNS, fmt)

"""``csw datasets``: the registry, and what is present locally."""

import click

from .. import options as opt
from ..report import emit

COLUMNS = [("name", "Dataset", 0), ("size", "Size", 0), ("range", "Disparities", 0),
           ("gt_scale", "GT scale", 0), ("masks", "Masks", 0), ("local", "Local", 0),
           ("description", "Description", 0)]


@click.command()
@opt.format_option
@opt.data_dir_option
def datasets(fmt, data_dir):
    """List every registered dataset: size, disparity range, and whether it is local.

    Files are looked up in --data-dir / $CSW_DATA_DIR, then the user cache; missing ones
    are downloaded from the official Middlebury URLs when a command needs them.
    """
    from csw.data.datasets import DATASETS, SYNTHETIC, SYNTHETIC_DMAX, SYNTHETIC_SIZE, is_local

    width, height = SYNTHETIC_SIZE
    rows = [{"name": SYNTHETIC, "size": f"{width}x{height}", "range": f"0..{SYNTHETIC_DMAX}",
             "dmin": 0, "dmax": SYNTHETIC_DMAX, "gt_scale": 1, "masks": "nonocc",
             "local": "yes", "description": "built-in synthetic scene (csw synth)"}]
    for name, ds in DATASETS.items():
        rows.append({"name": name, "size": ds.size, "range": f"0..{ds.dmax}",
                     "dmin": 0, "dmax": ds.dmax, "gt_scale": f"{ds.gt_scale:g}",
                     "masks": ",".join(ds.masks) or "-",
                     "local": "yes" if is_local(name, data_dir) else "no",
                     "description": ds.description})
    emit(rows, COLUMNS, fmt)

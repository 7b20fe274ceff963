"""``csw hist``: the distribution of the minimum-cost map m (the paper's Fig. 9)."""

from pathlib import Path

import click

from csw.config import params

from .. import options as opt
from ..report import emit

COLUMNS = [("low", "From", 0), ("high", "To", 0), ("count", "Pixels", 0),
           ("share", "Share (%)", 1), ("bar", "", 0)]
PRESET = params.EXPERIMENT_PRESET


@click.command()
@click.argument("images", nargs=-1, type=click.Path(dir_okay=False))
@opt.dataset_option(multiple=False, required=False)
@opt.option("engine", preset=PRESET)
@opt.option("cost", preset=PRESET)
@opt.option("window", short="-w", preset=PRESET)
@opt.experiment_dmin_option
@opt.dataset_dmax_option(
    help=f"Largest disparity [default: the dataset's range, or {params.FIXED_DMAX}].")
@opt.option("csw", help="Histogram the CSW run's m instead of plain matching's.")
@opt.option("tau", help="tau for --csw [default: the paper's rule].")
@click.option("--plot", type=click.Path(dir_okay=False),
              help="Also write the histogram as a PNG plot (needs matplotlib).")
@opt.option("threads", short="-j")
@opt.format_option
@opt.data_dir_option
@opt.download_option
@opt.verify_option
@opt.stage_options(PRESET)
@click.pass_context
def hist(ctx, images, dataset, plot, fmt, data_dir, download, verify, **_):
    """Histogram of m for a pair (LEFT RIGHT) or a --dataset, with the tau that the
    paper's rule picks: the width of the first of 10 equal bins.  m is the kernels' cost,
    so the preset's cost and prefilter shape it; its other stages do not.

    \b
    Examples:
      csw hist --dataset tsukuba --dmax 16
      csw hist left.png right.png --cost shd --plot fig9.png
    """
    from csw import read_image
    from csw.eval import plots
    from csw.eval.histogram import min_cost_histogram
    from csw.io.outputs import PairOutputs

    if bool(images) == bool(dataset) or (images and len(images) != 2):
        raise click.UsageError("give either LEFT RIGHT or --dataset NAME")
    options = opt.given(ctx, ["engine", "cost", "window", "dmin", "dmax", "csw", "tau",
                              "threads", "preset", *params.OFF])
    with opt.library_errors():
        # a bad option fails before any file is read, over the preset the run takes
        params.resolve(**{"preset": PRESET, **options})
        PairOutputs({"plot": plot},
                    dict(zip(("left", "right"), images, strict=False))).check_paths()
    if dataset:
        pair = next(opt.pairs([dataset], [], data_dir, download, verify))
        left, right, top, title = pair.left, pair.right, pair.dmax, dataset
    else:
        with opt.library_errors("LEFT"):
            left = read_image(images[0])
        with opt.library_errors("RIGHT"):
            right = read_image(images[1])
        top, title = params.FIXED_DMAX, Path(images[0]).name
    options.setdefault("dmax", top)
    with opt.library_errors():
        rows, rule_tau, min_cost, used = min_cost_histogram(left, right, **options)
    caption = (f"{title}: m of {used['cost'].upper()} {used['window']}x{used['window']} "
               f"d {used['dmin']}..{used['dmax']}{' + CSW' if used['csw'] else ''}; the "
               f"paper's rule gives tau = {rule_tau:g}")
    emit(rows, COLUMNS, fmt, caption)
    if plot:
        with opt.library_errors():
            plots.histogram(plot, min_cost, rule_tau, caption.split(";")[0])

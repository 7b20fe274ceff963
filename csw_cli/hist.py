"""``csw hist``: the distribution of the minimum-cost map m (the paper's Fig. 9)."""

from pathlib import Path

import click

from csw import kernels, plots
from csw.bench import histogram_rows
from csw.defaults import MATCH
from csw.matching import check_tau_use
from csw.tau import paper_tau, resolve_tau

from . import options as opt
from .match import check_output, load_pair
from .report import emit

COLUMNS = [("low", "From", 0), ("high", "To", 0), ("count", "Pixels", 0),
           ("share", "Share (%)", 1), ("bar", "", 0)]


@click.command(short_help="Histogram of the minimum-cost map m (the paper's Fig. 9).")
@click.argument("images", nargs=-1, type=click.Path(dir_okay=False))
@opt.dataset_option(multiple=False, required=False)
@opt.cost_option()
@opt.window_option()
@opt.dmin_option
@click.option("--dmax", type=click.IntRange(min=0), default=None,
              help=f"Largest disparity [default: the dataset's range, or {MATCH['dmax']}].")
@click.option("--csw/--no-csw", default=False, show_default=True,
              help="Histogram the CSW run's m instead of plain matching's.")
@click.option("--tau", type=opt.TauType(), default=None,
              help="tau for --csw [default: the paper's rule].")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False),
              help="Also write the histogram as a PNG plot (needs matplotlib).")
@opt.threads_option
@opt.format_option
@opt.data_dir_option
@opt.download_option
@opt.verify_option
def hist(images, dataset, cost, window, dmin, dmax, csw, tau, plot_path, threads, fmt,
         data_dir, download, verify):
    """Histogram of m for a pair (LEFT RIGHT) or a --dataset, with the tau that the
    paper's rule picks: the width of the first of 10 equal bins.

    \b
    Examples:
      csw hist --dataset tsukuba --dmax 16
      csw hist left.png right.png --cost shd --plot fig9.png
    """
    if bool(images) == bool(dataset) or (images and len(images) != 2):
        raise click.UsageError("give either LEFT RIGHT or --dataset NAME")
    with opt.library_errors("--tau"):
        check_tau_use(csw, tau)
    plot_path = check_output(plot_path, (".png",), "--plot")
    if dataset:
        pair = next(opt.pairs([dataset], [], data_dir, download, verify))
        left, right, top, title = pair.left, pair.right, pair.dmax, dataset
    else:
        left, right = load_pair(*images)
        top, title = MATCH["dmax"], Path(images[0]).name
    top = dmax if dmax is not None else top
    settings = dict(engine="fast", window=window, dmin=dmin, dmax=top, cost=cost,
                    threads=threads)
    with opt.library_errors():
        plain = kernels.match(left, right, csw=False, tau=-1, **settings)
        rule_tau = paper_tau(plain.min_cost)
        result = plain
        if csw:
            chosen, _ = resolve_tau("auto" if tau is None else tau, "literal",
                                    plain_min_cost=lambda: plain.min_cost)
            result = kernels.match(left, right, csw=True, tau=chosen, **settings)
    caption = (f"{title}: m of {cost.upper()} {window}x{window} d {dmin}..{top}"
               f"{' + CSW' if csw else ''}; the paper's rule gives tau = {rule_tau:g}")
    emit(histogram_rows(result.min_cost), COLUMNS, fmt, caption)
    if plot_path:
        with opt.library_errors():
            plots.histogram(plot_path, result.min_cost, rule_tau, caption.split(";")[0])

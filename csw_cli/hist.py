"""``csw hist``: the distribution of the minimum-cost map m (the paper's Fig. 9)."""

from pathlib import Path

import click
import numpy as np

from . import options as opt
from .datasets import DataError, load
from .engine import paper_tau, run_match
from .match import check_output, load_pair
from .report import emit, pyplot, save_figure

COLUMNS = [("low", "From", 0), ("high", "To", 0), ("count", "Pixels", 0),
           ("share", "Share (%)", 1), ("bar", "", 0)]


def histogram_rows(min_cost, bins=10):
    valid = min_cost[min_cost >= 0]
    counts, edges = np.histogram(valid, bins=bins)
    top = max(int(counts.max()), 1)
    return [{"low": float(edges[i]), "high": float(edges[i + 1]), "count": int(counts[i]),
             "share": 100.0 * counts[i] / max(valid.size, 1),
             "bar": "#" * int(round(40 * counts[i] / top))} for i in range(bins)]


def plot(path, min_cost, tau, title):
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.hist(min_cost[min_cost >= 0].ravel(), bins=10, color="#4878a8", edgecolor="white")
    ax.axvline(tau, color="#c03030", linestyle="--", label=f"paper's tau = {tau:g}")
    ax.set_xlabel("minimum cost m")
    ax.set_ylabel("pixels")
    ax.set_title(title)
    ax.legend()
    fig.tight_layout()
    save_figure(fig, path, dpi=120)


@click.command(short_help="Histogram of the minimum-cost map m (the paper's Fig. 9).")
@click.argument("images", nargs=-1, type=click.Path(dir_okay=False))
@opt.dataset_option(multiple=False, required=False)
@opt.cost_option()
@opt.window_option
@opt.dmin_option
@click.option("--dmax", type=click.IntRange(min=0), default=None,
              help="Largest disparity [default: the dataset's range, or 64].")
@click.option("--csw/--no-csw", default=False, show_default=True,
              help="Histogram the CSW run's m instead of plain matching's.")
@click.option("--tau", type=float, default=None, help="tau for --csw [default: the rule].")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False),
              help="Also write the histogram as a PNG plot (needs matplotlib).")
@opt.threads_option
@opt.format_option
@opt.data_dir_option
@opt.download_option
def hist(images, dataset, cost, window, dmin, dmax, csw, tau, plot_path, threads, fmt,
         data_dir, download):
    """Histogram of m for a pair (LEFT RIGHT) or a --dataset, with the tau that the
    paper's rule picks: the width of the first of 10 equal bins.

    \b
    Examples:
      csw hist --dataset tsukuba --dmax 16
      csw hist left.png right.png --cost shd --plot fig9.png
    """
    if bool(images) == bool(dataset) or (images and len(images) != 2):
        raise click.UsageError("give either LEFT RIGHT or --dataset NAME")
    plot_path = check_output(plot_path, (".png",), "--plot")
    if dataset:
        try:
            pair = load(dataset, data_dir, allow_download=download)
        except DataError as exc:
            raise click.ClickException(str(exc)) from None
        left, right, top, title = pair.left, pair.right, pair.dmax, dataset
    else:
        left, right = load_pair(*images)
        top, title = 64, Path(images[0]).name
    top = dmax if dmax is not None else top
    settings = dict(engine="fast", window=window, dmin=dmin, dmax=top, cost=cost,
                    threads=threads)
    plain = run_match(left, right, csw=False, tau=-1, **settings)
    rule_tau = paper_tau(plain.min_cost)
    result = plain
    if csw:
        result = run_match(left, right, csw=True, tau=rule_tau if tau is None else tau,
                           **settings)
    caption = (f"{title}: m of {cost.upper()} {window}x{window} d {dmin}..{top}"
               f"{' + CSW' if csw else ''}; the paper's rule gives tau = {rule_tau:g}")
    emit(histogram_rows(result.min_cost), COLUMNS, fmt, caption)
    if plot_path:
        plot(plot_path, result.min_cost, rule_tau, caption.split(";")[0])

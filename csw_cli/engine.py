"""The bridge from the CLI to csw's kernels: import checks, errors, timing, tau."""

import time

import click
import numpy as np

FOREIGN_KERNELS = (
    "the Python package 'kernels' found at {path} is not csw's (an unrelated PyPI package "
    "has the same name); uninstall it with 'pip uninstall kernels' and reinstall csw"
)


def load_kernels():
    """Import csw's ``kernels`` package, or fail plainly if another one shadows it."""
    try:
        import kernels
    except ImportError as exc:
        raise click.ClickException(f"csw's kernels can't be imported: {exc}") from None
    if not getattr(kernels, "CSW_KERNELS", False):
        raise click.ClickException(FOREIGN_KERNELS.format(path=getattr(kernels, "__file__", "?")))
    return kernels


def run_match(left, right, **options):
    """kernels.match with ValueError turned into a usage error (exit 2)."""
    kernels = load_kernels()
    try:
        return kernels.match(left, right, **options)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None


def warm_up(engine="window", cost="sad"):
    """Compile (or load from the cache) the kernels on a tiny pair; return seconds taken."""
    kernels = load_kernels()
    tiny = np.zeros((3, 4), np.uint8)
    start = time.perf_counter()
    for csw in (False, True):
        kernels.match(tiny, tiny, engine=engine, window=1, dmin=0, dmax=1, cost=cost,
                      csw=csw, tau=0)
    return time.perf_counter() - start


def paper_tau(min_cost):
    """The paper's rule for tau: the width of the first of 10 equal bins of the
    histogram of the plain min-cost map m (invalid pixels, m < 0, left out)."""
    valid = np.asarray(min_cost)[np.asarray(min_cost) >= 0]
    if valid.size == 0:
        return 0.0
    edges = np.histogram_bin_edges(valid, bins=10)
    return float(edges[1] - edges[0])


def estimate_tau(left, right, sample_rows=32, **options):
    """The paper's tau from plain matching on ``sample_rows`` evenly spaced rows, which
    costs about sample_rows / H of a full run."""
    height = left.shape[0]
    rows = np.unique(np.linspace(0, height - 1, min(sample_rows, height)).round().astype(int))
    options = dict(options, csw=False, rows=rows)
    result = run_match(left, right, **options)
    return paper_tau(result.min_cost)

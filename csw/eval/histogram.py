"""The distribution of the minimum-cost map m (the paper's Fig. 9), and the tau that the
paper's rule reads off it."""

import numpy as np

from ..config import params
from ..config.tau import paper_tau, resolve_tau
from ..matching.pipeline import run as run_pipeline


def min_cost_histogram(left, right, bins=10, **options):
    """The histogram of m for a pair, as :func:`histogram_rows`, with the tau the paper's
    rule picks from plain matching's map.

    options: matching options as for :func:`csw.match`, over the experiments' preset
    (raw): with ``csw``, m is the CSW run's (tau as given, else the rule's default, taken
    from the plain run's full map).  Returns (rows, the rule's tau, m int64 (H, W), the
    resolved options).
    """
    config = params.resolve(**{"preset": params.EXPERIMENT_PRESET, **options})
    stages, args = config.stages, config.kernel_args()
    plain = run_pipeline(left, right, dict(args, csw=False, tau=-1), stages)[2]
    rule_tau = paper_tau(plain.min_cost)
    min_cost = plain.min_cost
    if config.csw:
        tau, _ = resolve_tau(config.tau, config.csw_rule,
                             plain_min_cost=lambda: plain.min_cost)
        min_cost = run_pipeline(left, right, dict(args, csw=True, tau=tau), stages)[2].min_cost
    return histogram_rows(min_cost, bins), rule_tau, min_cost, config.as_dict()


def histogram_rows(min_cost, bins=10):
    """The distribution of a min-cost map m (int64, -1 invalid) in ``bins`` equal bins, as
    rows (low, high, count, share %, a text bar): the paper's Fig. 9."""
    valid = np.asarray(min_cost)[np.asarray(min_cost) >= 0]
    counts, edges = np.histogram(valid, bins=bins)
    top = max(int(counts.max()), 1)
    return [{"low": float(edges[i]), "high": float(edges[i + 1]), "count": int(counts[i]),
             "share": 100.0 * counts[i] / max(valid.size, 1),
             "bar": "#" * int(round(40 * counts[i] / top))} for i in range(bins)]

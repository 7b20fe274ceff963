"""tau, CSW's threshold on the minimum cost: what a user may write, and the number it
becomes. Every command and ``csw.match`` go through this module.

A tau is given as
  a number   claim when the minimum cost m <= tau (m and tau are compared as integers);
  "auto"     the paper's rule: the width of the first of 10 equal bins of the histogram
             of plain matching's minimum-cost map;
  "none"     no cost threshold (every match the rule finds distinct claims);
  "paper"    the paper's value for the dataset and cost (bench only; auto where the
             paper has none);
  None       the rule's default: auto for the literal rule, none for the unique rule.
The kernels take the resolved number, with -1 for "CSW off".
"""

import math

import numpy as np

WORDS = ("auto", "none", "paper")
# A sweep (csw sweep --tau-range) runs one match per value: past this it is a typo.
MAX_SWEEP_VALUES = 1000


def parse_tau(value, words=WORDS):
    """A tau as written (str or number) -> a float or one of ``words``; ValueError if not."""
    if value is None:
        return None
    if isinstance(value, str):
        text = value.strip().lower()
        if text in words:
            return text
        try:
            value = float(text)
        except ValueError:
            raise ValueError(f"tau {value!r} is not a number or one of "
                             f"{', '.join(words)}") from None
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"tau must be a number or one of {', '.join(words)}, got {value!r}")
    value = float(value)
    if math.isnan(value):
        raise ValueError("tau must be a number, not NaN")
    if value < 0:
        raise ValueError(f"tau must be >= 0 (got {value:g}); leave CSW off for plain matching")
    return value


def default_tau(rule):
    """The tau a rule uses when none is given."""
    return "none" if rule == "unique" else "auto"


def paper_tau(min_cost):
    """The paper's rule for tau: the width of the first of 10 equal bins of the histogram
    of a plain min-cost map m (int64, -1 where invalid, left out)."""
    valid = np.asarray(min_cost)[np.asarray(min_cost) >= 0]
    if valid.size == 0:
        return 0.0
    edges = np.histogram_bin_edges(valid, bins=10)
    return float(edges[1] - edges[0])


def sample_rows(height, count=32):
    """``count`` evenly spaced rows (int64, ascending): the sample tau auto is taken from,
    which costs about count / height of a full match."""
    return np.unique(np.linspace(0, height - 1, min(count, height)).round().astype(np.int64))


def resolve_tau(tau, rule, *, plain_min_cost=None, paper_value=None):
    """(number, source) for a CSW run.

    tau: as for :func:`parse_tau`, or None for the rule's default.
    plain_min_cost: callable returning a plain min-cost map (full or sampled), called only
        when tau resolves to auto.  paper_value: the paper's tau, or None.
    source is "given", "auto", "none", "paper" or "auto (no paper value)".
    """
    tau = parse_tau(tau)
    if tau is None:
        tau = default_tau(rule)
    if tau == "none":
        return math.inf, "none"
    if tau == "paper":
        if paper_value is not None:
            return float(paper_value), "paper"
        return paper_tau(plain_min_cost()), "auto (no paper value)"
    if tau == "auto":
        return paper_tau(plain_min_cost()), "auto"
    return tau, "given"


def tau_label(tau):
    """A tau for tables and log lines: 'none' for no threshold."""
    return "none" if tau is None or tau == math.inf else f"{tau:g}"


def parse_sweep(text, limit=MAX_SWEEP_VALUES):
    """Comma-separated sweep items -> list of (label, kind, number), kind in
    {"abs", "times", "none"}: a number, 'Nx' (N times the auto tau), 'a:b:step' (a to b
    inclusive) or 'none'.  Raises ValueError, also when there would be over ``limit``."""
    items = []
    for item in (v.strip().lower() for v in str(text).split(",") if v.strip()):
        try:
            if item == "none":
                items.append(("none", "none", None))
            elif item.endswith("x"):
                items.append((item, "times", parse_tau(item[:-1])))
            elif ":" in item:
                start, stop, step = (float(v) for v in item.split(":"))
                if not step > 0 or start < 0 or not math.isfinite(stop):
                    raise ValueError
                count = math.floor((stop - start) / step + 1e-9) + 1
                if count + len(items) > limit:
                    raise OverflowError
                items += [(f"{v:g}", "abs", v) for v in
                          (start + i * step for i in range(max(count, 0)))]
            else:
                items.append((item, "abs", parse_tau(item)))
        except OverflowError:
            raise ValueError(f"{item!r} gives more than {limit} taus; use a larger step")\
                from None
        except ValueError:
            raise ValueError(f"{item!r}: use numbers >= 0, Nx, a:b:step or none") from None
        if len(items) > limit:
            raise ValueError(f"more than {limit} taus; sweep fewer")
    if not items:
        raise ValueError("give at least one tau")
    return items


def sweep_value(kind, number, auto):
    """The tau of one sweep item, given the auto tau."""
    if kind == "none":
        return math.inf
    return auto * number if kind == "times" else number

"""csw's Numba kernels: window matching with and without the Constrained Sliding Window.

Engines are siblings that compute one contract (see README, "The matching contract"):
  window  full w x w sums per candidate, the paper's method (kernels.window)
  fast    running sums, O(1) per (pixel, disparity), after OpenCV's StereoBM (kernels.fast)

``match`` dispatches by engine name.  ``CSW_KERNELS`` marks this package as csw's own, so
the CLI can tell it from the unrelated PyPI package that is also called ``kernels``.
"""

from .contract import COSTS, INVALID, RULES, MatchResult, candidate_count
from .fast import match_fast
from .window import match_window

CSW_KERNELS = True

ENGINES = {"window": match_window, "fast": match_fast}


def match(left, right, *, engine="window", **options):
    """Match with the named engine; options as for :func:`kernels.window.match_window`."""
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {', '.join(ENGINES)}, got {engine!r}")
    return ENGINES[engine](left, right, **options)


__all__ = ["COSTS", "ENGINES", "INVALID", "RULES", "MatchResult", "candidate_count", "match",
           "match_fast", "match_window", "CSW_KERNELS"]

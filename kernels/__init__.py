"""csw's kernels: window matching with and without the Constrained Sliding Window.

Installed as ``csw.kernels`` (the folder is ``kernels/`` in the source tree). Engines are
siblings that compute one contract (see docs/engines.md, "The matching contract"):
  window  full w x w sums per candidate, the paper's method (.window)
  fast    running sums, O(1) per (pixel, disparity), after OpenCV's StereoBM (.fast)

These are the bare kernels: every matching parameter is given explicitly.  ``csw.match``
is the entry with the user-facing defaults.  The Numba code is in ``jit/``; each entry is
compiled once per CPU and loaded without Numba (``native``).  Nothing here imports Numba
until something must be compiled.
"""

import functools

from . import contract, native, workspace  # noqa: F401 (kernels.workspace, for callers)
from .contract import (
    COSTS,
    ENGINE_NAMES,
    INVALID,
    NEG_INVALID,
    RULES,
    MatchResult,
    candidate_count,
    invalid,
)


@functools.cache  # imported on first use; a stream calls this on every frame
def _engines():
    from .fast import match_fast
    from .window import match_window

    return dict(zip(ENGINE_NAMES, (match_fast, match_window), strict=True))


def match(left, right, *, engine, **options):
    """Match with the named engine; options as for :func:`.window.match_window`."""
    if engine not in ENGINE_NAMES:
        raise ValueError(f"engine must be one of {', '.join(ENGINE_NAMES)}, got {engine!r}")
    return _engines()[engine](left, right, **options)


def entries(engine, cost, pixels, window, census_window, csw, right_map, extras, dmin=0,
            lr_check=False, census_pattern=None):
    """The compiled entries (kernels/native.py) a match with these settings loads: its
    census transform, if any, its engine's variant, and the window engine's left-right
    check (the fast engine makes it in its rows).  lr_check: whether there is one."""
    from . import census, fast
    from . import window as window_engine
    from .contract import SHD

    code = COSTS[cost]
    compared = pixels
    if cost == "census":
        compared, code = contract.census_dtype(census_window, census_pattern), SHD
    module = fast if engine == "fast" else window_engine
    check = [("filters", ("lr",))] if lr_check and engine != "fast" else []
    return census.entries(pixels, cost, census_window, census_pattern) + check + \
        module.entries(code, compared, window, csw, right_map or lr_check, extras, dmin)


__all__ = ["COSTS", "ENGINE_NAMES", "INVALID", "NEG_INVALID", "RULES", "MatchResult",
           "candidate_count", "contract", "entries", "invalid", "match", "native"]

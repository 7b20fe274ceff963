"""csw's kernels: window matching with and without the Constrained Sliding Window.

Installed as ``csw.kernels`` (the folder is ``kernels/`` in the source tree). Engines are
siblings that compute one contract (see docs/engines.md, "The matching contract"):
  window  full w x w sums per candidate, the paper's method (.window)
  fast    running sums, O(1) per (pixel, disparity), after OpenCV's StereoBM (.fast)

These are the bare kernels: every matching parameter is given explicitly.  ``csw.match``
is the entry with the user-facing defaults.  The Numba code is in ``jit/``; each entry is
compiled once per CPU and loaded without Numba (``native``); ``catalogue`` lists every
kernel, its variants and the entries a match loads, ``costs`` the costs.  Nothing here
imports Numba until something must be compiled.
"""

import functools

from . import catalogue, contract, native, workspace  # noqa: F401 (for callers)
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
from .runtime import default_threads
from .store import target_cpu


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


__all__ = ["COSTS", "ENGINE_NAMES", "INVALID", "NEG_INVALID", "RULES", "MatchResult",
           "candidate_count", "catalogue", "contract", "default_threads", "invalid", "match",
           "native", "target_cpu"]

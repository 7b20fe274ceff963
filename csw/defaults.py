"""The one table of matching defaults: ``csw.match``, ``csw match`` and every command that
matches read it, so a default can't drift between the library and the CLI.

A preset is a named set of values over this table; options given explicitly override it.
"""

from .paper import WINDOW as PAPER_WINDOW
from .pipeline import OFF

MATCH = {
    "preset": "accurate",  # see PRESETS; README, "Presets", says why this one
    "engine": "fast",  # running sums; "window" is the paper's full-window method
    "cost": "sad",
    "window": 9,  # the paper's 9x9
    "dmin": 0,
    "dmax": 64,
    "csw": False,
    "csw_rule": "literal",  # the paper's rule
    "tau": None,  # the rule's own default: see csw.tau.default_tau
    "uniqueness": None,  # the cost's default: see csw.kernels.contract.DEFAULT_UNIQUENESS
    "threads": None,  # all cores
    **OFF,  # the pipeline's stages (csw.pipeline), all off
}

PRESETS = {
    # The paper's method exactly, what TABLE II measures: no stage may be added to it.
    "paper": {"engine": "window", "cost": "sad", "window": PAPER_WINDOW, **OFF},
    # The contract's raw winner-take-all map, with the engine and cost as given.
    "raw": {**OFF},
    # The pipeline recommended for real photographs, one setting for every dataset
    # (reports/quality.md has the measurements): census 7x7 over a 9x9 window, the
    # left-right check at 2, and speckles under 100 pixels removed.
    "accurate": {**OFF, "cost": "census", "census_window": 7, "lr_check": 2,
                 "speckle_size": 100, "speckle_range": 1.0},
}

# Experiments (bench, sweep) time and score on one thread, the paper's setting, unless told.
BENCH_THREADS = 1
BENCH_REPEAT = 5

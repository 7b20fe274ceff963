"""The one table of matching defaults: ``csw.match``, ``csw match`` and every command that
matches read it, so a default can't drift between the library and the CLI."""

MATCH = {
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
}

# Experiments (bench, sweep) time and score on one thread, the paper's setting, unless told.
BENCH_THREADS = 1
BENCH_REPEAT = 5

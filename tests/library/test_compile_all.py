"""csw compile puts in the cache every kernel a run can load (the catalogue's,
csw.kernels.catalogue.every_entry): drawn at random from the options table, no set of
options needs one it leaves out (tests/cli/test_cli_startup.py runs one preset's end to
end)."""

import numpy as np
import pytest

from csw.config import params
from csw.kernels.catalogue import LARGEST_WINDOW, every_entry
from csw.matching.setup import config_entries


def random_value(option, rng):
    """A value of ``option`` the table allows (windows up to LARGEST_WINDOW)."""
    if option.choices:
        return option.choices[rng.integers(len(option.choices))]
    if option.name in ("window", "census_window"):
        top = LARGEST_WINDOW if option.name == "window" else 15
        return int(rng.choice(np.arange(option.low, top + 1, 2)))
    if option.name == "dmin":
        return int(rng.integers(-20, 10))
    if option.name == "dmax":
        return int(rng.integers(10, 60))
    if option.kind == "bool":
        return bool(rng.integers(2))
    if option.kind == "tau":
        return ["auto", "none", float(rng.integers(0, 2000))][rng.integers(3)]
    if option.kind in ("off_int", "auto_int"):
        return None if rng.integers(2) else int(rng.integers(max(option.low or 0, 1), 50))
    if option.kind == "float":
        return float(rng.uniform(option.low, min(option.high, 10)))
    return int(rng.integers(option.low or 0, min(option.high or 100, 100) + 1))


def test_no_set_of_options_needs_a_kernel_compile_leaves_out():
    everything = set(every_entry())
    rng = np.random.default_rng(2026)
    checked = 0
    while checked < 600:
        given = {name: random_value(o, rng) for name, o in params.OPTIONS.items()
                 if name != "threads" and rng.random() < 0.6}
        if not given.get("csw"):
            given.pop("tau", None)
            given.pop("csw_margin", None)
        try:
            config = params.resolve(**given)
            if not config.range_known:
                config = config.replace(dmin=0, dmax=32)
            wanted = [(k, tuple(v)) for dtype in (np.uint8, np.uint16)
                      for confidence in (False, True)
                      for k, v in config_entries(config, np.dtype(dtype), confidence)]
        except ValueError:  # options that can't go together (the paper preset and a stage)
            continue
        assert set(wanted) <= everything, given
        checked += 1
    from csw.kernels.catalogue import entry

    assert {entry("remap", kind) for kind in ("maps", "fixed", np.uint8, np.uint16)} \
        <= everything


@pytest.mark.parametrize("name", ["csw_rule", "tau", "csw_margin", "speckle_range",
                                  "texture_threshold", "prefilter_cap", "threads", "dmax"])
def test_an_option_that_is_a_kernel_argument_chooses_no_kernel(name):
    """The enumeration's claim: these options change no compiled entry."""
    rng = np.random.default_rng(7)
    base = params.resolve(preset="accurate", csw=True, dmax=32)
    seen = set()
    for _ in range(5):
        value = random_value(params.OPTIONS[name], rng)
        try:
            config = base.replace(**{name: value})
        except (TypeError, ValueError):
            continue
        seen.add(tuple(config_entries(config, np.dtype(np.uint8))))
    assert len(seen) == 1


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_a_default_match_after_compile_preset_sgm_compiles_nothing(dtype):
    """The README's CI recipe: ``csw compile --preset sgm``, then a default ``csw
    match`` on a new photo, whose range is found by a coarse match of the shrunk pair
    (dmin 0 given, or found) before the match itself."""
    from csw.matching.disparity_range import coarse_configs
    from csw.matching.setup import preset_entries

    compiled = set(preset_entries([params.DEFAULTS["preset"]]))
    default = params.resolve()
    runs = [*coarse_configs(), default.replace(dmax=40)]
    for config in runs:
        wanted = {(k, tuple(v)) for k, v in config_entries(config, np.dtype(dtype))}
        assert wanted <= compiled, sorted(wanted - compiled)

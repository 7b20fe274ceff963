"""The kernel catalogue: every compiled kernel csw has, in one table, and the entries a
match loads.  ``csw compile`` (every variant of every kernel), the set-up's list of what
a Config loads (csw.matching.setup, csw.matching.pipeline) and the compiler's time
estimate (kernels/compiler.py) all read it, and a kernel it does not name can be neither
compiled nor loaded (``spec_of``).

A kernel is its workers, kernels/jit/NAME.py (``spec(*variant)``), and its driver, a
module of kernels/ whose ``variant(...)`` names the variant a call runs: the parameters
fixed at compile time (kernels/native.py).  Its row says what a variant fixes, every
variant a run can load, and how long one takes to compile.  The costs have their own
table (kernels/costs.py).

No Numba here: the drivers are imported where a row's variants are listed.
"""

import importlib
import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .contract import CENSUS_PATTERNS, MAX_CENSUS_BITS, census_bits, census_dtype
from .costs import COSTS_TABLE, cost_named

# What csw compile lists: windows up to this side (a wider one, rare, compiles its own
# on first use), images of these types, census windows up to this side (csw.config's
# largest; sparse 15 x 15 is the widest census within 64 bits).
LARGEST_WINDOW = 31
IMAGE_TYPES = (np.dtype(np.uint8), np.dtype(np.uint16))
LARGEST_CENSUS_WINDOW = 15
FILTER_KINDS = ("lr", "winners", "speckle", "median", "fill", "float")  # jit/filters.py
# The costs the engines' workers compute (psi in jit/fast.py and jit/sgm.py, window_cost
# in jit/window.py): each cost of kernels/costs.py runs as one of them.  The workers
# treat any other name as shd, so spec_of refuses it.
WORKER_COSTS = ("sad", "ssd", "shd")


@dataclass(frozen=True)
class Kernel:
    """One compiled kernel.

    name: its workers' module, kernels/jit/NAME.py, and its entries' first half.
    fields: what its variants fix, in order (the arguments of the jit module's spec).
    compile_seconds: Numba's time for one entry on the 2-core machine csw is measured
        on, shared with other work as a CI runner is (compiler.py sums them for the
        notice before a compile and to share the work between processes).
    variants(largest_window): every variant a run can load, windows up to that side.
    """

    name: str
    fields: tuple
    compile_seconds: float
    variants: Callable[[int], list]


def _compared(cost):
    """What a cost's workers compare, as (type, bits a pixel): the images' types (bits
    None: the type's), or for census the codes of every census window and pattern."""
    if not cost.census:
        return [(pixels, None) for pixels in IMAGE_TYPES]
    return sorted({(np.dtype(census_dtype(size, pattern)), census_bits(size, pattern))
                   for size, pattern in _census_windows()}, key=lambda c: (c[0].itemsize, c[1]))


def _compared_types(cost):
    return list(dict.fromkeys(compared for compared, _ in _compared(cost)))


def _census_windows():
    """Every (census window, pattern) within 64 bits."""
    return [(size, pattern) for size in range(3, LARGEST_CENSUS_WINDOW + 1, 2)
            for pattern in CENSUS_PATTERNS if census_bits(size, pattern) <= MAX_CENSUS_BITS]


FLAGS = list(itertools.product((False, True), repeat=3))  # csw, right map, extras


def _fast_variants(largest_window):
    from .fast import variant

    return [variant(cost.code, compared, window, *flags, dmin)
            for cost in COSTS_TABLE for compared in _compared_types(cost)
            for window in range(1, largest_window + 1, 2)
            for flags in FLAGS for dmin in (0, -1)]


def _window_variants(largest_window):
    from .window import variant

    return [variant(cost.code, compared, 1, *flags, dmin)  # one variant serves every window
            for cost in COSTS_TABLE for compared in _compared_types(cost)
            for flags in FLAGS for dmin in (0, -1)]


def _sgm_variants(largest_window, largest_penalty=10**7):
    """Penalties from 0 up to ``largest_penalty``: P2 0, the largest window cost and
    largest_penalty reach every accumulator type a cost and window can have."""
    from .sgm import PATHS, accumulator, variant

    found = []
    for cost in COSTS_TABLE:
        for (compared, bits), window in itertools.product(
                _compared(cost), range(1, largest_window + 1, 2)):
            cmax = cost.per_pixel(compared, bits) * window * window
            for p2, paths, banded in itertools.product((0, cmax, largest_penalty), PATHS,
                                                       (False, True)):
                try:
                    acc = accumulator(cmax, 0, p2, paths, banded)
                except ValueError:  # no run can have it
                    continue
                found += [variant(cost.code, compared, cmax, acc, dmin, banded)
                          for dmin in (0, -1)]
    return found


def _census_variants(largest_window):
    from .census import variant

    return [variant(pixels, size, pattern) for pixels in IMAGE_TYPES
            for size, pattern in _census_windows()]


def _prefilter_variants(largest_window):
    from .prefilter import variant

    return [variant(pixels) for pixels in IMAGE_TYPES]


def _pad_variants(largest_window):
    from .pad import variant

    return [variant(pixels) for pixels in IMAGE_TYPES]


def _colour_variants(largest_window):
    from .colour import variant

    return [variant(pixels, channels) for pixels in IMAGE_TYPES for channels in (3, 4)]


def _remap_variants(largest_window):
    from .remap import variant

    return [variant(kind) for kind in (None, "fixed", *IMAGE_TYPES)]


KERNELS = {kernel.name: kernel for kernel in (
    Kernel("fast", ("cost", "pixels", "accumulator", "csw", "right_map", "extras",
                    "negative"), 12.0, _fast_variants),
    Kernel("window", ("cost", "pixels", "csw", "right_map", "extras", "negative"), 4.5,
           _window_variants),
    Kernel("sgm", ("cost", "pixels", "costs", "accumulator", "negative", "banded"), 1.0,
           _sgm_variants),
    Kernel("census", ("pixels", "codes"), 3.0, _census_variants),
    Kernel("filters", ("kind",), 2.4, lambda largest: [(kind,) for kind in FILTER_KINDS]),
    Kernel("prefilter", ("pixels",), 1.0, _prefilter_variants),
    Kernel("pad", ("pixels",), 1.0, _pad_variants),
    Kernel("colour", ("pixels", "channels"), 1.0, _colour_variants),
    Kernel("remap", ("kind", "pixels"), 1.0, _remap_variants),  # kind "remap", "maps", "fixed"
)}


def kernel_named(name):
    """The catalogue's Kernel called ``name``; KeyError if it has none."""
    try:
        return KERNELS[name]
    except KeyError:
        raise KeyError(f"{name!r} is not a kernel of the catalogue (kernels/catalogue.py: "
                       f"{', '.join(KERNELS)}); add its row there") from None


def spec_of(kernel, variant):
    """The Spec of a catalogued kernel's variant (imports its jit module, and so Numba);
    ValueError for a cost its workers do not compute."""
    row = kernel_named(kernel)
    if "cost" in row.fields and variant[row.fields.index("cost")] not in WORKER_COSTS:
        raise ValueError(f"the {kernel} workers compute {', '.join(WORKER_COSTS)}, not "
                         f"{variant[row.fields.index('cost')]!r} (kernels/catalogue.py, "
                         "WORKER_COSTS)")
    module = importlib.import_module(f"{__package__}.jit.{row.name}")
    return module.spec(*variant)


def entries_of(kernel, largest_window=LARGEST_WINDOW):
    """Every (kernel, variant) of one kernel a run can load, windows up to
    ``largest_window``."""
    variants = kernel_named(kernel).variants(largest_window)
    return [(kernel, variant) for variant in dict.fromkeys(map(tuple, variants))]


def every_entry(largest_window=LARGEST_WINDOW):
    """Every (kernel, variant) a run can load, whatever the options' values (windows up
    to ``largest_window``), for 8- and 16-bit images: what ``csw compile`` puts in the
    cache, so that no run after it compiles."""
    return [entry for kernel in KERNELS for entry in entries_of(kernel, largest_window)]


def compile_seconds(kernel):
    """The estimate of one entry's compile (see Kernel)."""
    return kernel_named(kernel).compile_seconds


# The entries a match loads, from its settings (csw.matching.pipeline gives them from a
# Config's).

def engine_entries(engine, cost, pixels, window, census_window, csw, right_map, extras,
                   dmin=0, lr_check=False, census_pattern=None):
    """The entries a local match (kernels.match) with these settings loads: its census
    transform, if any, its engine's variant, and the window engine's left-right check
    (the fast engine makes it in its rows).  lr_check: whether there is one."""
    from . import fast
    from . import window as window_engine

    cost = cost_named(cost)
    compared = census_dtype(census_window, census_pattern) if cost.census else pixels
    module = {"fast": fast, "window": window_engine}[engine]
    check = filter_entries("lr") if lr_check and engine != "fast" else []
    return census_entries(cost.name, pixels, census_window, census_pattern) + check + \
        [(engine, module.variant(cost.code, compared, window, csw, right_map or lr_check,
                                 extras, dmin))]


def sgm_entries(cost, pixels, window, dmin, paths, p1, p2, census_window=None,
                census_pattern=None, banded=False):
    """The entries a semi-global match (kernels.sgm.match_sgm) loads: its census
    transform, if any, and its worker (``banded``: a narrowed search's)."""
    from . import sgm
    from .contract import census_bits

    cost = cost_named(cost)
    compared, bits = pixels, None
    if cost.census:
        compared = census_dtype(census_window, census_pattern)
        bits = census_bits(census_window, census_pattern)
    cmax = cost.per_pixel(compared, bits) * window * window
    acc = sgm.accumulator(cmax, p1, p2, paths, banded)
    return census_entries(cost.name, pixels, census_window, census_pattern) + \
        [("sgm", sgm.variant(cost.code, compared, cmax, acc, dmin, banded))]


def census_entries(cost, pixels, census_window, pattern):
    """The census transform's entry a match with this cost loads for its codes (none
    for a cost that compares the pixels)."""
    from .census import variant

    return [("census", variant(pixels, census_window, pattern))] \
        if cost_named(cost).census else []


def filter_entries(*kinds):
    """The filters' entries of these kinds (FILTER_KINDS)."""
    for kind in kinds:
        if kind not in FILTER_KINDS:
            raise ValueError(f"filter kind must be one of {', '.join(FILTER_KINDS)}, "
                             f"got {kind!r}")
    return [("filters", (kind,)) for kind in kinds]


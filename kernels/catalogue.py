"""The kernel catalogue: every compiled kernel csw has, in one table, and the entries a
match loads.  ``csw compile`` (every variant of every kernel), the set-up's list of what
a Config loads (csw.matching.setup, csw.matching.pipeline) and the compiler's time
estimate (kernels/compiler.py) all read it, and a kernel it does not name can be neither
compiled nor loaded (``spec_of``).

A kernel is its workers, kernels/jit/NAME.py (``spec(*variant)``), and its driver, a
module of kernels/ that loads it as ``native.entry(*entry("NAME", settings...))``.  Its
row says what a variant fixes (the parameters fixed at compile time: kernels/native.py),
which variant a call's settings run, every variant a run can load, and how long one
takes to compile.  The costs have their own table (kernels/costs.py).

Nothing here imports a driver, or Numba: the drivers and the cache (kernels/native.py,
kernels/compiler.py) import this.
"""

import functools
import importlib
import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .contract import CENSUS_PATTERNS, MAX_CENSUS_BITS, census_bits, census_dtype, dtype_name
from .costs import COSTS_TABLE, accumulator_dtype, cost_coded, cost_named

# What csw compile lists: windows up to this side (a wider one, rare, compiles its own
# on first use), images of these types, census windows up to this side (csw.config's
# largest; sparse 15 x 15 is the widest census within 64 bits).
LARGEST_WINDOW = 31
IMAGE_TYPES = (np.dtype(np.uint8), np.dtype(np.uint16))
LARGEST_CENSUS_WINDOW = 15
FILTER_KINDS = ("lr", "winners", "speckle", "median", "fill", "float", "subpixel",
                "confidence", "starts")  # jit/filters.py
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
    variant(*settings): the variant a call with these settings runs (its driver's
        settings: see ``entry``).
    variants(largest_window): every variant a run can load, windows up to that side.
    """

    name: str
    fields: tuple
    compile_seconds: float
    variant: Callable[..., tuple]
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


# The local engines (kernels/fast.py, kernels/window.py).

def _fast_variant(cost, pixels, window, csw, right_map, extras, dmin=0):
    """cost: a cost code (kernels/costs.py); pixels: the compared type, the images' or
    their census codes'; right_map: the right image's best matches are tracked (for its
    map or the left-right check)."""
    acc = accumulator_dtype(pixels, cost, window)
    return (cost_coded(cost).worker, dtype_name(pixels), dtype_name(acc), bool(csw),
            bool(right_map), bool(extras), dmin < 0)


def padded_type(pixels):
    """The type the window engine pads to: uint16 for 8- and 16-bit images (one variant
    for both), census codes keep their own."""
    return np.dtype(np.uint16) if np.dtype(pixels).itemsize <= 2 else np.dtype(pixels)


def _window_variant(cost, pixels, window, csw, right_map, extras, dmin=0):
    """As the fast engine's: one compiled variant serves every window."""
    return (cost_coded(cost).worker, dtype_name(padded_type(pixels)), bool(csw),
            bool(right_map), bool(extras), dmin < 0)


def _local_variants(variant, largest_window):
    return [variant(cost.code, compared, window, *flags, dmin)
            for cost in COSTS_TABLE for compared in _compared_types(cost)
            for window in range(1, largest_window + 1, 2)
            for flags in FLAGS for dmin in (0, -1)]


# Semi-global matching (kernels/sgm.py): its types follow from the largest window cost
# cmax, the penalties and the paths.

PATHS = (4, 5, 8)


def sentinel(cmax, p2, banded=False):
    """The path states' sentinel: above every path value (at most cmax + P2), and in a
    banded match above every min_j L + P2 too, so that a d the pixel before did not
    search counts as none (kernels/jit/sgm.py)."""
    return cmax + p2 * (2 if banded else 1)


@functools.cache
def accumulator(cmax, p1, p2, paths, banded=False):
    """The accumulator type (np.uint16 or np.uint32) in which every path value (at most
    cmax + P2), its sentinel plus P1 and every sum over the paths fits below the type's
    largest value, which marks none; ValueError if none does."""
    for dtype in (np.uint16, np.uint32):
        top = int(np.iinfo(dtype).max)
        if sentinel(cmax, p2, banded) + p1 < top and paths * (cmax + p2) < top:
            return np.dtype(dtype)
    raise ValueError(f"semi-global sums of costs up to {cmax} with P2 {p2} over {paths} "
                     "paths exceed 32 bits; use a smaller window, a Hamming cost or "
                     "smaller penalties")


def cost_type(cmax, acc):
    """The cost slab's type: a byte where every cost fits one (half the memory traffic
    of the paths' reads), else the accumulator's."""
    return np.dtype(np.uint8) if cmax <= 255 else acc


def aggregated_max(cost, compared, bits, window):
    """c_max, the largest cost a semi-global match aggregates (a Cost, its compared type,
    a census code's bits or None, the window's side): the largest window cost, but for a
    Hamming cost whose largest lies in 256..510, 255, every cost above it truncated to it.
    Its slab then holds bytes (cost_type), half the costs' memory traffic: a KITTI
    match took 3-4% less time (docs/engines.md).  Only costs with more than half the
    bits differing change: worse than two unrelated patches', which differ in half
    their bits."""
    largest = cost.per_pixel(compared, bits) * window * window
    return 255 if cost.worker == "shd" and 255 < largest <= 510 else largest


def _sgm_variant(cost, pixels, cmax, acc, dmin=0, banded=False):
    """cost: a cost code; pixels: the compared type; cmax: its largest window cost;
    acc: its accumulator type."""
    return (cost_coded(cost).worker, dtype_name(pixels), dtype_name(cost_type(cmax, acc)),
            dtype_name(acc), dmin < 0, bool(banded))


def _sgm_variants(largest_window, largest_penalty=10**7):
    """Penalties from 0 up to ``largest_penalty``: P2 0, the largest window cost and
    largest_penalty reach every accumulator type a cost and window can have."""
    found = []
    for cost in COSTS_TABLE:
        for (compared, bits), window in itertools.product(
                _compared(cost), range(1, largest_window + 1, 2)):
            cmax = aggregated_max(cost, compared, bits, window)
            for p2, paths, banded in itertools.product((0, cmax, largest_penalty), PATHS,
                                                       (False, True)):
                try:
                    acc = accumulator(cmax, 0, p2, paths, banded)
                except ValueError:  # no run can have it
                    continue
                found += [_sgm_variant(cost.code, compared, cmax, acc, dmin, banded)
                          for dmin in (0, -1)]
    return found


# The kernels around matching.

def _census_variant(pixels, size, pattern):
    """Images of type ``pixels``, a census window of ``size`` and a pattern."""
    return (dtype_name(pixels), dtype_name(census_dtype(size, pattern)))


def _filter_variant(kind):
    if kind not in FILTER_KINDS:
        raise ValueError(f"filter kind must be one of {', '.join(FILTER_KINDS)}, "
                         f"got {kind!r}")
    return (kind,)


def _image_variant(pixels):
    """Images of type ``pixels`` (the prefilter, the bound calls' padding)."""
    return (dtype_name(pixels),)


def _colour_variant(pixels, channels=3):
    """Images of type ``pixels`` with ``channels`` a pixel (3: RGB, 4: RGBA)."""
    return (dtype_name(pixels), int(channels))


def _remap_variant(kind):
    """"maps" (the undistort-rectify maps' builder), "fixed" (their conversion into
    fixed point), or an image type (the remap of such images)."""
    return (kind,) if kind in ("maps", "fixed") else ("remap", dtype_name(kind))


KERNELS = {kernel.name: kernel for kernel in (
    Kernel("fast", ("cost", "pixels", "accumulator", "csw", "right_map", "extras",
                    "negative"), 12.0, _fast_variant,
           lambda largest: _local_variants(_fast_variant, largest)),
    Kernel("window", ("cost", "pixels", "csw", "right_map", "extras", "negative"), 4.5,
           _window_variant,  # one variant serves every window: window 1 lists them all
           lambda largest: _local_variants(_window_variant, 1)),
    # sgm: one variant (census codes, byte costs, 16-bit sums) into an empty cache took
    # 16.8 s; its workers hold five steps, more code than any other kernel's.
    Kernel("sgm", ("cost", "pixels", "costs", "accumulator", "negative", "banded"), 17.0,
           _sgm_variant, _sgm_variants),
    Kernel("census", ("pixels", "codes"), 3.0, _census_variant,
           lambda largest: [_census_variant(pixels, size, pattern) for pixels in IMAGE_TYPES
                            for size, pattern in _census_windows()]),
    Kernel("filters", ("kind",), 2.4, _filter_variant,
           lambda largest: [(kind,) for kind in FILTER_KINDS]),
    Kernel("prefilter", ("pixels",), 1.0, _image_variant,
           lambda largest: [_image_variant(pixels) for pixels in IMAGE_TYPES]),
    Kernel("pad", ("pixels",), 1.0, _image_variant,
           lambda largest: [_image_variant(pixels) for pixels in IMAGE_TYPES]),
    Kernel("colour", ("pixels", "channels"), 1.0, _colour_variant,
           lambda largest: [_colour_variant(pixels, channels) for pixels in IMAGE_TYPES
                            for channels in (3, 4)]),
    Kernel("remap", ("kind", "pixels"), 1.0, _remap_variant,  # kind "remap", "maps", "fixed"
           lambda largest: [_remap_variant(kind) for kind in ("maps", "fixed", *IMAGE_TYPES)]),
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


def entry(kernel, *settings):
    """(kernel, variant): the entry a call of ``kernel`` with these settings runs, its
    variant from the kernel's row (``native.entry(*entry(...))`` loads it)."""
    row = kernel_named(kernel)
    return row.name, row.variant(*settings)


# The entries a match loads, from its settings (csw.matching.pipeline gives them from a
# Config's).

def engine_entries(engine, cost, pixels, window, census_window, csw, right_map, extras,
                   dmin=0, lr_check=False, census_pattern=None):
    """The entries a local match (kernels.match) with these settings loads: its census
    transform, if any, its engine's variant, and the window engine's left-right check
    (the fast engine makes it in its rows).  lr_check: whether there is one."""
    cost = cost_named(cost)
    compared = census_dtype(census_window, census_pattern) if cost.census else pixels
    check = [entry("filters", "lr")] if lr_check and engine != "fast" else []
    return census_entries(cost.name, pixels, census_window, census_pattern) + check + \
        [entry(engine, cost.code, compared, window, csw, right_map or lr_check, extras, dmin)]


def sgm_entries(cost, pixels, window, dmin, paths, p1, p2, census_window=None,
                census_pattern=None, banded=False):
    """The entries a semi-global match (kernels.sgm.match_sgm) loads: its census
    transform, if any, and its worker (``banded``: a narrowed search's)."""
    cost = cost_named(cost)
    compared, bits = pixels, None
    if cost.census:
        compared = census_dtype(census_window, census_pattern)
        bits = census_bits(census_window, census_pattern)
    cmax = aggregated_max(cost, compared, bits, window)
    acc = accumulator(cmax, p1, p2, paths, banded)
    return census_entries(cost.name, pixels, census_window, census_pattern) + \
        [entry("sgm", cost.code, compared, cmax, acc, dmin, banded)]


def census_entries(cost, pixels, census_window, pattern):
    """The census transform's entry a match with this cost loads for its codes (none
    for a cost that compares the pixels)."""
    return [entry("census", pixels, census_window, pattern)] \
        if cost_named(cost).census else []

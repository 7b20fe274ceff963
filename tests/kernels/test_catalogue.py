"""The kernel catalogue (kernels/catalogue.py) names every compiled kernel, and the cost
table (kernels/costs.py) every cost: a kernel left out of the catalogue, or a cost out of
the table, fails here or raises where it is used, never falls back to another."""

import re
from pathlib import Path

import numpy as np
import pytest

from csw import kernels
from csw.kernels import catalogue, costs, fast, native, sgm
from csw.kernels.signature import Spec

KERNELS_DIR = Path(kernels.__file__).parent


def test_every_jit_module_with_workers_is_a_kernel_of_the_catalogue():
    with_spec = {path.stem for path in (KERNELS_DIR / "jit").glob("*.py")
                 if re.search(r"^def spec\(", path.read_text(), re.M)}
    assert with_spec == set(catalogue.KERNELS)


def test_every_entry_a_driver_loads_names_a_kernel_of_the_catalogue():
    """Drivers load their entries as native.entry(*entry("name", settings...)), the
    variant from the catalogue's row: a name the catalogue lacks, or a call that makes
    its entry otherwise, fails here."""
    named = set()
    for path in KERNELS_DIR.glob("*.py"):
        if path.name == "catalogue.py":  # whose docstring shows the call
            continue
        for call in re.findall(r"native\.entry\((.{0,20})", path.read_text()):
            literal = re.match(r'\*entry\("(\w+)"', call)
            assert literal, f"{path.name}: native.entry({call}...) is not the catalogue's"
            named.add(literal.group(1))
    assert named == set(catalogue.KERNELS)


def test_every_entry_the_suite_compiles_first_is_in_the_catalogue():
    """tests/suite_kernels.txt, the entries the session compiles before its first test:
    a name the catalogue no longer has would be skipped there, silently slower."""
    from suite_kernels import catalogued, listed

    names = listed()
    assert names and len(set(names)) == len(names)
    assert not set(names) - set(catalogued()), "run make suite-kernels"


@pytest.mark.slow  # builds 354 specs: about a second
def test_every_catalogued_variant_gives_its_workers_spec():
    for name, kernel in catalogue.KERNELS.items():
        variants = catalogue.entries_of(name)
        assert variants, name
        for _, variant in variants:
            assert len(variant) <= len(kernel.fields), (name, variant)
            assert isinstance(catalogue.spec_of(name, variant), Spec)
        assert kernel.compile_seconds > 0


def test_every_cost_runs_as_a_cost_the_workers_compute():
    assert {cost.worker for cost in costs.COSTS_TABLE} <= set(catalogue.WORKER_COSTS)
    with pytest.raises(ValueError, match="workers compute"):
        catalogue.spec_of("fast", ("zncc", "u8", "u16", False, False, False, False))


def test_csw_compile_lists_every_variant_of_every_kernel_once():
    everything = catalogue.every_entry()
    assert len(everything) == len(set(everything))
    assert {name for name, _ in everything} == set(catalogue.KERNELS)


def test_a_kernel_outside_the_catalogue_is_neither_compiled_nor_loaded():
    with pytest.raises(KeyError, match="not a kernel of the catalogue"):
        native.entry("nope", ("u8",))
    with pytest.raises(KeyError, match="not a kernel of the catalogue"):
        catalogue.compile_seconds("nope")


@pytest.mark.slow
def test_one_variant_of_each_kernel_compiles_and_loads(tmp_path, monkeypatch):
    """Into an empty cache, through the catalogue (the rest share their code with it:
    the variants only fix types and flags)."""
    monkeypatch.setenv("CSW_KERNEL_CACHE", str(tmp_path))
    native.clear()
    try:
        first = [catalogue.entries_of(name)[0] for name in catalogue.KERNELS]
        native.ensure(first, notice=False)
        assert all(isinstance(native.entry(*e), native.Entry) for e in first)
        assert len(list(tmp_path.glob("*/*.o"))) == len(first)
    finally:
        native.clear()  # later tests load from the usual cache


def test_the_cost_table_holds_each_cost_and_what_it_implies():
    assert list(costs.COSTS) == ["sad", "ssd", "shd", "census"]
    assert kernels.COSTS == costs.COSTS
    u8, u16 = np.dtype(np.uint8), np.dtype(np.uint16)
    assert costs.cost_named("sad").per_pixel(u16) == 65535
    assert costs.cost_named("ssd").per_pixel(u8) == 255 * 255
    assert costs.cost_named("shd").per_pixel(u16) == 16
    assert costs.cost_named("census").per_pixel(np.dtype(np.uint32), bits=24) == 24
    assert costs.cost_named("census").worker == "shd" and costs.cost_named("census").census
    assert sgm.default_penalties("sad", 3) == (72, 288)  # OpenCV's 8 and 32 per pixel
    assert sgm.default_penalties("census", 5, 32) == (200, 800)


UNKNOWN = 9  # a cost code the table does not hold


@pytest.mark.parametrize("use", [
    lambda: costs.cost_named("zncc"),
    lambda: costs.cost_coded(UNKNOWN),
    lambda: fast.accumulator_dtype(np.dtype(np.uint8), UNKNOWN, 3),
    lambda: catalogue.entry("fast", UNKNOWN, np.dtype(np.uint8), 3, False, False, False),
    lambda: catalogue.entry("window", UNKNOWN, np.dtype(np.uint8), 3, False, False, False),
    lambda: catalogue.entry("sgm", UNKNOWN, np.dtype(np.uint8), 100, np.dtype(np.uint16)),
    lambda: sgm.default_penalties("zncc", 3),
    lambda: catalogue.engine_entries("fast", "zncc", np.dtype(np.uint8), 3, 5, False,
                                     False, False),
    lambda: catalogue.sgm_entries("zncc", np.dtype(np.uint8), 3, 0, 4, 8, 32),
    lambda: catalogue.census_entries("zncc", np.dtype(np.uint8), 5, "dense"),
    lambda: kernels.match(np.zeros((8, 8), np.uint8), np.zeros((8, 8), np.uint8),
                          engine="fast", window=3, dmin=0, dmax=2, cost="zncc"),
], ids=["named", "coded", "accumulator", "fast", "window", "sgm", "penalties",
        "engine-entries", "sgm-entries", "census-entries", "match"])
def test_an_unknown_cost_raises_rather_than_falling_back(use):
    with pytest.raises(ValueError, match="cost"):
        use()


def test_an_unknown_filter_kind_raises():
    with pytest.raises(ValueError, match="filter kind"):
        catalogue.entry("filters", "blur")

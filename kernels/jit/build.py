"""Compiling a kernel entry: a C-callable wrapper around a worker, compiled by Numba, and
its machine code as an object file (see kernels/native.py)."""

import contextlib
import threading

import llvmlite.binding as llvm
import numba
import numpy as np
from numba import carray, cfunc, types

from ..catalogue import spec_of
from .options import ENTRY, LLVM_OPTIONS

# The Numba helpers a stored entry may call: the GIL's, which the loader provides, and
# those only its error path calls, which the loader records as a failure (the workers
# never take that path).  Any other, such as reshape's numba_attempt_nocopy_reshape, is
# on a normal path: loaded without Numba, every call would fail.
LOADED_WITHOUT_NUMBA = frozenset({
    "numba_gil_ensure", "numba_gil_release", "numba_do_raise", "numba_unpickle",
    "numba_runtime_build_excinfo_struct", "NRT_Free", "NRT_MemInfo_call_dtor"})

SIGNATURE = types.int64(types.CPointer(types.voidptr), types.CPointer(types.int64),
                        types.CPointer(types.int64))


def wrapper_source(spec):
    """Python source of ``entry(arrays, dims, scalars)``: each array rebuilt from its
    pointer and dimensions, then ``worker(*arrays, scalars)``."""
    signature = spec.signature
    lines = ["def entry(arrays, dims, scalars):"]
    names, dim = [], 0
    for i, ndim in enumerate(a.ndim for a in signature.arrays):
        shape = ", ".join(f"dims[{dim + d}]" for d in range(ndim)) + ("," if ndim == 1 else "")
        lines.append(f"    a{i} = carray(arrays[{i}], ({shape}), T{i})")
        names.append(f"a{i}")
        dim += ndim
    lines.append(f"    values = carray(scalars, ({len(signature.scalars)},), np.int64)")
    lines.append(f"    return worker({', '.join(names + ['values'])})")
    return "\n".join(lines)


def _compiled(kernel, variant):
    """A variant's spec and its entry compiled by Numba."""
    spec = spec_of(kernel, variant)
    return spec, compile_spec(spec, f"{kernel} {variant}")


_options_lock = threading.Lock()


@contextlib.contextmanager
def csw_llvm_options():
    """LLVM_OPTIONS set while the block compiles, LLVM's defaults again after it: the
    options are the process's, and a notebook's own Numba functions compiled later keep
    LLVM's choices.  (A compile in another thread meanwhile would see csw's.)"""
    with _options_lock:
        for option, (ours, _) in LLVM_OPTIONS.items():
            llvm.set_option("csw", f"-{option}={ours}")
        try:
            yield
        finally:
            for option, (_, default) in LLVM_OPTIONS.items():
                llvm.set_option("csw", f"-{option}={default}")


def compile_spec(spec, name):
    """The C-callable entry of a Spec, compiled by Numba (a cfunc), with csw's LLVM
    options (its machine code is made then: the cfunc is compiled when made)."""
    namespace = {"carray": carray, "np": np, "worker": spec.worker}
    namespace.update({f"T{i}": a.dtype.type for i, a in enumerate(spec.signature.arrays)})
    exec(compile(wrapper_source(spec), f"<csw kernel {name}>", "exec"), namespace)
    with csw_llvm_options():
        return cfunc(SIGNATURE, **ENTRY)(namespace["entry"])


def compile_entry(kernel, variant):
    """(symbol, (description, object code)) of a variant's entry."""
    spec, compiled = _compiled(kernel, variant)
    return compiled.native_name, stored_form(spec, compiled, f"{kernel} {variant}")


def stored_form(spec, compiled, name):
    """(description, object code) of a compiled entry, as the cache stores it.  An entry
    whose worker allocates (it imports Numba's allocator) is refused: the loaded code
    has no Numba runtime to allocate with, and the workers' layer must not allocate."""
    code, imports, _ = numba_internals(compiled)
    allocators = [n for n in imports if n.startswith(("NRT_MemInfo_alloc", "NRT_Allocate"))]
    if allocators:
        raise RuntimeError(f"csw's kernel {name} allocates ({', '.join(allocators)}); a "
                           "worker must take its scratch from its driver")
    helpers = [n for n in imports if n.startswith(("numba_", "NRT_")) and
               n not in LOADED_WITHOUT_NUMBA]
    if helpers:
        raise RuntimeError(f"csw's kernel {name} calls Numba's {', '.join(helpers)}, which "
                           "a kernel loaded without Numba does not have (kernels/loader.py); "
                           "write the worker without it")
    description = dict(spec.signature.describe(), numba=numba.__version__, imports=imports)
    return description, code


def numba_internals(compiled):
    """(object code bytes, the symbols it imports, the code library) of a compiled cfunc.

    The one place csw reads Numba's private attributes (``_library``,
    ``serialize_using_object_code``, ``_final_module``), which Numba has no public way
    to give; a Numba that changed them fails here, in one line, and
    tests/kernels/test_kernels_cache.py checks it on every run of the suite."""
    try:
        library = compiled._library
        _, _, (code, _) = library.serialize_using_object_code()
        module = library._final_module
        imports = sorted({f.name for f in module.functions if f.is_declaration and
                          not f.name.startswith("llvm.")} |
                         {g.name for g in module.global_variables if g.is_declaration})
    except (AttributeError, TypeError, ValueError) as exc:
        raise RuntimeError(f"csw's kernel cache can't read Numba {numba.__version__}'s "
                           f"compiled code ({type(exc).__name__}: {exc}); install the "
                           "Numba version pyproject.toml names") from None
    if not isinstance(code, bytes):
        raise RuntimeError(f"csw's kernel cache can't read Numba {numba.__version__}'s "
                           "object code (not bytes)")
    return code, imports, library


def assembly(kernel, variant):
    """The machine code of a variant's entry as assembly text (for tests that check how
    a loop was vectorised)."""
    return numba_internals(_compiled(kernel, variant)[1])[2].get_asm_str()

"""Compiling a kernel entry: a C-callable wrapper around a worker, compiled by Numba, and
its machine code as an object file (see kernels/native.py)."""

import numpy as np
from numba import carray, cfunc, types

from ..config import ENTRY

SIGNATURE = types.int64(types.CPointer(types.voidptr), types.CPointer(types.int64),
                        types.CPointer(types.int64))


def wrapper_source(spec):
    """Python source of ``entry(arrays, dims, scalars)``: each array rebuilt from its
    pointer and dimensions, then ``worker(*arrays, scalars)``."""
    lines = ["def entry(arrays, dims, scalars):"]
    names, dim = [], 0
    for i, (_, ndim) in enumerate(spec.arrays):
        shape = ", ".join(f"dims[{dim + d}]" for d in range(ndim)) + ("," if ndim == 1 else "")
        lines.append(f"    a{i} = carray(arrays[{i}], ({shape}), T{i})")
        names.append(f"a{i}")
        dim += ndim
    lines.append(f"    values = carray(scalars, ({spec.scalars},), np.int64)")
    lines.append(f"    return worker({', '.join(names + ['values'])})")
    return "\n".join(lines)


def _compiled(kernel, variant):
    """A variant's spec and its entry compiled by Numba."""
    from ..native import _spec

    spec = _spec(kernel, variant)
    namespace = {"carray": carray, "np": np, "worker": spec.worker}
    namespace.update({f"T{i}": np.dtype(d).type for i, (d, _) in enumerate(spec.arrays)})
    exec(compile(wrapper_source(spec), f"<csw kernel {kernel}>", "exec"), namespace)
    return spec, cfunc(SIGNATURE, **ENTRY)(namespace["entry"])


def compile_entry(kernel, variant):
    """(symbol, (description, object code)) of a variant's entry."""
    import numba

    spec, compiled = _compiled(kernel, variant)
    library = compiled._library
    _, _, (code, _) = library.serialize_using_object_code()
    module = library._final_module
    imports = sorted({f.name for f in module.functions if f.is_declaration and
                      not f.name.startswith("llvm.")} |
                     {g.name for g in module.global_variables if g.is_declaration})
    description = {"arrays": [(np.dtype(d).str, n) for d, n in spec.arrays],
                   "scalars": spec.scalars, "numba": numba.__version__, "imports": imports}
    return compiled.native_name, (description, code)


def assembly(kernel, variant):
    """The machine code of a variant's entry as assembly text (for tests that check how
    a loop was vectorised)."""
    return _compiled(kernel, variant)[1]._library.get_asm_str()

"""Loading a stored kernel entry without Numba: its object code into an llvmlite
execution engine, its imported symbols resolved in this process, and the entry as a
ctypes function (which releases the GIL while it runs)."""

import ctypes
import threading

from .signature import Signature
from .store import cache_dir, lock, store, verified

_ENGINES = []  # llvmlite execution engines, kept alive with the code they hold


def load(folder, key, meta):
    """The ctypes function of a stored entry (``meta``: its verified description),
    through an llvmlite execution engine."""
    import llvmlite.binding as llvm

    if not _ENGINES:
        llvm.initialize_native_target()
        llvm.initialize_native_asmprinter()
    _resolve([*meta["imports"], "memset", "memcpy", "memmove"])
    engine = llvm.create_mcjit_compiler(llvm.parse_assembly(""), _target_machine())
    engine.add_object_file(llvm.ObjectFileRef.from_data((folder / f"{key}.o").read_bytes()))
    engine.finalize_object()
    _ENGINES.append(engine)
    address = engine.get_function_address(meta["symbol"])
    if not address:
        raise RuntimeError(f"csw's kernel cache entry {folder / key} is damaged; delete "
                           f"{folder} and run again")
    c_pointers = ctypes.POINTER(ctypes.c_void_p)
    c_ints = ctypes.POINTER(ctypes.c_int64)
    return ctypes.CFUNCTYPE(ctypes.c_int64, c_pointers, c_ints, c_ints)(address)


# Numba's runtime helpers, which a loaded entry calls only on the path that reports an
# exception (a worker's bug: csw's workers check nothing and allocate nothing).  Without
# Numba in this process they are missing, and stand-ins take their place: the GIL's take
# and give it back as Numba's do (compiled here from LLVM IR: a ctypes callback can't
# keep the GIL once it returns), and the others record the failure for this thread and
# return NULL, so the entry returns and Entry raises a RuntimeError (abort() once ended
# the process there).  With Numba loaded, its own helpers serve.
_FAILED = threading.local()


def _record(*_):
    _FAILED.hit = True


_RECORD = ctypes.CFUNCTYPE(ctypes.c_void_p)(_record)
_GIL_IR = """
declare i32 @PyGILState_Ensure()
declare void @PyGILState_Release(i32)
define void @csw_gil_ensure(i32* %state) {
  %s = call i32 @PyGILState_Ensure()
  store i32 %s, i32* %state
  ret void
}
define void @csw_gil_release(i32* %state) {
  %s = load i32, i32* %state
  call void @PyGILState_Release(i32 %s)
  ret void
}
"""


def _target_machine():
    import llvmlite.binding as llvm

    return llvm.Target.from_default_triple().create_target_machine(
        cpu=llvm.get_host_cpu_name(), features=llvm.get_host_cpu_features().flatten(),
        opt=3, jit=True)


GIL_HELPERS = "gil-helpers"  # their entry in the kernel cache


def _gil_helpers():
    """The addresses of csw_gil_ensure and csw_gil_release (see _GIL_IR), loaded from
    the kernel cache as object code like the entries: compiling the IR in every process
    would start LLVM's code generator, 12 MB more at the peak of a warm run."""
    import llvmlite.binding as llvm

    folder, found = cache_dir(), {}
    if not verified(folder, GIL_HELPERS, found):
        with lock(folder):
            if not verified(folder, GIL_HELPERS, found, discard=True):
                code = _target_machine().emit_object(llvm.parse_assembly(_GIL_IR))
                description = dict(Signature((), ()).describe(), imports=[])
                store(folder, GIL_HELPERS, "csw_gil_ensure", (description, code))
                verified(folder, GIL_HELPERS, found)
    engine = llvm.create_mcjit_compiler(llvm.parse_assembly(""), _target_machine())
    engine.add_object_file(llvm.ObjectFileRef.from_data(
        (folder / f"{GIL_HELPERS}.o").read_bytes()))
    engine.finalize_object()
    _ENGINES.append(engine)
    return {"numba_gil_ensure": engine.get_function_address("csw_gil_ensure"),
            "numba_gil_release": engine.get_function_address("csw_gil_release")}


def failed():
    """Whether an entry called in this thread since the last call reached Numba's
    raise path (and forget it)."""
    hit = getattr(_FAILED, "hit", False)
    _FAILED.hit = False
    return hit


def _resolve(names):
    """Give the execution engine the address of every symbol an entry's code uses from
    outside it: the C library's (memset ...) and Python's from this process, and for
    Numba's runtime helpers, where Numba is not loaded, the stand-ins above."""
    import llvmlite.binding as llvm

    process = ctypes.CDLL(None)
    helpers = None
    for name in names:
        if llvm.address_of_symbol(name):
            continue
        if name in ("numba_gil_ensure", "numba_gil_release"):
            helpers = helpers or _gil_helpers()
            llvm.add_symbol(name, helpers[name])
        elif name.startswith(("numba_", "NRT_")):
            llvm.add_symbol(name, ctypes.cast(_RECORD, ctypes.c_void_p).value)
        else:
            llvm.add_symbol(name, ctypes.cast(getattr(process, name, None) or process.abort,
                                              ctypes.c_void_p).value)

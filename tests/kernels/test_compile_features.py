"""The CPU features csw compiles its kernels with (kernels/store.py:compile_features):
the full vector width where the CPU has AVX-512, the user's settings where given, and
the cache folder and the compile workers following them."""

import os

import pytest

from csw.kernels import compiler, store


class _Features:
    def __init__(self, text):
        self.text = text

    def flatten(self):
        return self.text


@pytest.fixture
def host(monkeypatch):
    """Set this host's feature string as llvmlite reports it; no NUMBA_CPU_* set."""
    import llvmlite.binding as llvm

    monkeypatch.delenv("NUMBA_CPU_FEATURES", raising=False)
    monkeypatch.delenv("NUMBA_CPU_NAME", raising=False)

    def set_features(text, name="rocketlake"):
        monkeypatch.setattr(llvm, "get_host_cpu_features", lambda: _Features(text))
        monkeypatch.setattr(llvm, "get_host_cpu_name", lambda: name)
    return set_features


@pytest.mark.parametrize("name", ["skylake-avx512", "icelake-server", "sapphirerapids"])
def test_an_intel_avx512_cpu_compiles_without_llvms_256_bit_preference(host, name):
    host("+avx2,+avx512f,+avx512bw,+sse4.2", name)
    assert store.compile_features() == "+avx2,+avx512f,+avx512bw,+sse4.2,-prefer-256-bit"


@pytest.mark.parametrize("name", ["znver4", "znver5"])
def test_amds_avx512_cpus_keep_numbas_features_which_llvm_vectorises_512_wide(host, name):
    host("+avx2,+avx512f,+avx512bw", name)
    assert store.compile_features() is None


@pytest.mark.parametrize("features", ["+avx2,+sse4.2", "+avx2,+avx512f,-avx512bw"])
def test_a_cpu_without_16_bit_avx512_lanes_keeps_numbas_features(host, features):
    host(features)
    assert store.compile_features() is None


@pytest.mark.parametrize("variable, value", [("NUMBA_CPU_FEATURES", "+avx2"),
                                             ("NUMBA_CPU_NAME", "znver4")])
def test_the_users_numba_cpu_settings_are_followed_as_they_are(host, monkeypatch, variable,
                                                               value):
    host("+avx2,+avx512f,+avx512bw")
    monkeypatch.setenv(variable, value)
    assert store.compile_features() is None


def test_a_named_host_cpu_is_the_host(host, monkeypatch):
    host("+avx512bw")
    monkeypatch.setenv("NUMBA_CPU_NAME", "host")
    assert store.compile_features() == "+avx512bw,-prefer-256-bit"


def test_the_cache_folder_follows_the_compile_features(monkeypatch):
    monkeypatch.setattr(store, "compile_features", lambda: None)
    monkeypatch.setattr(store, "_FINGERPRINT", {})
    narrow = store._fingerprint()
    monkeypatch.setattr(store, "compile_features", lambda: "+avx512bw,-prefer-256-bit")
    monkeypatch.setattr(store, "_FINGERPRINT", {})
    assert store._fingerprint() != narrow


@pytest.mark.parametrize("features", ["+avx512bw,-prefer-256-bit", None])
def test_one_missing_entry_goes_to_a_worker_only_with_features_of_csws_own(
        tmp_path, monkeypatch, features):
    """This process's Numba may have made its code generator with its own features
    (kernels/compiler.py): with csw's, even one entry is compiled by a worker; without,
    here (no worker to start)."""
    from csw.kernels.jit import build

    by_workers, here = [], []

    def workers(folder, missing, shares, progress=None):
        by_workers.extend(missing)
        return []  # as if every entry was stored
    monkeypatch.setattr(compiler, "_compile_in_processes", workers)
    monkeypatch.setattr(compiler, "_shares", lambda missing, n: [list(missing)])
    monkeypatch.setattr(build, "compile_entry", lambda k, v: here.append((k, v)) or ("s", 0))
    monkeypatch.setattr(compiler, "store", lambda *args: None)
    monkeypatch.setattr(compiler, "compile_features", lambda: features)
    entry = ("census", ("u8", 9))
    assert compiler.compile_missing(tmp_path, [entry], notice=False) == 1
    assert (by_workers, here) == (([entry], []) if features else ([], [entry]))


@pytest.mark.parametrize("features", ["+avx512bw,-prefer-256-bit", None])
def test_the_compile_workers_are_given_the_features(tmp_path, monkeypatch, features):
    """Each worker's environment names the features (a worker here writes it down and
    compiles nothing, so the entry is left to the caller); without any, the caller's
    own environment goes to them unchanged."""
    monkeypatch.setattr(compiler, "compile_features", lambda: features)
    monkeypatch.setenv("NUMBA_CPU_FEATURES", "")  # the caller's, empty: "not set"
    monkeypatch.setattr(compiler, "_WORKER", (
        "import os, sys; from pathlib import Path; "
        "Path(sys.argv[1], 'seen').write_text(os.environ['NUMBA_CPU_FEATURES'])"))
    entry = ("census", ("u8", 9))
    left = compiler._compile_in_processes(tmp_path, [entry], [[entry]])
    assert left == [entry]  # nothing stored: the caller would compile it
    assert (tmp_path / "seen").read_text() == (features or "")
    assert os.environ["NUMBA_CPU_FEATURES"] == ""  # the caller's environment unchanged

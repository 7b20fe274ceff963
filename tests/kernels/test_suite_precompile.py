"""tests/suite_kernels.py: `make test` compiles the kernel entries the suite loads before
its first test, on every core, and only when asked to (scripts/test.sh asks)."""

import pytest
import suite_kernels

from csw.kernels import native, store

# With the JIT off nothing is compiled, ahead or not.
compiles = pytest.mark.skipif(native.JIT_DISABLED, reason="NUMBA_DISABLE_JIT=1")


@pytest.fixture
def one_listed(tmp_path, monkeypatch):
    """A list of one cheap entry and an empty cache: the cache's folder."""
    listing = tmp_path / "suite_kernels.txt"
    listing.write_text("# a comment\npad-u8\n\n")
    monkeypatch.setattr(suite_kernels, "LIST", listing)
    monkeypatch.setenv("CSW_KERNEL_CACHE", str(tmp_path / "cache"))
    return store.cache_dir()


@compiles
@pytest.mark.slow  # a compile worker: a few seconds
def test_the_listed_entries_are_compiled_when_asked(one_listed, monkeypatch, capsys):
    monkeypatch.setenv("CSW_SUITE_PRECOMPILE", "1")
    suite_kernels.precompile()
    assert store.verified(one_listed, "pad-u8", {})
    assert "compiling 1 kernel entries" in capsys.readouterr().err
    suite_kernels.precompile()  # nothing left to compile: not a word
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("asked", [None, "0"])
def test_nothing_is_compiled_unless_asked(one_listed, monkeypatch, asked):
    if asked is None:
        monkeypatch.delenv("CSW_SUITE_PRECOMPILE", raising=False)
    else:
        monkeypatch.setenv("CSW_SUITE_PRECOMPILE", asked)
    suite_kernels.precompile()
    assert not one_listed.exists() or not list(one_listed.iterdir())


@compiles
def test_a_failed_compile_is_reported_and_left_to_the_tests(one_listed, monkeypatch, capsys):
    def broken(*args, **kwargs):
        raise RuntimeError("no compiler here")

    monkeypatch.setenv("CSW_SUITE_PRECOMPILE", "1")
    monkeypatch.setattr("csw.kernels.compiler.compile_missing", broken)
    suite_kernels.precompile()  # does not raise: the session goes on
    assert "compiling ahead failed (no compiler here)" in capsys.readouterr().err
    assert not store.verified(one_listed, "pad-u8", {})

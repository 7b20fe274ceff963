"""One csw match resolves its options exactly once (issue 26), counted with a spy on
every module that holds csw.config.params.resolve."""

import importlib
import sys

import pytest
from click.testing import CliRunner

from csw.config import params
from csw_cli.main import cli


@pytest.mark.parametrize("extra", [[], ["--memory-limit", "16MB"], ["--preset", "raw"]],
                         ids=["whole", "stripes", "raw"])
def test_one_match_resolves_its_options_once(pair_files, tmp_path, monkeypatch, extra):
    calls = []
    real = params.resolve

    def spy(**given):
        calls.append(given)
        return real(**given)

    for name in ("csw.matching.matcher", "csw.scale.files", "csw.scale.tiled.run",
                 "csw.scale.batch"):
        importlib.import_module(name)
    patched = [module for module in list(sys.modules.values())
               if getattr(module, "__name__", "").startswith(("csw", "csw_cli"))
               and getattr(module, "resolve", None) is real]
    for module in [params, *patched]:
        monkeypatch.setattr(module, "resolve", spy)
    assert patched  # csw.matching.matcher.resolved: the one place options become a Config
    result = CliRunner().invoke(cli, ["match", *map(str, pair_files), "-o",
                                      str(tmp_path / "d.pfm"), "--dmax", "8", *extra])
    assert result.exit_code == 0, result.output
    assert len(calls) == 1, calls


@pytest.mark.parametrize("options", [("--preset", "accurate", "--engine", "fast"),
                                     ("--preset", "accurate", "--engine", "window"), ()])
def test_one_whole_match_validates_the_contract_once(pair_files, tmp_path, monkeypatch,
                                                      options):
    """The kernels' rules are checked once, at the kernel's entry, on the real pixels:
    the set-up before it checks the pair with the contract's own functions, not a
    second validate."""
    from csw.kernels import contract, fast, sgm, window

    calls = []
    real = contract.validate

    def spy(*args, **kwargs):
        calls.append(kwargs)
        return real(*args, **kwargs)

    for module in (contract, fast, sgm, window):
        monkeypatch.setattr(module, "validate", spy)
    result = CliRunner().invoke(cli, ["match", *map(str, pair_files), "-o",
                                      str(tmp_path / "d.pfm"), "--dmax", "8", *options])
    assert result.exit_code == 0, result.output
    assert len(calls) == 1


def test_a_batch_resolves_its_options_once(pair_files, tmp_path, monkeypatch):
    """Every pair of a batch runs with the one Config the batch resolved."""
    calls = []
    real = params.resolve

    def spy(**given):
        calls.append(given)
        return real(**given)

    import csw.matching.matcher

    for module in (params, csw.matching.matcher):
        monkeypatch.setattr(module, "resolve", spy)
    left, right = pair_files
    lefts, rights = tmp_path / "L", tmp_path / "R"
    lefts.mkdir()
    rights.mkdir()
    for name in ("a", "b", "c"):
        (lefts / f"{name}.png").write_bytes(left.read_bytes())
        (rights / f"{name}.png").write_bytes(right.read_bytes())
    result = CliRunner().invoke(cli, ["match", str(lefts), str(rights), "-O",
                                      str(tmp_path / "out"), "--dmax", "8"])
    assert result.exit_code == 0, result.output
    assert len(calls) == 1, calls
    assert sorted(p.name for p in (tmp_path / "out").glob("*.pfm")) == \
        ["a.pfm", "b.pfm", "c.pfm"]

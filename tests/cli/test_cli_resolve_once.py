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

    for name in ("csw.matching.matcher", "csw.matching.files", "csw.scale.tiled.run",
                 "csw.scale.batch"):
        importlib.import_module(name)
    patched = [module for module in list(sys.modules.values())
               if getattr(module, "__name__", "").startswith(("csw", "csw_cli"))
               and getattr(module, "resolve", None) is real]
    for module in [params, *patched]:
        monkeypatch.setattr(module, "resolve", spy)
    assert len(patched) >= 4
    result = CliRunner().invoke(cli, ["match", *map(str, pair_files), "-o",
                                      str(tmp_path / "d.pfm"), "--dmax", "8", *extra])
    assert result.exit_code == 0, result.output
    assert len(calls) == 1, calls

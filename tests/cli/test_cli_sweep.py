"""csw sweep: the trade-off table, checked against the kernels."""

import json

import pytest
from click.testing import CliRunner

from csw import kernels
from csw.config.tau import paper_tau
from csw.data import datasets as D
from csw.eval.scoring import bad1_all
from csw_cli.main import cli


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.mark.slow
def test_sweep_rows_match_the_kernels(tmp_path):
    result = invoke("sweep", "-d", "synthetic", "--dmax", 24, "--window", 5, "--tau-range",
                    "0.5x,200,none", "--csw-margin", "8,20", "--format", "json")
    assert result.exit_code == 0, result.output
    rows = json.loads(result.stdout)
    # plain, 3 literal taus, 2 margins x 3 taus
    assert [r["rule"] for r in rows] == [None] + ["literal"] * 3 + ["unique"] * 6
    pair = D.load("synthetic")
    plain = kernels.match(pair.left, pair.right, engine="fast", window=5, dmin=0, dmax=24,
                          cost="sad")
    auto = paper_tau(plain.min_cost)
    assert rows[1]["tau"] == pytest.approx(0.5 * auto) and rows[2]["tau"] == 200
    for row in rows[1:]:
        tau = float("inf") if row["tau_label"] == "none" else row["tau"]
        got = kernels.match(pair.left, pair.right, window=5, dmax=24, csw=True, tau=tau,
                            rule=row["rule"], csw_margin=row["csw_margin"], engine="fast",
                            dmin=0, cost="sad")
        assert row["work_saved"] == pytest.approx(100 * got.work_saved)
        assert row["error_rate"] == pytest.approx(bad1_all(got.disparity, pair))
        assert row["delta"] == pytest.approx(row["error_rate"] - rows[0]["error_rate"])


@pytest.mark.slow
def test_sweep_plot(tmp_path):
    pytest.importorskip("matplotlib")
    result = invoke("sweep", "-d", "synthetic", "--dmax", 16, "--window", 3, "--tau-range",
                    "1x,none", "--plot", tmp_path / "s.png")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "s.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("args, message", [
    (["--tau-range", "1:abc:2"], "a:b:step"),
    (["--tau-range", "5:1:0"], "a:b:step"),
    (["--csw-margin", "x"], "whole percentages"),
    (["--csw-rule", "greedy"], "literal, unique"),
    (["--plot", "p.jpg"], "unknown extension"),
])
def test_sweep_bad_input(args, message):
    result = invoke("sweep", "-d", "synthetic", *args)
    assert result.exit_code == 2 and message in result.output

"""csw bench, score, datasets and hist through CliRunner."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from csw import kernels
from csw.config.params import csw_margin_for
from csw.config.tau import paper_tau
from csw.data import datasets as D
from csw.eval.scoring import score
from csw_cli.main import cli

BENCH_KEYS = {"dataset", "size", "cost", "csw", "tau", "window", "dmin", "dmax",
              "error_rate", "bad", "invalid", "time_s", "time_reduced", "work_saved",
              "threads"}


def invoke(*args):
    result = CliRunner().invoke(cli, [str(a) for a in args])
    return result


@pytest.fixture(scope="module")
def synthetic_bench():
    result = invoke("bench", "-d", "synthetic", "--cost", "sad,shd", "--repeat", 2,
                    "--dmax", 40, "--window", 7, "--format", "json")
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


@pytest.mark.slow
def test_bench_json_schema(synthetic_bench):
    assert len(synthetic_bench) == 12  # 2 costs x 2 engines x (plain, literal, unique)
    assert [r["engine"] for r in synthetic_bench[:6]] == ["window"] * 3 + ["fast"] * 3
    assert [r["rule"] for r in synthetic_bench[:3]] == [None, "literal", "unique"]
    for row in synthetic_bench:
        assert BENCH_KEYS <= set(row)
        assert set(row["bad"]) == {"0.5", "1", "2", "4"}
        assert isinstance(row["csw"], bool) and row["threads"] == 1
        assert row["time_s"] > 0 and row["window"] == 7 and row["dmax"] == 40
        assert row["size"] == "450x375"
        if row["rule"] == "literal":
            assert isinstance(row["tau"], float)
        if row["rule"] == "unique":
            assert row["tau"] is None and row["tau_source"] == "none"  # no threshold
            assert row["csw_margin"] == 12
        if row["csw"]:
            assert row["time_reduced"] is not None and 0 <= row["work_saved"] <= 100
        else:
            assert row["tau"] is None and row["work_saved"] is None
    assert [r["csw"] for r in synthetic_bench] == [False, True, True] * 4


@pytest.mark.slow
def test_bench_rows_equal_the_kernels_own_output(synthetic_bench):
    pair = D.load("synthetic")
    for row in synthetic_bench:
        plain = kernels.match(pair.left, pair.right, engine="window", window=7, dmin=0,
                              dmax=40, cost=row["cost"])
        tau = paper_tau(plain.min_cost)  # --tau defaults to auto: the paper's rule
        result = plain
        if row["rule"] == "literal":
            assert row["tau"] == pytest.approx(tau)
            result = kernels.match(pair.left, pair.right, window=7, dmax=40,
                                   cost=row["cost"], csw=True, tau=tau, engine="window", dmin=0)
        elif row["rule"] == "unique":  # no tau by default, per-cost margin
            result = kernels.match(pair.left, pair.right, window=7, dmax=40,
                                   cost=row["cost"], csw=True, tau=float("inf"),
                                   rule="unique", csw_margin=csw_margin_for(row["cost"]),
                                   engine="window", dmin=0)
        if row["csw"]:
            assert row["work_saved"] == pytest.approx(100 * result.work_saved)
        metrics = score(result.disparity, pair.gt, pair.masks)
        assert row["error_rate"] == pytest.approx(metrics["all"]["bad"][1.0])
        assert row["bad"]["4"] == pytest.approx(metrics["all"]["bad"][4.0])
        assert row["invalid"] == pytest.approx(metrics["all"]["invalid"])


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["table", "github", "latex", "csv"])
def test_bench_human_formats(fmt):
    result = invoke("bench", "-d", "synthetic", "--repeat", 1, "--dmax", 16, "--window", 3,
                    "--tau", 300, "--format", fmt, "--csw-rule", "literal")
    assert result.exit_code == 0, result.output
    assert "SAD + CSW" in result.stdout and "bench: synthetic" in result.stderr
    if fmt == "csv":
        lines = result.stdout.strip().splitlines()
        assert lines[0].startswith("Image,Algorithm,Engine") and len(lines) == 5


@pytest.mark.slow
@pytest.mark.data
def test_bench_paper_preset_on_tsukuba(data_dir):
    result = invoke("bench", "-d", "tsukuba", "--preset", "paper", "--cost", "sad,ssd,shd",
                    "--engine", "window", "--csw-rule", "literal", "--repeat", 1,
                    "--format", "json", "--data-dir", data_dir)
    assert result.exit_code == 0, result.output
    rows = json.loads(result.stdout)
    assert [(r["cost"], r["csw"]) for r in rows] == [
        ("sad", False), ("sad", True), ("ssd", False), ("ssd", True), ("shd", False),
        ("shd", True)]
    assert [r["tau"] for r in rows if r["csw"]] == [410, 360, 32]
    assert all(r["dmax"] == 16 and r["window"] == 9 for r in rows)
    assert rows[0]["paper_error_rate"] == 11.45


def test_bench_bad_input():
    assert invoke("bench", "-d", "nowhere").exit_code == 2
    assert invoke("bench", "-d", "synthetic", "--engine", "gpu").exit_code == 2
    assert invoke("bench", "-d", "synthetic", "--csw-rule", "greedy").exit_code == 2
    assert invoke("bench", "-d", "synthetic", "--cost", "ncc").exit_code == 2
    result = invoke("bench", "-d", "synthetic", "--preset", "paper", "--window", 5)
    assert result.exit_code == 2 and "9x9" in result.output
    result = invoke("bench", "-d", "synthetic", "--dmax", 500)
    assert result.exit_code == 2 and "less than the image width" in result.output


def test_datasets_lists_registry_as_json(tmp_path):
    result = invoke("datasets", "--format", "json", "--data-dir", tmp_path)
    rows = json.loads(result.stdout)
    assert [r["name"] for r in rows] == D.names()
    assert rows[0]["local"] == "yes" and all(r["local"] == "no" for r in rows[1:])


def test_score_command_by_hand(tmp_path):
    from csw.io import write_disparity, write_png

    gt = np.full((4, 5), 40, np.uint8)  # scale 4 -> 10 px everywhere
    gt[0, 0] = 0  # unknown
    write_png(tmp_path / "gt.png", gt)
    disp = np.full((4, 5), 10, np.int32)
    disp[1, 1], disp[2, 2] = 12, -1  # one bad, one invalid
    write_disparity(tmp_path / "d.pfm", disp)
    result = invoke("score", tmp_path / "d.pfm", "--gt", tmp_path / "gt.png", "--gt-scale", 4,
                    "--format", "json")
    assert result.exit_code == 0, result.output
    (row,) = json.loads(result.stdout)
    assert row["pixels"] == 19
    assert row["bad_1"] == pytest.approx(100 * 2 / 19)
    assert row["invalid"] == pytest.approx(100 / 19)


def test_score_bad_input(tmp_path):
    assert invoke("score", tmp_path / "none.pfm", "--gt", tmp_path / "x.png").exit_code == 2
    assert invoke("score", tmp_path / "none.pfm").exit_code == 2


def test_hist_shows_the_rule_tau():
    result = invoke("hist", "-d", "synthetic", "--dmax", 16, "--window", 3)
    assert result.exit_code == 0, result.output
    pair = D.load("synthetic")
    plain = kernels.match(pair.left, pair.right, engine="fast", window=3, dmin=0, dmax=16,
                          cost="sad")
    assert f"tau = {paper_tau(plain.min_cost):g}" in result.stdout
    assert len(result.stdout.strip().splitlines()) == 2 + 2 + 10


@pytest.mark.slow
def test_hist_plot(tmp_path):
    pytest.importorskip("matplotlib")
    result = invoke("hist", "-d", "synthetic", "--dmax", 16, "--window", 3, "--plot",
                    tmp_path / "h.png")
    assert result.exit_code == 0 and (tmp_path / "h.png").stat().st_size > 1000


def test_score_options_that_conflict_fail_before_any_download(tmp_path, monkeypatch):
    monkeypatch.setenv("CSW_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("CSW_DATA_MIRROR", "http://127.0.0.1:9/")
    (tmp_path / "d.npy").write_bytes(b"")
    (tmp_path / "empty").mkdir()
    result = invoke("score", tmp_path / "d.npy", "--dataset", "tsukuba", "--gt-scale", 3,
                    "--data-dir", tmp_path / "empty")
    assert result.exit_code == 2 and "--gt-scale and --mask go with --gt" in result.output
    assert not (tmp_path / "cache").exists()


def test_bench_scores_kitti_with_d1_and_middlebury_2014_with_bad_2(tmp_path):
    """Folders as published, built on the fly; the sgm preset gets plain rows only (CSW
    can't skip costs that semi-global matching needs), on its own 3x3 window."""
    from layout_fixtures import kitti, middlebury2014

    import csw
    from csw.eval.scoring import summary

    kitti(tmp_path / "kitti" / "training", frames=1)
    middlebury2014(tmp_path / "mb" / "Scene", seed=3)
    result = invoke("bench", "--dataset-dir", tmp_path / "kitti", "--dataset-dir",
                    tmp_path / "mb", "--preset", "sgm", "--dmax", 31, "--repeat", 1,
                    "--format", "json")
    assert result.exit_code == 0, result.output
    rows = json.loads(result.stdout)
    assert [(r["dataset"], r["metric"], r["csw"], r["engine"], r["window"]) for r in rows
            if r.get("metric")] == [("000000_10", "D1", False, "fast", 3),
                                     ("Scene", "bad-2", False, "fast", 3)]
    assert rows[0]["algorithm"] == "CENSUS + SGM"
    for row, scene in zip(rows, [*csw.scan_folder(tmp_path / "kitti"),
                                 *csw.scan_folder(tmp_path / "mb")], strict=False):
        pair = scene.load()
        disp = csw.match(pair.left, pair.right, preset="sgm", dmax=31, threads=1).disparity
        want = summary(disp, pair.gt, pair.masks["all"], row["metric"])
        assert row["density"] == pytest.approx(want["density"])
        assert row["bad_valid"] == pytest.approx(want["bad_valid"])
        assert row["filled_bad"] == pytest.approx(want["filled"])
    text = invoke("bench", "--dataset-dir", tmp_path / "kitti", "--preset", "sgm", "--dmax",
                  31, "--repeat", 1)
    assert text.exit_code == 0, text.output
    assert "plain rows only" in text.stdout and "D1" in text.stdout
    window = invoke("bench", "--dataset-dir", tmp_path / "mb", "--preset", "sgm",
                    "--engine", "window", "--repeat", 1)
    assert window.exit_code != 0 and "computes its own costs" in window.output

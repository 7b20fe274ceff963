"""The commands on benchmark folders, on many pairs, and the bench fixes of the library
issue; each compared with the library call the command makes."""

import json
import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner
from layout_fixtures import kitti, middlebury2014

import csw
from csw.io import write_png
from csw_cli.main import cli


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def test_bench_a_kitti_folder_per_scene_and_total(tmp_path):
    kitti(tmp_path / "training", frames=2)
    result = invoke("bench", "--dataset-dir", tmp_path, "--engine", "fast", "--csw-rule",
                    "unique", "--repeat", 1, "--window", 5, "--format", "json")
    assert result.exit_code == 0, result.output
    rows = json.loads(result.stdout)
    assert [r["dataset"] for r in rows] == ["000000_10"] * 2 + ["000001_10"] * 2 + \
        ["total (2 scenes)"] * 2
    first = next(iter(csw.scan_folder(tmp_path))).load()
    assert rows[0]["dmax"] == first.dmax == 95
    want = csw.match(first.left, first.right, window=5, dmax=95, preset="raw")
    bad1 = csw.score(want.disparity, first.gt, first.masks)["all"]["bad"][1.0]
    assert rows[0]["error_rate"] == pytest.approx(bad1)
    pooled = [r for r in rows[:4] if not r["csw"]]
    pixels = [r["regions"]["all"]["pixels"] for r in pooled]
    expect = sum(r["error_rate"] * n for r, n in zip(pooled, pixels, strict=True)) / sum(pixels)
    assert rows[4]["error_rate"] == pytest.approx(expect)


def test_score_a_folder_of_maps_against_middlebury_scenes(tmp_path):
    middlebury2014(tmp_path / "data" / "A", seed=1)
    middlebury2014(tmp_path / "data" / "B", seed=2)
    (tmp_path / "maps").mkdir()
    result = invoke("match", tmp_path / "data" / "A" / "im0.png",
                    tmp_path / "data" / "A" / "im1.png", "-o", tmp_path / "maps" / "A.pfm",
                    "--dmax", 23)
    assert result.exit_code == 0, result.output
    out = invoke("score", tmp_path / "maps", "--dataset-dir", tmp_path / "data", "--format",
                 "json")
    assert out.exit_code == 0, out.output
    rows = json.loads(out.stdout)
    assert "no map for 1 scene(s): B" in out.stderr
    assert [(r["scene"], r["region"]) for r in rows] == [
        ("A", "all"), ("A", "nonocc"), ("total (1 scenes)", "all"),
        ("total (1 scenes)", "nonocc")]
    single = invoke("score", tmp_path / "maps" / "A.pfm", "--dataset-dir", tmp_path / "data",
                    "--scene", "A", "--format", "json")
    assert json.loads(single.stdout)[0]["bad_1"] == rows[0]["bad_1"]
    several = invoke("score", tmp_path / "maps" / "A.pfm", "--dataset-dir", tmp_path / "data")
    assert several.exit_code == 2 and "choose one with --scene" in several.output


def test_match_folders_with_progress_summary_and_exit_code(tmp_path):
    for name in ("l", "r", "o"):
        (tmp_path / name).mkdir()
    left, right, _, _ = csw.synthetic_pair(64, 40, dmax=12, seed=3)
    write_png(tmp_path / "l" / "good.png", left)
    write_png(tmp_path / "r" / "good.png", right)
    (tmp_path / "l" / "bad.png").write_bytes(b"junk")
    (tmp_path / "r" / "bad.png").write_bytes(b"junk")
    result = invoke("match", tmp_path / "l", tmp_path / "r", "-O", tmp_path / "o",
                    "--dmax", 12)
    assert result.exit_code == 1
    assert "1 matched, 0 skipped" in result.stderr and "failed: bad:" in result.stderr
    assert result.stdout == ""
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["counts"] == {"ok": 1, "skipped": 0, "failed": 1}
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == ["good.pfm", "summary.json"]


@pytest.mark.parametrize("args, message", [
    (["{l}", "{r}"], "needs --output-dir"),
    (["{l}", "{r}", "-O", "{l}", "-o", "x.pfm"], "are for one pair"),
    (["--manifest", "{m}", "-O", "{l}", "{l}", "{r}"], "not both"),
    (["{l}", "{m}", "-O", "{l}"], "RIGHT must be a folder"),
])
def test_batch_usage_errors(tmp_path, args, message):
    for name in ("l", "r"):
        (tmp_path / name).mkdir()
    (tmp_path / "m.csv").write_text("a,b\n")
    paths = {"l": tmp_path / "l", "r": tmp_path / "r", "m": tmp_path / "m.csv"}
    result = invoke("match", *[a.format(**paths) for a in args])
    assert result.exit_code == 2 and message in result.output


@pytest.mark.slow
def test_bench_tau_words():
    """--tau none reached float("none"), and 'paper' was rejected though advertised."""
    none = invoke("bench", "-d", "synthetic", "--tau", "none", "--engine", "fast",
                  "--csw-rule", "literal", "--repeat", 1, "--format", "json")
    assert none.exit_code == 0, none.output
    assert json.loads(none.stdout)[1]["tau"] is None  # inf has no JSON form: null
    paper = invoke("bench", "-d", "synthetic", "--tau", "paper", "--engine", "fast",
                   "--csw-rule", "literal", "--repeat", 1, "--format", "json")
    assert paper.exit_code == 0, paper.output
    assert json.loads(paper.stdout)[1]["tau_source"] == "auto (no paper value)"


@pytest.mark.slow
@pytest.mark.data
def test_preset_paper_prints_the_six_tsukuba_rows(data_dir):
    result = invoke("bench", "-d", "tsukuba", "--preset", "paper", "--repeat", 1,
                    "--format", "json", "--data-dir", data_dir)
    assert result.exit_code == 0, result.output
    rows = json.loads(result.stdout)
    assert [(r["algorithm"], r["tau"]) for r in rows] == [
        ("SAD", None), ("SAD + CSW", 410), ("SSD", None), ("SSD + CSW", 360),
        ("SHD", None), ("SHD + CSW", 32)]
    assert {r["engine"] for r in rows} == {"window"} and rows[0]["dmax"] == 16
    assert rows[0]["error_rate"] == pytest.approx(11.02, abs=0.01)  # reports/table2.md


@pytest.mark.slow
def test_wheel_installs_no_top_level_kernels(tmp_path):
    """An unrelated PyPI package is called 'kernels': the wheel must not install one."""
    import zipfile
    from pathlib import Path

    root = Path(csw.__file__).parent.parent
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w",
                    str(tmp_path), str(root)], check=True, capture_output=True, timeout=600)
    (wheel,) = tmp_path.glob("*.whl")
    assert wheel.name.startswith("csw_stereo-")  # the distribution: PyPI's csw is another
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names if not n.split("/")[0].endswith(".dist-info")}
    assert tops == {"csw", "csw_cli"}
    assert "csw/kernels/fast.py" in names and "csw/kernels/__init__.py" in names
    assert np.all([not n.startswith("kernels/") for n in names])


def test_a_batch_pair_has_a_preview_and_confidence_and_the_single_pair_s_bytes(pair_files,
                                                                               tmp_path):
    """A pair of a batch writes what the same pair alone writes, byte for byte, and can
    have the single pair's companions: the colour preview and the confidence map."""
    from click.testing import CliRunner

    from csw_cli.main import cli

    left, right = pair_files
    lefts, rights = tmp_path / "L", tmp_path / "R"
    lefts.mkdir()
    rights.mkdir()
    (lefts / "p.png").write_bytes(left.read_bytes())
    (rights / "p.png").write_bytes(right.read_bytes())
    out = tmp_path / "out"
    batch = CliRunner().invoke(cli, ["match", str(lefts), str(rights), "-O", str(out),
                                     "--dmax", "8", "--preview", ".png",
                                     "--confidence", ".pfm"])
    assert batch.exit_code == 0, batch.output
    single = CliRunner().invoke(cli, ["match", str(left), str(right), "-o",
                                      str(tmp_path / "d.pfm"), "--dmax", "8", "--preview",
                                      str(tmp_path / "v.png"), "--confidence",
                                      str(tmp_path / "c.pfm")])
    assert single.exit_code == 0, single.output
    for batch_name, single_name in (("p.pfm", "d.pfm"), ("p.preview.png", "v.png"),
                                    ("p.confidence.pfm", "c.pfm")):
        assert (out / batch_name).read_bytes() == (tmp_path / single_name).read_bytes()
    refused = CliRunner().invoke(cli, ["match", str(lefts), str(rights), "-O", str(out),
                                       "--dmax", "8", "--preview", ".pfm", "--overwrite"])
    assert refused.exit_code == 2 and "format, one of .png" in refused.output

"""csw depth, csw cloud, and csw match writing depth and clouds: from a calibrated pair
to 3-D, and a disparity range found for you."""

import json

import numpy as np
import pytest
from click.testing import CliRunner
from layout_fixtures import middlebury2014

from csw.data.synth import BASELINE_MM, render
from csw.io import read_disparity, write_float_pfm
from csw_cli.main import cli

plyfile = pytest.importorskip("plyfile")


def invoke(*args):
    result = CliRunner().invoke(cli, [str(a) for a in args])
    return result


@pytest.fixture
def scene(tmp_path):
    """A synthetic scene folder as csw synth writes it (with its calib.txt)."""
    result = invoke("synth", tmp_path / "s", "--size", "120x80", "--dmax", "24")
    assert result.exit_code == 0, result.output
    return tmp_path / "s"


def test_match_writes_depth_and_a_cloud_in_one_run(scene, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    result = invoke("match", scene / "left.png", scene / "right.png", "-o", out / "d.pfm",
                    "--depth", out / "z.pfm", "--cloud", out / "c.ply", "--depth-preview",
                    out / "z.png", "--units", "m")
    assert result.exit_code == 0, result.output
    # The calib.txt beside left.png was found, and its ndisp set the range.
    assert " d 0..24 " in result.output and "range from ndisp of" in result.output
    assert "calibration" in result.output
    disp = read_disparity(out / "d.pfm")
    depth = read_disparity(out / "z.pfm")
    valid = np.isfinite(disp) & (disp > 0)
    np.testing.assert_allclose(depth[valid], 120 * BASELINE_MM / 1000 / disp[valid],
                               rtol=1e-6)
    vertices = plyfile.PlyData.read(str(out / "c.ply"))["vertex"]
    assert vertices.count == valid.sum()
    assert (out / "z.png").stat().st_size > 0


def test_csw_depth_and_csw_cloud(scene, tmp_path):
    left, right, gt, _ = render(120, 80, dmax=24, seed=0)
    write_float_pfm(tmp_path / "gt.pfm", gt)
    result = invoke("depth", tmp_path / "gt.pfm", "--calib", scene / "calib.txt", "-o",
                    tmp_path / "z.npy", "--preview", tmp_path / "z.png")
    assert result.exit_code == 0, result.output
    z = np.load(tmp_path / "z.npy")
    np.testing.assert_allclose(z, 120 * BASELINE_MM / gt, rtol=1e-6)
    by_hand = invoke("cloud", tmp_path / "gt.pfm", "--focal", 120, "--baseline", 0.1,
                     "--image", scene / "left.png", "--max-depth", 1.0, "-o",
                     tmp_path / "c.ply")
    assert by_hand.exit_code == 0, by_hand.output
    vertices = plyfile.PlyData.read(str(tmp_path / "c.ply"))["vertex"]
    assert 0 < vertices.count == (120 * 0.1 / gt <= 1.0).sum() < gt.size
    assert max(vertices["z"]) <= 1.0


@pytest.mark.parametrize("calib, message", [
    ("cam0=[1 0 2; 0 1 3; 0 0 1]\nwidth=4\n", "without baseline"),
    ("cam0=[100 0 2; 0 100 3; 0 0 1]\nbaseline=0\ndoffs=0\n", "baseline is 0"),
    ("%YAML:1.0\nQ: !!opencv-matrix\n   data: [" + ", ".join(["0"] * 16) + "]\n",
     "not invertible"),
    ("cam0=[100 0 2; 0 100 3; 0 0 1]\nbaseline=5\ndoffs=0\nwidth=999\nheight=80\n",
     "999x80 images"),
])
def test_a_bad_calibration_is_one_line_and_writes_nothing(scene, tmp_path, calib, message):
    (tmp_path / "bad.txt").write_text(calib)
    out = tmp_path / "out"
    out.mkdir()
    for args in (["match", scene / "left.png", scene / "right.png", "-o", out / "d.pfm",
                  "--dmax", 24, "--calib", tmp_path / "bad.txt", "--depth", out / "z.pfm"],
                 ["depth", scene / "gt.pfm", "--calib", tmp_path / "bad.txt", "-o",
                  out / "z.pfm"]):
        result = invoke(*args)
        assert result.exit_code == 2 and message in result.output, result.output
        assert list(out.iterdir()) == []


def test_depth_without_a_calibration_says_so(tmp_path):
    left, right, _, _ = render(64, 40, dmax=8, seed=1)
    from csw.io import write_png

    write_png(tmp_path / "l.png", left)
    write_png(tmp_path / "r.png", right)
    result = invoke("match", tmp_path / "l.png", tmp_path / "r.png", "-o", tmp_path / "d.pfm",
                    "--dmax", 8, "--depth", tmp_path / "z.pfm")
    assert result.exit_code == 2 and "needs the pair's calibration" in result.output
    assert not (tmp_path / "d.pfm").exists()


def test_many_pairs_write_their_depth_and_cloud_beside_their_maps(tmp_path):
    for i in range(2):
        middlebury2014(tmp_path / f"scene{i}", seed=i)
    (tmp_path / "m.csv").write_text("".join(f"scene{i}/im0.png,scene{i}/im1.png,s{i}\n"
                                            for i in range(2)))
    result = invoke("match", "--manifest", tmp_path / "m.csv", "-O", tmp_path / "out",
                    "--depth", ".pfm", "--cloud", ".ply")
    assert result.exit_code == 0, result.output
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert names == ["s0.depth.pfm", "s0.pfm", "s0.ply", "s1.depth.pfm", "s1.pfm", "s1.ply",
                     "summary.json"]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    entry = summary["pairs"][0]
    assert entry["range"] == [0, 23] and "ndisp" in entry["range_source"]
    assert entry["calibration"]["baseline"] == 100
    bad = invoke("match", "--manifest", tmp_path / "m.csv", "-O", tmp_path / "o2",
                 "--depth", ".jpg")
    assert bad.exit_code == 2 and "format" in bad.output


def test_dmax_auto_on_a_middlebury_2014_folder(tmp_path):
    left, right, gt = middlebury2014(tmp_path / "scene", seed=3, size=(160, 100))
    (tmp_path / "scene" / "calib.txt").unlink()  # no ndisp to go by
    result = invoke("match", tmp_path / "scene" / "im0.png", tmp_path / "scene" / "im1.png",
                    "-o", tmp_path / "d.pfm", "--dmax", "auto")
    assert result.exit_code == 0, result.output
    assert "range found from the pair" in result.output
    top = int(result.output.split(" d 0..")[1].split()[0])
    assert top >= np.nanpercentile(gt, 99)


def test_a_negative_dmin_on_the_command_line(scene, tmp_path):
    result = invoke("match", scene / "left.png", scene / "right.png", "-o", tmp_path / "d.pfm",
                    "--dmin", -4, "--dmax", 24, "--preset", "raw")
    assert result.exit_code == 0 and " d -4..24 " in result.output, result.output


def test_a_bad_image_for_the_cloud_is_named_as_the_image(scene, tmp_path):
    (tmp_path / "broken.png").write_bytes((scene / "left.png").read_bytes()[:200])
    result = invoke("cloud", scene / "gt.pfm", "--focal", 120, "--baseline", 0.1,
                    "--image", tmp_path / "broken.png", "-o", tmp_path / "c.ply")
    assert result.exit_code == 2
    error = result.output.splitlines()[-1]
    assert "Invalid value for --image" in error, result.output
    assert not (tmp_path / "c.ply").exists()

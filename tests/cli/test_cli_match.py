"""csw match and csw synth through Click's CliRunner, and once as a real process."""

import os
import shutil
import subprocess
import sys

import imageio.v3 as iio
import numpy as np
import pytest
from click.testing import CliRunner

import csw
from csw.io import read_disparity, read_image, read_pfm, write_png
from csw.io.pictures import disparity_picture
from csw_cli.main import cli


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def files_in(folder):
    return sorted(p.name for p in folder.iterdir())


def test_match_writes_pfm_equal_to_kernel(pair_files, tmp_path, small_scene):
    left, right = pair_files
    out = tmp_path / "d.pfm"
    result = run("match", left, right, "-o", out, "--dmax", 16, "--preset", "accurate",
                 "--csw", "--tau", 500)
    assert result.exit_code == 0, result.output
    expected = csw.match(small_scene[0], small_scene[1], dmax=16, preset="accurate",
                         csw=True, tau=500)
    got = read_pfm(out)
    want = np.where(expected.disparity >= 0, expected.disparity, np.inf).astype(np.float32)
    np.testing.assert_array_equal(got, want)
    assert "CSW literal tau=500" in result.stderr and "evaluated" in result.stderr
    assert result.stdout == ""


@pytest.mark.parametrize("options, described", [
    ((), "CENSUS (sparse 9x9 codes) 3x3 SGM 4 paths P1 72 P2 288, preset sgm"),
    (("--preset", "accurate"), "CENSUS (sparse 9x9 codes) 9x9 plain, preset accurate"),
    (("--preset", "accurate", "--census-window", 5, "--census-pattern", "dense",
      "--window", 7), "CENSUS (dense 5x5 codes) 7x7 plain, preset accurate"),
    (("--preset", "raw"), "SAD 9x9 plain, preset raw")])
def test_the_summary_names_the_census_codes_apart_from_the_window(pair_files, tmp_path,
                                                                   options, described):
    left, right = pair_files
    result = run("match", left, right, "-o", tmp_path / "d.pfm", "--dmax", 16, *options)
    assert result.exit_code == 0, result.output
    assert described in result.stderr


@pytest.mark.parametrize("dmax, narrowed", [(16, False), (63, False), (64, True)])
def test_the_summary_says_when_the_range_is_narrowed(pair_files, tmp_path, dmax, narrowed):
    """The sgm preset narrows only a range wider than its 64 slots."""
    left, right = pair_files
    result = run("match", left, right, "-o", tmp_path / "d.pfm", "--dmax", dmax)
    assert result.exit_code == 0, result.output
    assert ("64 disparities a pixel after a half-size pass" in result.stderr) == narrowed


def test_pfm_is_bottom_to_top_little_endian(tmp_path):
    from csw.io import write_disparity

    disp = np.array([[1, 2, 3], [4, -1, 6]], np.int32)
    write_disparity(tmp_path / "x.pfm", disp)
    raw = (tmp_path / "x.pfm").read_bytes()
    assert raw.startswith(b"Pf\n3 2\n-1\n")
    body = np.frombuffer(raw[len(b"Pf\n3 2\n-1\n"):], "<f4").reshape(2, 3)
    np.testing.assert_array_equal(body[0], [4, np.inf, 6])  # bottom row first
    np.testing.assert_array_equal(body[1], [1, 2, 3])


def test_png_and_npy_outputs(pair_files, tmp_path, small_scene):
    left, right = pair_files
    assert run("match", left, right, "-o", tmp_path / "d.png", "--dmax", 16).exit_code == 0
    assert run("match", left, right, "-o", tmp_path / "d.npy", "--dmax", 16).exit_code == 0
    expected = csw.match(small_scene[0], small_scene[1], dmax=16).disparity
    png = read_image(tmp_path / "d.png")
    assert png.dtype == np.uint16  # KITTI's: d x 256, rounded; 0 where invalid
    np.testing.assert_array_equal(png, np.where(expected >= 0, np.rint(expected * 256), 0))
    npy = np.load(tmp_path / "d.npy")
    np.testing.assert_array_equal(npy, np.nan_to_num(expected, nan=np.inf))


def test_preview_cost_map_and_tau_auto(pair_files, tmp_path):
    left, right = pair_files
    result = run("match", left, right, "-o", tmp_path / "d.pfm", "--dmax", 16, "--preset",
                 "accurate", "--csw", "--preview", tmp_path / "v.png", "--cost-map",
                 tmp_path / "m.pfm")
    assert result.exit_code == 0, result.output
    assert "(auto)" in result.stderr
    # The map in colour over its colour bar.
    np.testing.assert_array_equal(iio.imread(tmp_path / "v.png"), disparity_picture(
        read_pfm(tmp_path / "d.pfm"), 0, 16))
    m = read_pfm(tmp_path / "m.pfm")
    assert np.isfinite(m).all() and m.min() >= 0


def test_color_input_is_converted_like_pillow(tmp_path):
    rgb = np.random.default_rng(0).integers(0, 256, (10, 12, 3), dtype=np.uint8)
    write_png(tmp_path / "c.png", rgb)
    gray = read_image(tmp_path / "c.png")
    r, g, b = (rgb[..., i].astype(np.int64) for i in range(3))
    # Pillow's convert("L") integer formula (ITU-R 601-2 luma).
    expected = (r * 19595 + g * 38470 + b * 7471 + 0x8000) >> 16
    np.testing.assert_array_equal(gray, expected)


def test_palette_png_reads_values_not_indices(tmp_path):
    from PIL import Image

    img = Image.new("P", (4, 2))
    img.putpalette([0, 0, 0, 200, 200, 200] + [0] * 762)
    img.putdata([0, 1, 1, 0, 1, 0, 0, 1])
    img.save(tmp_path / "p.png")
    assert set(np.unique(read_image(tmp_path / "p.png"))) == {0, 200}


BAD_INPUTS = [
    (["missing.png", "{right}"], 2, "no such file"),
    (["{left}", "{junk}"], 2, "not a readable image"),
    (["{left}", "{small}"], 2, "differ in size"),
    (["{left}", "{right}", "--window", "4"], 2, "odd"),
    (["{left}", "{right}", "--window", "0"], 2, "odd"),
    (["{left}", "{right}", "--window", "101"], 2, "larger than the image"),
    (["{left}", "{right}", "--dmin", "5", "--dmax", "2"], 2, "must not exceed"),
    (["{left}", "{right}", "--dmin", "-96", "--dmax", "4"], 2, "minus the image width"),
    (["{left}", "{right}", "--dmin", "-2", "-o", "{tmp}/d.png"], 2, "negative"),
    (["{left}", "{right}", "--dmax", "96"], 2, "less than the image width"),
    (["{left}", "{right}", "-o", "{tmp}/d.jpg"], 2, "unknown extension"),
    (["{left}", "{right}", "-o", "{tmp}/nowhere/d.pfm"], 2, "does not exist"),
    (["{left}", "{right}", "-o", "{junk}/d.pfm"], 2, "does not exist"),
    (["{left}", "{right}", "--tau", "many", "--csw"], 2, "not a number"),
    (["{left}", "{right}", "--tau", "nan", "--csw"], 2, "NaN"),
    (["{left}", "{right}", "--csw-margin", "-3", "--csw"], 2, "-3"),
    (["{left}", "{right}", "--csw-rule", "greedy", "--csw"], 2, "greedy"),
    (["{left}", "{right}", "--engine", "gpu"], 2, "gpu"),
    (["{left}", "{right}", "-o", "{left}"], 2, "must not overwrite"),
    (["{left}", "{right}", "-o", "{tmp}/a.png", "--preview", "{tmp}/a.png"], 2,
     "must not overwrite"),
    (["{left}", "{right}", "--cost", "ncc"], 2, "ncc"),
]


@pytest.mark.parametrize("args, code, message", BAD_INPUTS)
def test_bad_input_gives_one_line_and_no_output(pair_files, tmp_path, args, code, message):
    left, right = pair_files
    (tmp_path / "junk.png").write_bytes(b"this is not an image")
    write_png(tmp_path / "small.png", np.zeros((10, 10), np.uint8))
    names = dict(left=left, right=right, junk=tmp_path / "junk.png",
                 small=tmp_path / "small.png", tmp=tmp_path)
    args = [a.format(**names) for a in args]
    if "-o" not in args:
        args += ["-o", str(tmp_path / "out.pfm")]
    before = files_in(tmp_path)
    result = CliRunner().invoke(cli, ["match", *args, "--dmax", "8"] if "--dmax" not in args
                                else ["match", *args])
    assert result.exit_code == code, result.output
    assert message in result.output
    assert "Traceback" not in result.output
    assert not isinstance(result.exception, Exception) or isinstance(result.exception,
                                                                     SystemExit)
    error_lines = [line for line in result.output.splitlines() if line.startswith("Error")]
    assert len(error_lines) == 1
    assert files_in(tmp_path) == before  # nothing written, not even a temporary file


def test_png_output_refuses_disparities_it_cannot_hold(tmp_path):
    wide = np.random.default_rng(0).integers(0, 256, (12, 300), dtype=np.uint8)
    write_png(tmp_path / "l.png", wide)
    result = run("match", tmp_path / "l.png", tmp_path / "l.png", "-o", tmp_path / "d.png",
                 "--dmax", 280, "--window", 3)
    assert result.exit_code == 2 and "too large for a 16-bit PNG" in result.output
    assert not (tmp_path / "d.png").exists()


def test_failed_write_leaves_no_partial_file(pair_files, tmp_path, monkeypatch):
    import csw.io.formats as io

    def broken(tmp):
        with open(tmp, "wb") as f:
            f.write(b"half")
        raise OSError(28, "No space left on device")

    left, right = pair_files
    out = tmp_path / "d.npy"
    monkeypatch.setattr(io.np, "save", lambda f, arr: broken(f.name))
    before = files_in(tmp_path)
    result = run("match", left, right, "-o", out, "--dmax", 16)
    assert result.exit_code == 1
    assert "No space left on device" in result.output
    assert files_in(tmp_path) == before


def test_synth_writes_a_scene_that_reads_back(tmp_path):
    result = run("synth", tmp_path / "s", "--size", "64x48", "--dmax", 12, "--seed", 4)
    assert result.exit_code == 0, result.output
    gt = read_disparity(tmp_path / "s" / "gt.pfm")
    assert gt.shape == (48, 64) and 0 < np.nanmax(gt) <= 12
    assert read_image(tmp_path / "s" / "left.png").shape == (48, 64)
    again = tmp_path / "again"
    run("synth", again, "--size", "64x48", "--dmax", 12, "--seed", 4)
    assert (again / "left.png").read_bytes() == (tmp_path / "s" / "left.png").read_bytes()


@pytest.mark.parametrize("args, message", [
    (["--size", "64by48"], "WIDTHxHEIGHT"),
    (["--size", "4x4"], "at least 8x8"),
    (["--size", "32x32", "--dmax", "40"], "less than the width"),
])
def test_synth_bad_input(tmp_path, args, message):
    result = run("synth", tmp_path / "s", *args)
    assert result.exit_code == 2 and message in result.output


@pytest.mark.slow
def test_installed_entry_point_runs_as_a_process(pair_files, tmp_path):
    exe = shutil.which("csw", path=os.path.dirname(sys.executable)) or shutil.which("csw")
    assert exe, "the csw console script is not installed"
    left, right = pair_files
    out = tmp_path / "d.pfm"
    proc = subprocess.run([exe, "match", left, right, "-o", out, "--dmax", "16"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert out.exists() and proc.stdout == ""
    version = subprocess.run([sys.executable, "-m", "csw_cli", "--version"],
                             capture_output=True, text=True, timeout=60)
    assert version.returncode == 0 and "csw" in version.stdout
    bad = subprocess.run([exe, "match", "nope.png", left, "-o", out], capture_output=True,
                         text=True, timeout=60)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert [line for line in bad.stderr.splitlines() if line.startswith("Error")] == [
        "Error: Invalid value for LEFT: nope.png: no such file"]


def test_unique_rule_through_the_cli(pair_files, tmp_path, small_scene):
    left, right = pair_files
    out = tmp_path / "u.npy"
    result = run("match", left, right, "-o", out, "--dmax", 16, "--preset", "accurate",
                 "--csw", "--csw-rule", "unique", "--csw-margin", 20, "--engine", "window")
    assert result.exit_code == 0, result.output
    assert "CSW unique tau=none" in result.stderr
    expected = csw.match(small_scene[0], small_scene[1], dmax=16, preset="accurate",
                         csw=True, tau="none", csw_rule="unique", csw_margin=20)
    np.testing.assert_array_equal(np.load(out), np.nan_to_num(expected.disparity, nan=np.inf))


def test_engines_write_identical_maps(pair_files, tmp_path):
    left, right = pair_files
    for engine in ("window", "fast"):
        assert run("match", left, right, "-o", tmp_path / f"{engine}.pfm", "--dmax", 16,
                   "--preset", "accurate", "--csw", "--tau", 700,
                   "--engine", engine).exit_code == 0
    assert (tmp_path / "window.pfm").read_bytes() == (tmp_path / "fast.pfm").read_bytes()


def test_a_match_names_the_files_it_wrote(pair_files, tmp_path):
    """Before the summary, a line names every output, so a newcomer knows what to open."""
    left, right = pair_files
    outputs = [tmp_path / "d.pfm", tmp_path / "v.png", tmp_path / "c.pfm"]
    result = run("match", left, right, "-o", outputs[0], "--preview", outputs[1],
                 "--confidence", outputs[2], "--dmax", 16)
    assert result.exit_code == 0, result.output
    assert result.stderr.strip().splitlines()[-2] == \
        "wrote " + ", ".join(str(path) for path in outputs)
    assert all(path.is_file() for path in outputs)

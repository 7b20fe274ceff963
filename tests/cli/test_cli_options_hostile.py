"""Options, environments and outputs a hostile or careless caller gives: one line, no
traceback, nothing written but what was asked for (from a pass over every command run as
a real process)."""

import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner

import csw
from csw.data.synth import render
from csw.io import write_float_pfm, write_png
from csw_cli.main import cli

CSW = [sys.executable, "-m", "csw_cli"]


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture
def pair(tmp_path):
    left, right, gt, _ = render(97, 48, dmax=8, seed=4)  # an odd width
    write_png(tmp_path / "l.png", left)
    write_png(tmp_path / "r.png", right)
    write_float_pfm(tmp_path / "gt.pfm", gt.astype(np.float32))
    return tmp_path


def shell(line, folder):
    """``line`` in bash, csw being this Python's (closed streams are the shell's to make)."""
    command = " ".join(CSW)
    return subprocess.run(["bash", "-c", line.replace("csw ", command + " ", 1)],
                          cwd=folder, capture_output=True, text=True, timeout=120)


def test_a_closed_standard_output_is_no_traceback(pair):
    done = shell("csw --version >&-", pair)
    assert done.returncode == 0 and done.stderr == ""
    done = shell("csw match l.png r.png --dmax 8 -o d.pfm >&-", pair)
    assert done.returncode == 0 and "Traceback" not in done.stderr
    assert (pair / "d.pfm").exists()


def test_with_standard_error_closed_an_error_stays_out_of_the_data(pair):
    done = shell("csw score gt.pfm --gt missing.pfm --format json 2>&- >out.json", pair)
    assert done.returncode == 2 and (pair / "out.json").read_text() == ""


@pytest.mark.parametrize("command", ["bench --dataset-dir . --dmax 8", "hist l.png r.png"])
def test_the_experiments_take_a_number_for_dmin_not_auto(pair, command):
    result = invoke(*command.split(), "--dmin", "auto")
    assert result.exit_code == 2 and "'auto' is not a valid integer" in result.output
    assert "Traceback" not in result.output


def test_hist_with_csw_takes_its_own_preset(pair):
    result = invoke("hist", pair / "l.png", pair / "r.png", "--dmax", 8, "--csw")
    assert result.exit_code == 0, result.output


def test_an_output_name_that_is_not_utf8_is_written(pair):
    name = b"\xe9.pfm".decode(sys.getfilesystemencoding(), "surrogateescape")
    result = invoke("match", pair / "l.png", pair / "r.png", "--dmax", 8, "-o",
                    pair / name)
    assert result.exit_code == 0, result.output
    assert (pair / name).exists()


def test_units_whose_depths_float32_cannot_hold_are_refused(pair):
    csw.write_disparity(pair / "d.pfm", np.full((8, 8), 4, np.float32))
    result = invoke("depth", pair / "d.pfm", "-o", pair / "z.pfm", "--focal", "1e30",
                    "--baseline", 1, "--calib-units", "km", "--units", "um")
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1 and "use a larger unit" in lines[0]
    assert not (pair / "z.pfm").exists()


@pytest.mark.parametrize("scale", ["nan", "inf", "1e-320"])
def test_a_ground_truth_scale_that_is_no_scale_is_refused(pair, scale):
    result = invoke("score", pair / "gt.pfm", "--gt", pair / "gt.pfm", "--gt-scale", scale)
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1 and "between 1e-30 and 1e30" in lines[0]


@pytest.mark.parametrize("dmin, dmax", [(0, 96), (-96, 0)])
def test_a_range_at_the_width_s_edge_is_searched_whole(pair, dmin, dmax):
    """Halved for the narrowed search's half-size pass, 0..96 of a 97-wide pair went
    past the half width (48), and the match was refused with numbers of its own."""
    left, right = (csw.io.read_image(pair / n) for n in ("l.png", "r.png"))
    got = csw.match(left, right, dmin=dmin, dmax=dmax).disparity
    whole = csw.match(left, right, dmin=dmin, dmax=dmax, sgm_narrow=0).disparity
    np.testing.assert_array_equal(got, whole)

"""Every map format csw writes, csw reads back equal to what was written: the library,
csw depth, csw cloud and csw score alike (issue 26)."""

import numpy as np
import pytest
from click.testing import CliRunner

import csw
from csw.io.formats import suffixes
from csw_cli.main import cli


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.mark.parametrize("suffix", suffixes("map"))
def test_a_map_csw_wrote_is_read_back_by_every_reader(pair_files, tmp_path, suffix):
    left, right = pair_files
    reference = invoke("match", left, right, "-o", tmp_path / "ref.pfm", "--dmax", 8,
                       "--fill", "none")
    written = invoke("match", left, right, "-o", tmp_path / f"d{suffix}", "--dmax", 8)
    assert reference.exit_code == 0 and written.exit_code == 0, written.output
    expected = csw.read_disparity(tmp_path / "ref.pfm")
    got = csw.read_disparity(tmp_path / f"d{suffix}")
    if suffix == ".png":  # KITTI's PNG: d x 256 rounded, and 0 its invalid value
        expected = np.rint(expected * 256) / 256
        expected = np.where(expected == 0, np.nan, expected)
    np.testing.assert_array_equal(got, expected)
    assert invoke("depth", tmp_path / f"d{suffix}", "--focal", 100, "--baseline", 1,
                  "-o", tmp_path / "z.pfm").exit_code == 0
    assert invoke("cloud", tmp_path / f"d{suffix}", "--focal", 100, "--baseline", 1,
                  "-o", tmp_path / "c.ply").exit_code == 0
    scored = invoke("score", tmp_path / f"d{suffix}", "--gt", tmp_path / "ref.pfm")
    assert scored.exit_code == 0, scored.output


@pytest.mark.parametrize("bounds", [("--dmin", -4), ("--dmax", 300)])
def test_a_bound_a_map_format_cant_hold_is_refused_before_any_work(pair_files, tmp_path,
                                                                   bounds):
    """A negative dmin for an integer PNG, or a dmax past its 255.99, with the other
    bound found from the pair: refused at once, naming the option, no file written."""
    left, right = pair_files
    result = invoke("match", left, right, "-o", tmp_path / "d.png", *bounds)
    assert result.exit_code == 2, result.output
    assert "Invalid value for --dmax" in result.output and "write .pfm" in result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "d.png").exists()

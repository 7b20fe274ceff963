"""``csw match`` in row stripes: the same map as a whole-image match, the formats only
stripes write, and the errors of a memory limit too small or a TIFF that isn't one."""

import numpy as np
import pytest
import tifffile
from click.testing import CliRunner

from csw.data.synth import render
from csw.io import read_disparity, read_pfm, write_png
from csw_cli.main import cli

DMAX = 24


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def files_in(folder):
    return sorted(p.name for p in folder.iterdir())


# Striped maps equal whole ones exactly with local matching; sgm's paths cross the
# stripes' edges (tests/library/test_tiled.py and reports/sgm.md measure what differs).
ACCURATE = ("--preset", "accurate")


@pytest.fixture
def pair(tmp_path):
    left, right, _, _ = render(200, 301, dmax=DMAX, seed=4)
    write_png(tmp_path / "l.png", left)
    write_png(tmp_path / "r.png", right)
    return tmp_path / "l.png", tmp_path / "r.png"


def test_a_memory_limit_stripes_the_match_and_changes_nothing(tmp_path, pair):
    whole = invoke("match", *pair, "-o", tmp_path / "whole.pfm", "--dmax", DMAX, *ACCURATE,
                   "--confidence", tmp_path / "wc.pfm")
    assert whole.exit_code == 0 and "stripe(s)" not in whole.output
    striped = invoke("match", *pair, "-o", tmp_path / "s.pfm", "--dmax", DMAX, *ACCURATE,
                     "--memory-limit", "3MB", "--confidence", tmp_path / "sc.tif")
    assert striped.exit_code == 0, striped.output
    assert " stripe(s))" in striped.output.splitlines()[-1]
    assert "preset accurate (fast engine, 1 stripe(s))" not in striped.output
    assert (tmp_path / "s.pfm").read_bytes() == (tmp_path / "whole.pfm").read_bytes()
    np.testing.assert_array_equal(tifffile.imread(tmp_path / "sc.tif"),
                                  read_pfm(tmp_path / "wc.pfm"))


def test_tiff_and_zarr_outputs_need_no_flag(tmp_path, pair):
    invoke("match", *pair, "-o", tmp_path / "whole.pfm", "--dmax", DMAX, *ACCURATE)
    want = read_disparity(tmp_path / "whole.pfm")
    for name in ("d.tif", "d.zarr", "d.zarr"):  # a second .zarr replaces the first
        result = invoke("match", *pair, "-o", tmp_path / name, "--dmax", DMAX, *ACCURATE)
        assert result.exit_code == 0, result.output
    import zarr

    np.testing.assert_array_equal(tifffile.imread(tmp_path / "d.tif"), want)
    np.testing.assert_array_equal(zarr.open_array(tmp_path / "d.zarr", mode="r")[:], want)


@pytest.mark.parametrize("args, message", [
    (["--memory-limit", "200kB"], "below what one stripe needs"),
    (["--memory-limit", "lots"], "a size such as 512MB"),
    (["--memory-limit", "3MB", "--cost-map", "m.pfm"],
     "--cost-map: the cost map is not written"),
])
def test_bad_stripe_options_are_one_line_errors(tmp_path, pair, args, message):
    (tmp_path / "out").mkdir()
    args = [a if a != "m.pfm" else tmp_path / "out" / a for a in args]
    result = invoke("match", *pair, "-o", tmp_path / "out" / "d.tif", "--dmax", DMAX, *args)
    assert result.exit_code == 2 and message in result.output
    assert len([x for x in result.output.splitlines() if x.startswith("Error:")]) == 1
    assert files_in(tmp_path / "out") == []


def test_a_tiff_that_is_not_one(tmp_path, pair):
    (tmp_path / "l.tif").write_bytes(b"II*\x00 this is no TIFF")
    (tmp_path / "out").mkdir()
    result = invoke("match", tmp_path / "l.tif", pair[1], "-o", tmp_path / "out" / "d.tif",
                    "--dmax", DMAX)
    assert result.exit_code == 2 and "not a readable TIFF" in result.output
    assert "Traceback" not in result.output and files_in(tmp_path / "out") == []


def damaged_tiffs(image):
    """TIFFs that tifffile or Pillow log or warn of as they read them, or raise other
    errors than their own for: the first page's offset past the file's end; the first
    tag of a type that does not exist, or of a count that does not fit it; the 8th
    tag's count (samples per pixel); the file cut after the first directory's tags, or
    inside its header."""
    import io
    import struct

    buffer = io.BytesIO()
    tifffile.imwrite(buffer, image)
    good = buffer.getvalue()
    (first,) = struct.unpack("<I", good[4:8])
    (tags,) = struct.unpack("<H", good[first:first + 2])
    return {"page past the end": good[:4] + b"\xff\xff\x00\x00" + good[8:],
            "tag of no type": good[:10] + b"\x00\x00\x00\x7f" + good[14:],
            "directory cut short": good[:first + 2 + 12 * tags],
            "header cut short": good[:5],
            "tag of a wrong count": good[:14] + bytes([good[14] ^ 255]) + good[15:],
            "samples per pixel": good[:98] + bytes([good[98] ^ 255]) + good[99:]}


@pytest.mark.parametrize("damage", ["page past the end", "tag of no type",
                                    "directory cut short", "header cut short",
                                    "tag of a wrong count", "samples per pixel"])
def test_a_damaged_tiff_gets_one_line_in_a_real_process(tmp_path, pair, damage):
    """In a process of its own, where nothing configures logging: tifffile's records
    would reach stderr through logging's last resort beside csw's error (CliRunner
    runs under pytest's log capture, which hides them)."""
    import subprocess
    import sys

    (tmp_path / "l.tif").write_bytes(damaged_tiffs(render(64, 48, dmax=8)[0])[damage])
    (tmp_path / "out").mkdir()
    done = subprocess.run([sys.executable, "-m", "csw_cli", "match", tmp_path / "l.tif",
                           pair[1], "-o", tmp_path / "out" / "d.pfm", "--dmax", str(DMAX)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "l.tif" in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert files_in(tmp_path / "out") == []


@pytest.mark.slow
def test_the_stripes_of_one_pair_on_a_local_cluster(tmp_path, pair):
    pytest.importorskip("dask.distributed")
    invoke("match", *pair, "-o", tmp_path / "whole.pfm", "--dmax", DMAX, *ACCURATE)
    result = invoke("match", *pair, "-o", tmp_path / "d.pfm", "--dmax", DMAX, *ACCURATE,
                    "--memory-limit", "3MB", "--workers", "2")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "d.pfm").read_bytes() == (tmp_path / "whole.pfm").read_bytes()


def test_synth_writes_the_same_scene_as_tiled_tiffs(tmp_path):
    assert invoke("synth", tmp_path / "png", "--size", "300x200").exit_code == 0
    assert invoke("synth", tmp_path / "tif", "--size", "300x200", "--tiff").exit_code == 0
    from csw.io import read_image

    for name in ("left", "right"):
        with tifffile.TiffFile(tmp_path / "tif" / f"{name}.tif") as tif:
            assert tif.pages.first.is_tiled
            image = tif.asarray()
        np.testing.assert_array_equal(image, read_image(tmp_path / "png" / f"{name}.png"))
    np.testing.assert_array_equal(tifffile.imread(tmp_path / "tif" / "gt.tif"),
                                  read_pfm(tmp_path / "png" / "gt.pfm"))
    big = invoke("synth", tmp_path / "big", "--size", "10000x6000")
    assert big.exit_code == 2 and "needs --tiff" in big.output


def test_a_pair_too_big_for_the_default_limit_is_striped_unasked(tmp_path, pair, monkeypatch):
    import csw.scale.tiled.plan

    invoke("match", *pair, "-o", tmp_path / "whole.pfm", "--dmax", DMAX, *ACCURATE)
    # As if the pair were big:
    monkeypatch.setattr(csw.scale.tiled.plan, "DEFAULT_MEMORY_LIMIT", 3 * 10**6)
    result = invoke("match", *pair, "-o", tmp_path / "d.pfm", "--dmax", DMAX, *ACCURATE)
    assert result.exit_code == 0 and " stripe(s))" in result.output
    assert "1 stripe(s)" not in result.output
    assert (tmp_path / "d.pfm").read_bytes() == (tmp_path / "whole.pfm").read_bytes()
    small = invoke("match", *pair, "-o", tmp_path / "r.pfm", "--dmax", DMAX, "--preset", "raw")
    assert "stripe(s)" not in small.output  # the raw preset's whole match fits

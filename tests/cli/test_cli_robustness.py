"""Faults and the edges around them: Ctrl-C, corrupt data, file modes and links, hostile
headers, writes that fail halfway, and fuzzed input files."""

import os
import shutil
import signal
import struct
import subprocess
import sys
import time
import zlib

import numpy as np
import pytest
from child import interruptible
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from csw.eval.scoring import score
from csw.io import read_disparity, write_float_pfm, write_png
from csw_cli.main import cli


def invoke(*args, **kwargs):
    return CliRunner().invoke(cli, [str(a) for a in args], **kwargs)


def files_in(folder):
    return sorted(p.name for p in folder.iterdir())


def one_line_error(result):
    lines = [line for line in result.output.splitlines() if line.startswith("Error:")]
    return len(lines) == 1 and "Traceback" not in result.output


def png_bytes(width, height, bit_depth=8, colour=0, payload=b""):
    """A PNG by hand (header chunks with correct CRCs), for headers Pillow won't write."""
    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, colour, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(payload))
            + chunk(b"IEND", b""))


@pytest.mark.slow
@pytest.mark.parametrize("output", [["d.pfm"], ["d.tif", "--memory-limit", "16MB"]],
                         ids=["whole", "stripes"])
def test_ctrl_c_stops_a_long_match_at_once(tmp_path, output):
    """SIGINT during a window-engine match that would take about half a minute, whole or
    in stripes (whose temporary stores must go too)."""
    rng = np.random.default_rng(0)
    left = rng.integers(0, 256, (540, 960)).astype(np.uint8)
    write_png(tmp_path / "l.png", left)
    write_png(tmp_path / "r.png", np.roll(left, -7, axis=1))
    csw = shutil.which("csw") or os.path.join(os.path.dirname(sys.executable), "csw")
    command = [csw, "match", "l.png", "r.png", "--preview", "p.png",
               "--preset", "raw", "--engine", "window", "--dmax", "255", "--threads", "1"]
    # Compile first, on a small pair: LLVM's compiler does not let Python act on a signal
    # until it returns, so a first, cold run is only interruptible once it is matching.
    write_png(tmp_path / "s.png", left[:16, :300])
    subprocess.run([*command[:2], "s.png", "s.png", "-o", "s.pfm", *command[6:]], cwd=tmp_path,
                   check=True, capture_output=True)
    for name in ("s.png", "s.pfm"):
        (tmp_path / name).unlink()
    before = files_in(tmp_path)
    process = interruptible([*command, "-o", *output], cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    time.sleep(4)  # past start-up and the warm-up (from the cache), inside the kernel
    assert process.poll() is None, process.communicate()
    sent = time.perf_counter()
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    waited = time.perf_counter() - sent
    assert process.returncode == 130, stderr
    assert waited < 3.0, f"took {waited:.1f} s to stop"
    lines = stderr.strip().splitlines()
    if output[0] == "d.pfm":
        assert lines == ["csw: interrupted; no partial file was left"]
    else:  # after the progress bar
        assert lines[-1].endswith("csw: interrupted; no partial file was left")
        assert "Traceback" not in stderr
    assert files_in(tmp_path) == before  # no map, no preview, no temporary file


def test_outputs_get_the_umask_mode_and_keep_an_existing_mode(pair_files, tmp_path):
    left, right = pair_files
    old = os.umask(0o022)
    try:
        assert invoke("match", left, right, "-o", tmp_path / "d.pfm", "--dmax", 8,
                      "--preview", tmp_path / "p.png").exit_code == 0
        assert (tmp_path / "d.pfm").stat().st_mode & 0o777 == 0o644
        assert (tmp_path / "p.png").stat().st_mode & 0o777 == 0o644
        os.chmod(tmp_path / "d.pfm", 0o640)
        assert invoke("match", left, right, "-o", tmp_path / "d.pfm", "--dmax", 8).exit_code == 0
        assert (tmp_path / "d.pfm").stat().st_mode & 0o777 == 0o640
        assert invoke("synth", tmp_path / "s", "--size", "16x12", "--dmax", 4).exit_code == 0
        assert {(p.stat().st_mode & 0o777) for p in (tmp_path / "s").iterdir()} == {0o644}
    finally:
        os.umask(old)


def test_a_symlinked_output_writes_its_target(pair_files, tmp_path):
    left, right = pair_files
    (tmp_path / "real").mkdir()
    (tmp_path / "link.pfm").symlink_to(tmp_path / "real" / "d.pfm")
    assert invoke("match", left, right, "-o", tmp_path / "link.pfm", "--dmax", 8).exit_code == 0
    assert (tmp_path / "link.pfm").is_symlink()
    assert read_disparity(tmp_path / "real" / "d.pfm").shape == (64, 96)
    assert files_in(tmp_path / "real") == ["d.pfm"]


def test_a_stale_temporary_file_is_cleaned_up(pair_files, tmp_path, monkeypatch):
    """An older csw's temporary name, which says no writer: it goes once a day old."""
    from csw.io import atomic

    monkeypatch.setattr(atomic, "_SWEPT", set())  # a new run: it sweeps the folder again
    left, right = pair_files
    stale = tmp_path / ".csw-tmp.d.pfm.abc123.tmp"
    fresh = tmp_path / ".csw-tmp.d.pfm.def456.tmp"  # maybe another writer's: kept
    stale.write_bytes(b"half")
    fresh.write_bytes(b"half")
    os.utime(stale, (time.time() - 3 * 86400,) * 2)
    assert invoke("match", left, right, "-o", tmp_path / "d.pfm", "--dmax", 8).exit_code == 0
    assert not stale.exists() and fresh.exists()


@pytest.mark.parametrize("header, message", [
    (b"Pf\n100000 100000\n-1\n", "needs 40000000000 bytes"),
    (b"Pf\n-1 -1\n-1\n", "size of -1x-1"),
    (b"Pf\n4 4\n0\n", "non-zero number"),
    (b"Pf\n4 4\nnan\n", "non-zero number"),
    (b"Pf\n4 4\n-1\n", "needs 64 bytes"),
])
def test_hostile_pfm_headers(tmp_path, header, message):
    (tmp_path / "d.pfm").write_bytes(header + b"\0" * 36)
    write_float_pfm(tmp_path / "gt.pfm", np.ones((4, 4), np.float32))
    start = time.perf_counter()
    result = invoke("score", tmp_path / "d.pfm", "--gt", tmp_path / "gt.pfm")
    assert result.exit_code == 2 and one_line_error(result) and message in result.output
    assert time.perf_counter() - start < 5


@pytest.mark.parametrize("content, message", [
    (b"Pf\n", "the PFM header ends before its size"),
    (b"Pf\n\n\n", "the PFM header ends before its size"),  # read forever once
    (b"Px\n4 4\n-1\n", "d.pfm: not a PFM file"),
])
def test_a_pfm_that_ends_in_its_header_is_refused_at_once(tmp_path, content, message):
    import subprocess
    import sys

    (tmp_path / "d.pfm").write_bytes(content)
    write_float_pfm(tmp_path / "gt.pfm", np.ones((4, 4), np.float32))
    done = subprocess.run([sys.executable, "-m", "csw_cli", "score", str(tmp_path / "gt.pfm"),
                           "--gt", str(tmp_path / "d.pfm")],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and done.stderr.strip().endswith(message)
    assert len(done.stderr.strip().splitlines()) == 1 and done.stderr.count("d.pfm") == 1


@pytest.mark.parametrize("content, option", [
    ("\n" * (1 << 19), "--calib"),
    ("\n" * (1 << 19), "--rig"),
    ("cam0=[1 0 1; 0 1 1; 0 0 1]\nbaseline=1" + " " * (1 << 19) + "z\n", "--calib"),
    ("%YAML:1.0\n" + "Q:\n" * (1 << 18), "--calib"),
])
def test_a_calibration_made_to_stall_its_parser_is_refused_at_once(tmp_path, content,
                                                                   option):
    """Under the 1 MiB limit, each once took minutes: a key's pattern whose line start
    ran over every blank line below it, a value's lazy match against half a million
    spaces, a Q key's search for its data from every Q line (their time grew with the
    square of the size)."""
    import subprocess
    import sys

    write_float_pfm(tmp_path / "d.pfm", np.ones((4, 4), np.float32))
    (tmp_path / "calib.txt").write_text(content)
    args = ["depth", str(tmp_path / "d.pfm"), "-o", str(tmp_path / "z.pfm")] \
        if option == "--calib" else ["rectify", str(tmp_path / "d.pfm"),
                                     str(tmp_path / "d.pfm"), "-O", str(tmp_path / "out")]
    done = subprocess.run([sys.executable, "-m", "csw_cli", *args, option,
                           str(tmp_path / "calib.txt")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1
    assert "calib.txt" in done.stderr and len(done.stderr) < 400
    assert not (tmp_path / "z.pfm").exists() and not (tmp_path / "out").exists()


@pytest.mark.parametrize("indent", ["\f", "\xa0", "\t ", ""])
def test_a_middlebury_calibration_s_keys_may_be_indented_by_any_space(tmp_path, indent):
    from csw.camera.calibration import read_calibration

    (tmp_path / "calib.txt").write_text(
        f"{indent}cam0=[1000 0 40; 0 1000 30; 0 0 1]\r\n{indent}baseline=170\r\n"
        f"{indent}doffs=0\r\n", encoding="utf-8")
    calib = read_calibration(tmp_path / "calib.txt")
    assert (calib.focal, calib.baseline) == (1000.0, 170.0)


def test_an_image_over_the_pixel_limit_says_so(tmp_path, pair_files):
    (tmp_path / "big.png").write_bytes(png_bytes(60000, 60000))
    result = invoke("match", tmp_path / "big.png", pair_files[1], "-o", tmp_path / "d.pfm")
    assert result.exit_code == 2 and one_line_error(result)
    assert "safety limit" in result.output and "CSW_MAX_PIXELS" in result.output
    assert "--memory-limit" in result.output  # a pair's match can go in stripes
    result = invoke("hist", tmp_path / "big.png", pair_files[1])  # hist can't
    assert result.exit_code == 2 and one_line_error(result)
    assert "safety limit" in result.output and "memory-limit" not in result.output


def test_16_bit_colour_keeps_its_precision(tmp_path):
    from csw.io import luma, read_image

    rgb = (np.arange(4 * 5 * 3).reshape(4, 5, 3) * 997 + 7).astype(np.uint16)
    rows = b"".join(b"\0" + rgb[y].astype(">u2").tobytes() for y in range(4))
    (tmp_path / "c.png").write_bytes(png_bytes(5, 4, 16, 2, rows))
    got = read_image(tmp_path / "c.png")
    assert got.dtype == np.uint16
    np.testing.assert_array_equal(got, luma(rgb))


@pytest.mark.parametrize("args, message", [
    (["--tau", "100"], "only with CSW"),
    (["--csw-rule", "unique"], "csw_rule applies only with CSW"),
    (["--preset", "raw", "--census-window", "7"], "census_window applies only"),
    (["--speckle-size", "0", "--speckle-range", "3"], "speckle_range applies only"),
    (["--csw", "--tau", "-5"], ">= 0"),
])
def test_options_that_would_do_nothing_are_refused(pair_files, tmp_path, args, message):
    result = invoke("match", *pair_files, "-o", tmp_path / "d.pfm", *args)
    assert result.exit_code == 2 and message in result.output


def test_bad_numbers_and_folders_are_usage_errors(tmp_path):
    assert invoke("synth", tmp_path / "s", "--seed", -1).exit_code == 2
    result = invoke("bench", "-d", "tsukuba", "--data-dir", tmp_path / "nowhere")
    assert result.exit_code == 2 and "does not exist" in result.output


def test_a_mask_of_the_wrong_size(tmp_path):
    write_float_pfm(tmp_path / "gt.pfm", np.ones((4, 4), np.float32))
    write_float_pfm(tmp_path / "d.pfm", np.ones((4, 4), np.float32))
    write_png(tmp_path / "m.png", np.full((3, 3), 255, np.uint8))
    result = invoke("score", tmp_path / "d.pfm", "--gt", tmp_path / "gt.pfm", "--mask",
                    f"occ={tmp_path / 'm.png'}")
    assert result.exit_code == 2 and one_line_error(result) and "3x3" in result.output


@pytest.mark.data
def test_modified_dataset_files_are_refused_unless_told(tmp_path, data_dir, monkeypatch):
    monkeypatch.setenv("CSW_CACHE_DIR", str(tmp_path / "cache"))
    copy = tmp_path / "data"
    shutil.copytree(data_dir / "tsukuba", copy / "tsukuba")
    truth = copy / "tsukuba" / "truedisp.row3.col3.pgm"
    write_float_pfm(tmp_path / "d.pfm", np.zeros((288, 384), np.float32))
    ok = invoke("score", tmp_path / "d.pfm", "-d", "tsukuba", "--data-dir", copy)
    assert ok.exit_code == 0, ok.output  # verified, and remembered
    raw = bytearray(truth.read_bytes())
    raw[50000:50010] = b"\x55" * 10  # a few bytes overwritten, later (times are coarse)
    time.sleep(0.05)
    truth.write_bytes(bytes(raw))
    bad = invoke("score", tmp_path / "d.pfm", "-d", "tsukuba", "--data-dir", copy)
    assert bad.exit_code == 1 and one_line_error(bad)
    assert "truedisp.row3.col3.pgm does not match the registry's sha256" in bad.output
    told = invoke("score", tmp_path / "d.pfm", "-d", "tsukuba", "--data-dir", copy,
                  "--no-verify")
    assert told.exit_code == 0 and "not checked against their sha256" in told.stderr


def test_bad_n_is_strictly_greater_than_the_threshold():
    """Real maps have many whole-number errors: an error of exactly t is not bad-t."""
    gt = np.zeros((1, 8), np.float32) + 10
    disp = gt + np.array([[0.5, 1, 2, 4, 0.6, 1.1, 2.5, 4.5]], np.float32)
    bad = score(disp, gt, {"all": np.ones_like(gt, bool)})["all"]["bad"]
    assert bad == {0.5: 7 / 8 * 100, 1.0: 5 / 8 * 100, 2.0: 3 / 8 * 100, 4.0: 1 / 8 * 100}


def half_then_enospc(path):
    with open(path, "wb") as f:
        f.write(b"half")
    raise OSError(28, "No space left on device")


@pytest.mark.parametrize("suffix, target", [
    (".pfm", "csw.io.formats.write_parts"), (".npy", "numpy.save"),
    (".png", "pathlib.Path.write_bytes")])  # PNGs are encoded in memory, then written
def test_a_failed_write_leaves_nothing(pair_files, tmp_path, monkeypatch, suffix, target):
    module, _, name = target.rpartition(".")
    if module == "pathlib.Path":
        import pathlib
        monkeypatch.setattr(pathlib.Path, "write_bytes", lambda self, data: half_then_enospc(self))
    elif module == "csw.io.formats":
        from csw.io import formats
        monkeypatch.setattr(formats, "write_parts", lambda path, *parts: half_then_enospc(path))
    elif module == "numpy":
        monkeypatch.setattr(np, "save", lambda f, arr: half_then_enospc(f.name))
    (tmp_path / "out").mkdir()
    result = invoke("match", *pair_files, "-o", tmp_path / "out" / f"d{suffix}", "--dmax", 8)
    assert result.exit_code == 1 and "No space left on device" in result.output
    assert files_in(tmp_path / "out") == []


def test_a_failed_synth_write_leaves_no_scene_file(tmp_path, monkeypatch):
    import pathlib

    monkeypatch.setattr(pathlib.Path, "write_bytes", lambda self, data: half_then_enospc(self))
    (tmp_path / "s").mkdir()
    result = invoke("synth", tmp_path / "s", "--size", "16x12", "--dmax", 4)
    assert result.exit_code == 1 and "No space left on device" in result.output
    assert files_in(tmp_path / "s") == []


def mutate(data, flips, cut, header_edit):
    data = bytearray(data)
    for position, value in flips:
        data[position % len(data)] = value
    if header_edit:
        data[: len(header_edit)] = header_edit
    return bytes(data[: max(1, len(data) - cut)])


mutations = dict(
    flips=st.lists(st.tuples(st.integers(0, 10**6), st.integers(0, 255)), max_size=6),
    cut=st.sampled_from([0, 0, 1, 7, 40, 300]),
    header_edit=st.sampled_from([b"", b"Pf\n9 9\n", b"PF\n", b"\x89PNG", b"Pf\n0 3\n-1\n",
                                 b"Pf\n3 3\ninf\n"]))


@pytest.mark.slow
@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(**mutations)
def test_fuzzed_files_never_crash(tmp_path_factory, flips, cut, header_edit):
    folder = tmp_path_factory.mktemp("fuzz")
    rng = np.random.default_rng(1)
    image = rng.integers(0, 256, (12, 16)).astype(np.uint8)
    write_png(folder / "ok.png", image)
    write_float_pfm(folder / "ok.pfm", rng.random((12, 16)).astype(np.float32) * 4)
    (folder / "l.png").write_bytes(mutate((folder / "ok.png").read_bytes(), flips, cut,
                                          header_edit if header_edit == b"\x89PNG" else b""))
    (folder / "d.pfm").write_bytes(mutate((folder / "ok.pfm").read_bytes(), flips, cut,
                                          header_edit))
    (folder / "out").mkdir()
    runs = [invoke("match", folder / "l.png", folder / "ok.png", "-o",
                   folder / "out" / "m.pfm", "--dmax", 4, "--window", 3),
            invoke("score", folder / "d.pfm", "--gt", folder / "ok.pfm")]
    for result in runs:
        assert result.exit_code in (0, 1, 2), result.output
        assert result.exception is None or isinstance(result.exception, SystemExit), \
            repr(result.exception)
    assert files_in(folder / "out") in ([], ["m.pfm"])
    if files_in(folder / "out"):
        assert read_disparity(folder / "out" / "m.pfm").shape == (12, 16)

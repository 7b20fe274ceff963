"""The hostile audit's reproductions (issue 25), each held: an output never replaces an
input or a device, outputs of a batch never collide, signals and kills leave nothing
behind, bad numbers and files end in one line, and wrong results became errors or
right results."""

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from child import interruptible
from click.testing import CliRunner
from hostile_files import png, tiff
from layout_fixtures import middlebury2014

import csw
from csw.io import atomic, read_disparity, write_png
from csw_cli.main import cli


def invoke(*args, **kwargs):
    return CliRunner().invoke(cli, [str(a) for a in args], **kwargs)


def one_line(result):
    """Exit non-zero, and the output is one 'Error:' line: no usage lines, no trace."""
    lines = result.output.strip().splitlines()
    return result.exit_code != 0 and len(lines) == 1 and lines[0].startswith("Error:") \
        and "Traceback" not in result.output


def digest(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def temporaries(folder):
    return sorted(p.name for p in Path(folder).rglob(".csw-tmp*"))


# ---------------------------------------------------------------- inputs never outputs


def test_a_plot_may_not_replace_an_input_image(pair_files):
    left, right = pair_files
    before = digest(left)
    result = invoke("hist", left, right, "--plot", left, "--dmax", 8)
    assert one_line(result) and "input" in result.output and result.exit_code == 2
    assert digest(left) == before


def test_a_sweep_plot_may_not_replace_a_dataset_image(tmp_path):
    middlebury2014(tmp_path / "scene")
    image = tmp_path / "scene" / "im0.png"
    before = digest(image)
    result = invoke("sweep", "--dataset-dir", tmp_path / "scene", "--tau-range", "1x",
                    "--plot", image, "--dmax", 8)
    assert result.exit_code != 0 and "input" in result.output
    assert "Traceback" not in result.output and digest(image) == before


def q_file(path):
    q = np.array([[1, 0, 0, -48], [0, 1, 0, -32], [0, 0, 0, 100], [0, 0, 0.01, 0]])
    np.save(path, q)
    return digest(path)


def test_depth_may_not_replace_its_calibration(pair_files, tmp_path):
    left, right = pair_files
    before = q_file(tmp_path / "q.npy")
    assert invoke("match", left, right, "-o", tmp_path / "d.pfm", "--dmax", 8).exit_code == 0
    result = invoke("depth", tmp_path / "d.pfm", "--calib", tmp_path / "q.npy",
                    "-o", tmp_path / "q.npy")
    assert one_line(result) and "input" in result.output
    result = invoke("match", left, right, "-o", tmp_path / "m.pfm", "--dmax", 8,
                    "--calib", tmp_path / "q.npy", "--depth", tmp_path / "q.npy")
    assert one_line(result) and "input" in result.output
    assert digest(tmp_path / "q.npy") == before and not (tmp_path / "m.pfm").exists()


@pytest.mark.parametrize("target", ["/dev/null", "/dev/full"])
def test_an_output_that_is_a_device_or_links_to_one_is_refused(pair_files, tmp_path, target):
    left, right = pair_files
    (tmp_path / "d.pfm").symlink_to(target)
    result = invoke("match", left, right, "-o", tmp_path / "d.pfm", "--dmax", 8)
    assert one_line(result) and "not a regular file" in result.output
    assert (tmp_path / "d.pfm").is_symlink() and Path(target).is_char_device()
    result = invoke("match", left, right, "-o", tmp_path / "e.pfm", "--dmax", 8,
                    "--preview", target)
    assert result.exit_code != 0 and not (tmp_path / "e.pfm").exists()


def test_the_atomic_writer_itself_refuses_a_device(tmp_path):
    """The check every write passes, whatever its caller checked before."""
    (tmp_path / "x.pfm").symlink_to("/dev/null")
    with pytest.raises(ValueError, match="not a regular file"):
        atomic.atomic_write(tmp_path / "x.pfm", lambda tmp: Path(tmp).write_bytes(b"x"))
    assert temporaries(tmp_path) == [] and Path("/dev/null").is_char_device()


def test_a_write_fails_naming_the_output_not_the_temporary(tmp_path):
    def full(tmp):
        raise OSError(28, "No space left on device", tmp)
    with pytest.raises(OSError) as raised:
        atomic.atomic_write(tmp_path / "d.pfm", full)
    assert raised.value.filename == str(tmp_path / "d.pfm")
    assert temporaries(tmp_path) == []


# ---------------------------------------------------------------- batches


def batch_folders(root, names):
    left, right = (csw.synthetic_pair(64, 48, dmax=8, seed=2)[i] for i in (0, 1))
    for side in ("l", "r"):
        (root / side).mkdir(parents=True, exist_ok=True)
    lines = []
    for name in names:
        write_png(root / "l" / "p.png", left)
        write_png(root / "r" / "p.png", right)
        lines.append(f"l/p.png,r/p.png,{name}")
    (root / "pairs.csv").write_text("\n".join(lines) + "\n")
    return root / "pairs.csv"


def test_batch_outputs_of_two_pairs_may_not_collide(tmp_path):
    manifest = batch_folders(tmp_path, ["a", "a.depth"])
    (tmp_path / "l" / "calib.txt").write_text(
        "cam0=[100 0 32; 0 100 24; 0 0 1]\ndoffs=0\nbaseline=100\nndisp=9\n")
    result = invoke("match", "--manifest", manifest, "-O", tmp_path / "out",
                    "--depth", ".pfm")
    assert one_line(result) and "also" in result.output
    assert not (tmp_path / "out").exists()
    manifest = batch_folders(tmp_path, ["b", "b.depth"])
    result = invoke("match", "--manifest", manifest, "-O", tmp_path / "out2",
                    "--depth-preview", ".png", "--suffix", ".png")
    assert one_line(result) and "also" in result.output


@pytest.mark.parametrize("summary", ["out/a.pfm", "pairs.csv"])
def test_a_batch_summary_may_not_replace_a_map_or_the_manifest(tmp_path, summary):
    manifest = batch_folders(tmp_path, ["a", "b"])
    before = digest(manifest)
    result = invoke("match", "--manifest", manifest, "-O", tmp_path / "out",
                    "--summary", tmp_path / summary, "--dmax", 8)
    assert one_line(result) and "summary" in result.output
    assert digest(manifest) == before and not (tmp_path / "out" / "a.pfm").exists()


def test_a_summary_in_a_missing_folder_is_refused_before_the_work(tmp_path):
    manifest = batch_folders(tmp_path, ["a"])
    result = invoke("match", "--manifest", manifest, "-O", tmp_path / "out",
                    "--summary", tmp_path / "missing" / "s.json", "--dmax", 8)
    assert one_line(result) and "does not exist" in result.output
    assert not (tmp_path / "out" / "a.pfm").exists()


def test_a_pair_named_star_removes_only_its_own_temporaries(tmp_path):
    other = tmp_path / f"{atomic.temporary_prefix('a.pfm')}xyz.tmp"
    other.write_bytes(b"another writer's")
    mine = tmp_path / f"{atomic.temporary_prefix('*.pfm')}xyz.tmp"
    mine.write_bytes(b"mine")
    atomic.remove_temporaries(tmp_path / "*.pfm")
    assert other.exists() and not mine.exists()


def test_a_too_long_name_is_a_failed_pair_and_the_others_finish(tmp_path):
    manifest = batch_folders(tmp_path, ["ok"])
    long_name = "n" * 300
    with open(manifest, "a") as f:
        f.write(f"l/p.png,r/p.png,{long_name}\n")
    result = invoke("match", "--manifest", manifest, "-O", tmp_path / "out", "--dmax", 8)
    assert result.exit_code == 2 and "longer than" in result.output
    # A bad pair of a folder batch (here: a corrupt deflate stream) is reported and the
    # others finish.
    (tmp_path / "l" / "z.png").write_bytes((tmp_path / "l" / "p.png").read_bytes()[:60]
                                           + b"\0" * 200)
    write_png(tmp_path / "r" / "z.png", np.zeros((48, 64), np.uint8))
    result = invoke("match", tmp_path / "l", tmp_path / "r", "-O", tmp_path / "out2",
                    "--dmax", 8)
    summary = json.loads((tmp_path / "out2" / "summary.json").read_text())
    assert result.exit_code == 1 and summary["counts"] == {"ok": 1, "skipped": 0,
                                                           "failed": 1}
    assert "Traceback" not in result.output


def test_a_batch_survives_any_error_of_one_pair(tmp_path, monkeypatch):
    """Not only csw's own errors: an overflow, a zlib error, anything a pair raises."""
    from csw.scale import batch
    from csw.scale.jobs import Job

    jobs = [Job("a", tmp_path / "a.png", tmp_path / "a.png"),
            Job("b", tmp_path / "b.png", tmp_path / "b.png")]
    left = csw.synthetic_pair(64, 48, dmax=8, seed=2)[0]
    for job in jobs:
        write_png(job.left, left)
    real = batch.match_files

    def sometimes(left, right, output, **options):
        # Pair a fails, by its name: the batch may start its pairs in either order.
        if Path(left).name == "a.png":
            raise OverflowError("cannot convert float infinity to integer")
        return real(left, right, output, **options)
    monkeypatch.setattr(batch, "match_files", sometimes)
    report = csw.match_many(jobs, tmp_path / "out", dmax=8, progress=False)
    assert report["counts"] == {"ok": 1, "skipped": 0, "failed": 1}
    assert "OverflowError" in report["pairs"][0]["error"]


# ---------------------------------------------------------------- zarr through a link


def test_a_zarr_output_through_a_link_keeps_the_link(pair_files, tmp_path):
    left, right = pair_files
    real = tmp_path / "real"
    real.mkdir()
    first = invoke("match", left, right, "-o", real / "d.zarr", "--dmax", 8)
    assert first.exit_code == 0, first.output
    (tmp_path / "d.zarr").symlink_to(real / "d.zarr")
    again = invoke("match", left, right, "-o", tmp_path / "d.zarr", "--dmax", 8)
    assert again.exit_code == 0, again.output
    assert (tmp_path / "d.zarr").is_symlink() and (real / "d.zarr" / "zarr.json").is_file()
    assert temporaries(tmp_path) == []


# ---------------------------------------------------------------- what killed runs leave


def test_temporaries_of_a_killed_process_are_swept_by_the_next_run(pair_files, tmp_path,
                                                                  monkeypatch):
    monkeypatch.setattr(atomic, "_SWEPT", set())  # a new run: it sweeps the folder again
    left, right = pair_files
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    host = atomic.HOST
    stale_file = tmp_path / f".csw-tmp.d.pfm.{host}-{dead.pid}-abc.tmp"
    stale_file.write_bytes(b"half a map")
    stale_dir = tmp_path / f".csw-tmp.d.zarr.{host}-{dead.pid}-def.tmp"
    (stale_dir / "disparity.zarr").mkdir(parents=True)
    alive = tmp_path / f".csw-tmp.x.pfm.{host}-{os.getppid()}-ghi.tmp"
    alive.write_bytes(b"a running writer's")
    assert invoke("match", left, right, "-o", tmp_path / "other.pfm", "--dmax", 8)\
        .exit_code == 0
    assert not stale_file.exists() and not stale_dir.exists() and alive.exists()


CSW = [sys.executable, "-c", "from csw_cli.main import main; main()"]


PROBE = ("import signal; from csw_cli.main import stop_on_signals; stop_on_signals(); "
         "print(*(signal.getsignal(getattr(signal, n)) == signal.SIG_IGN "
         "for n in ('SIGINT', 'SIGTERM', 'SIGHUP')))")


def test_a_signal_ignored_at_start_stays_ignored_and_signal_tests_restore_them():
    """`nohup csw ...` keeps SIGHUP ignored, a background job SIGINT; and the tests that
    interrupt a child give it the default handlers back, so that they pass with the suite
    started in the background (`nohup make test`)."""
    def ignore_all():
        for name in ("SIGINT", "SIGTERM", "SIGHUP"):
            signal.signal(getattr(signal, name), signal.SIG_IGN)

    probe = [sys.executable, "-c", PROBE]
    ignored = subprocess.run(probe, preexec_fn=ignore_all, capture_output=True, text=True)
    assert ignored.stdout.split() == ["True", "True", "True"], ignored.stderr
    saved = {n: signal.getsignal(n) for n in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    try:  # this process as a suite started with `nohup make test &` is
        ignore_all()
        child = interruptible(probe, stdout=subprocess.PIPE, text=True)
        out, _ = child.communicate(timeout=60)
    finally:
        for number, handler in saved.items():
            signal.signal(number, handler)
    assert out.split() == ["False", "False", "False"]


CLEAN_UP = """
import os, signal, sys
from csw_cli import main
main.stop_on_signals()
try:
    os.kill(os.getpid(), signal.SIGINT)  # the first Ctrl-C: the run stops ...
    for _ in range(10**7):
        pass
except KeyboardInterrupt as exc:  # ... and cleans up, while two more signals come
    os.kill(os.getpid(), signal.SIGINT)
    os.kill(os.getpid(), signal.SIGTERM)
    sum(range(10**5))  # a signal's handler runs between two bytecodes: here, if any
    open(sys.argv[1], "w").write("the summary")
    main._interrupted(getattr(exc, "signum", signal.SIGINT))
"""


def test_a_second_signal_during_clean_up_changes_nothing(tmp_path):
    """Ctrl-C, then Ctrl-C and SIGTERM while the run cleans up: the clean-up finishes
    (the summary is written), the exit is the first signal's (130), no traceback.  The
    signals are sent by the process to itself, so the test holds however fast the
    machine is."""
    from child import default_signals

    out = subprocess.run([sys.executable, "-c", CLEAN_UP, str(tmp_path / "summary.json")],
                         preexec_fn=default_signals, capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 130, out.stderr
    assert out.stderr.strip().splitlines() == ["csw: interrupted; no partial file was left"]
    assert (tmp_path / "summary.json").read_text() == "the summary"


DROPPED = """
import ctypes, os, signal, sys, time
from csw_cli import main
main.stop_on_signals()

def send():  # the handler runs at the next bytecode: inside whatever called send
    os.kill(os.getpid(), signal.SIGTERM)
    sum(range(10**5))

class Finalised:
    def __del__(self):
        send()

try:
    if sys.argv[1] == "__del__":
        Finalised()
    else:
        ctypes.CFUNCTYPE(None)(send)()
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        sum(range(1000))
    print("still running", file=sys.stderr)
except KeyboardInterrupt as exc:
    main._interrupted(getattr(exc, "signum", signal.SIGINT))
"""


@pytest.mark.parametrize("where", ["__del__", "a ctypes callback"])
def test_a_signal_that_lands_where_python_drops_exceptions_still_stops_the_run(where):
    """Python prints and drops an exception raised in a __del__ or a callback from C
    (Numba's object cache hooks are one), so the first handling of the signal stops
    nothing; the run must still stop, quietly, with the signal's exit code."""
    from child import default_signals

    out = subprocess.run([sys.executable, "-c", DROPPED, where], preexec_fn=default_signals,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 128 + signal.SIGTERM, out.stderr
    assert out.stderr.strip().splitlines() == \
        ["csw: stopped by SIGTERM; no partial file was left"]


@pytest.mark.slow
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP])
def test_sigterm_and_sighup_behave_like_ctrl_c(tmp_path, signum):
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, (540, 960)).astype(np.uint8)
    write_png(tmp_path / "l.png", image)
    write_png(tmp_path / "r.png", np.roll(image, -7, axis=1))
    command = [*CSW, "match", "l.png", "r.png", "--preset", "raw", "--engine", "window",
               "--dmax", "255", "--threads", "1"]
    write_png(tmp_path / "s.png", image[:16, :300])  # compiled first, on a small pair
    subprocess.run([*command[:4], "s.png", "s.png", "-o", "s.pfm", *command[6:]],
                   cwd=tmp_path, check=True, capture_output=True)
    before = sorted(p.name for p in tmp_path.iterdir())
    process = interruptible([*command, "-o", "d.pfm", "--preview", "p.png"],
                            cwd=tmp_path, stderr=subprocess.PIPE, text=True)
    time.sleep(4)
    assert process.poll() is None
    process.send_signal(signum)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 128 + signum, stderr
    lines = stderr.splitlines()
    assert lines[-1] == f"csw: stopped by {signal.Signals(signum).name}; no partial file " \
        "was left"
    assert "" not in lines  # Click's blank line closes a ^C's echo, and none was typed
    assert "Traceback" not in stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == before


# ---------------------------------------------------------------- sizes and limits


def test_the_pixel_limit_holds_for_16_bit_pngs_and_tiffs(tmp_path, pair_files):
    (tmp_path / "bomb.png").write_bytes(png(20000, 20000, 16, 2))
    result = invoke("match", tmp_path / "bomb.png", pair_files[1], "-o", tmp_path / "d.pfm")
    assert one_line(result) and "CSW_MAX_PIXELS" in result.output
    assert "--memory-limit" in result.output
    (tmp_path / "bomb.tif").write_bytes(tiff(60000, 60000, 1, 8, b"\0" * 64))
    result = invoke("match", tmp_path / "bomb.tif", tmp_path / "bomb.tif", "-o",
                    tmp_path / "d.tif")
    assert one_line(result) and "CSW_MAX_PIXELS" in result.output
    assert not (tmp_path / "d.tif").exists() and temporaries(tmp_path) == []


def test_the_pixel_limit_follows_the_variable(tmp_path, pair_files, monkeypatch):
    monkeypatch.setenv("CSW_MAX_PIXELS", "1000")
    result = invoke("match", *pair_files, "-o", tmp_path / "d.pfm", "--dmax", 8)
    assert one_line(result) and "1000" in result.output


def test_an_output_larger_than_the_free_space_is_refused_before_the_work(
        pair_files, tmp_path, monkeypatch):
    import shutil
    from collections import namedtuple

    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda path: usage(10**9, 10**9, 1000))
    result = invoke("match", *pair_files, "-o", tmp_path / "d.pfm", "--dmax", 8)
    assert one_line(result) and "free" in result.output
    assert not (tmp_path / "d.pfm").exists()


def test_a_huge_census_window_is_refused_at_once(pair_files, tmp_path):
    start = time.perf_counter()
    for window in (99999, 1001):
        result = invoke("match", *pair_files, "-o", tmp_path / "d.pfm", "--dmax", 8,
                        "--census-window", window)
        assert one_line(result) and "15 or less" in result.output
    assert time.perf_counter() - start < 10


@pytest.mark.parametrize("option", ["--calib", "--manifest"])
def test_a_device_as_calibration_or_manifest_is_refused(pair_files, tmp_path, option):
    args = ["match", *pair_files, "-o", tmp_path / "d.pfm"] if option == "--calib" else \
        ["match", "-O", tmp_path / "out"]
    result = invoke(*args, option, "/dev/zero")
    assert result.exit_code == 2 and "not a" in result.output
    assert "Traceback" not in result.output


# ---------------------------------------------------------------- numbers and files


@pytest.mark.parametrize("line, words", [
    ("ndisp=inf", "ndisp must be a finite number"),
    ("width=1e400", "width must be a finite number"),
    ("ndisp=-5", "ndisp must be a whole number"),
    ("baseline=abc", "baseline must be a number"),
])
def test_calibration_numbers_that_overflow_or_mean_nothing(tmp_path, pair_files, line, words):
    key = line.split("=")[0]
    values = {"cam0": "[100 0 48; 0 100 32; 0 0 1]", "doffs": "0", "baseline": "100",
              key: line.split("=")[1]}
    (tmp_path / "calib.txt").write_text("".join(f"{k}={v}\n" for k, v in values.items()))
    result = invoke("depth", pair_files[0], "--calib", tmp_path / "calib.txt",
                    "-o", tmp_path / "z.pfm")
    assert one_line(result) and words in result.output and "calib.txt" in result.output


def test_kitti_size_that_overflows_is_one_line(tmp_path):
    p = " ".join(["700", "0", "300", "0", "0", "700", "200", "0", "0", "0", "1", "0"])
    (tmp_path / "k.txt").write_text(f"P_rect_02: {p}\nP_rect_03: {p}\nS_rect_02: 1e400 5\n")
    with pytest.raises(ValueError, match="S_rect_02"):
        csw.read_calibration(tmp_path / "k.txt")


@pytest.mark.parametrize("content, words", [
    (np.zeros((4, 4), [("a", "f8")]), "plain array"),
    (np.eye(4) * (1 + 1j), "real numbers"),
    (b"", "not a readable .npy"),
])
def test_npy_calibrations_of_the_wrong_kind(tmp_path, content, words):
    path = tmp_path / "q.npy"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        np.save(path, content)
    result = invoke("depth", path, "--calib", path, "-o", tmp_path / "z.pfm")
    assert one_line(result) and words in result.output and result.exit_code != 130


def test_a_yaml_q_with_nan_says_so(tmp_path):
    data = ", ".join(["1."] * 15 + [".Nan"])
    (tmp_path / "q.yml").write_text(f"%YAML:1.0\nQ: !!opencv-matrix\n   rows: 4\n   cols: 4\n"
                                    f"   dt: d\n   data: [ {data} ]\n")
    with pytest.raises(ValueError, match="finite"):
        csw.read_calibration(tmp_path / "q.yml")


def test_a_calibration_with_every_point_behind_the_cameras_is_refused(tmp_path):
    disparity = np.full((8, 8), 5.0, np.float32)
    calib = csw.Calibration(focal=100.0, baseline=0.1, doffs=-1000.0)
    with pytest.raises(ValueError, match="in front of the cameras"):
        csw.depth(disparity, calib)
    with pytest.raises(ValueError, match="max_depth"):
        csw.point_cloud(disparity, csw.Calibration(focal=100.0, baseline=0.1),
                        max_depth=float("nan"))


def test_zero_rows_and_long_names_are_one_line(tmp_path, pair_files):
    np.save(tmp_path / "empty.npy", np.zeros((0, 10), np.uint8))
    result = invoke("match", tmp_path / "empty.npy", tmp_path / "empty.npy",
                    "-o", tmp_path / "d.tif")
    assert one_line(result) and "empty" in result.output
    long_path = tmp_path / ("x" * 300 + ".png")
    result = invoke("match", long_path, pair_files[1], "-o", tmp_path / "d.pfm")
    assert one_line(result)


def test_messages_name_the_real_image_and_range(tmp_path):
    image = np.zeros((375, 1), np.uint8)
    write_png(tmp_path / "thin.png", image)
    result = invoke("match", tmp_path / "thin.png", tmp_path / "thin.png",
                    "-o", tmp_path / "d.pfm")
    assert one_line(result) and "1x375" in result.output
    wide = np.random.default_rng(0).integers(0, 256, (40, 80)).astype(np.uint8)
    write_png(tmp_path / "w.png", wide)
    result = invoke("match", tmp_path / "w.png", tmp_path / "w.png", "-o", tmp_path / "d.pfm",
                    "--dmin", 1000, "--dmax", "auto")
    assert one_line(result) and "dmin (1000)" in result.output


def test_a_folder_in_a_manifest_and_a_bad_cloud_image_are_named(tmp_path, pair_files):
    (tmp_path / "dir.png").mkdir()
    with pytest.raises(csw.ImageError, match="is a directory"):
        csw.read_image(tmp_path / "dir.png")
    assert invoke("match", *pair_files, "-o", tmp_path / "d.pfm", "--dmax", 8).exit_code == 0
    write_png(tmp_path / "small.png", np.zeros((10, 10), np.uint8))
    result = invoke("cloud", tmp_path / "d.pfm", "--focal", 100, "--baseline", 1,
                    "--image", tmp_path / "small.png", "-o", tmp_path / "c.ply")
    assert one_line(result) and "--image" in result.output


def test_image_errors_are_value_errors_and_big_endian_arrays_work(small_scene):
    assert issubclass(csw.ImageError, ValueError)
    left, right = small_scene[0].astype(">u2") * 257, small_scene[1].astype(">u2") * 257
    swapped = csw.match(left, right, dmax=8).disparity
    native = csw.match(left.astype(np.uint16), right.astype(np.uint16), dmax=8).disparity
    np.testing.assert_array_equal(swapped, native)


# ---------------------------------------------------------------- colour spaces, bit depths


def test_cmyk_jpegs_are_read_as_colour(tmp_path, small_scene):
    from PIL import Image

    left = small_scene[0]
    rgb = np.repeat(left[..., None], 3, axis=2)
    Image.fromarray(rgb).convert("CMYK").save(tmp_path / "c.jpg", quality=100)
    Image.fromarray(rgb).save(tmp_path / "r.jpg", quality=100)
    cmyk, plain = csw.read_image(tmp_path / "c.jpg"), csw.read_image(tmp_path / "r.jpg")
    assert np.corrcoef(cmyk.ravel(), plain.ravel())[0, 1] > 0.99
    assert np.abs(cmyk.astype(int) - left).mean() < 3


def test_16_bit_tiffs_and_gray_alpha_pngs_keep_16_bits(tmp_path):
    import png
    import tifffile

    rng = np.random.default_rng(3)
    rgb = rng.integers(0, 65536, (40, 50, 3)).astype(np.uint16)
    tifffile.imwrite(tmp_path / "rgb.tif", rgb)
    tifffile.imwrite(tmp_path / "be.tif", rgb.astype(">u2"), byteorder=">")
    whole = csw.read_image(tmp_path / "rgb.tif")
    assert whole.dtype == np.uint16
    np.testing.assert_array_equal(whole, csw.read_image(tmp_path / "be.tif"))
    from csw.io.sources import open_source

    np.testing.assert_array_equal(whole, open_source(tmp_path / "rgb.tif").rows(0, 40))
    gray_alpha = rng.integers(0, 65536, (30, 20, 2)).astype(np.uint16)
    with open(tmp_path / "ga.png", "wb") as f:
        png.Writer(20, 30, greyscale=True, alpha=True, bitdepth=16).write(
            f, gray_alpha.reshape(30, 40))
    np.testing.assert_array_equal(csw.read_image(tmp_path / "ga.png"), gray_alpha[..., 0])


def test_striped_and_whole_maps_of_a_16_bit_rgb_tiff_agree(tmp_path, small_scene):
    import tifffile

    for name, image in (("l", small_scene[0]), ("r", small_scene[1])):
        rgb = np.stack([image.astype(np.uint16) * 257 + k for k in (0, 100, 200)], axis=2)
        tifffile.imwrite(tmp_path / f"{name}.tif", rgb)
    for out in ("d.pfm", "d.tif"):
        assert invoke("match", tmp_path / "l.tif", tmp_path / "r.tif", "-o", tmp_path / out,
                      "--dmax", 8).exit_code == 0
    np.testing.assert_array_equal(read_disparity(tmp_path / "d.pfm"),
                                  np.asarray(tifffile.imread(tmp_path / "d.tif")))


# ---------------------------------------------------------------- the environment


@pytest.mark.parametrize("variable, value", [
    ("CSW_MAX_PIXELS", "abc"), ("CSW_MAX_PIXELS", "0"), ("CSW_MAX_PIXELS", "9" * 5000),
    ("NUMBA_NUM_THREADS", "9" * 5000),
    ("NUMBA_NUM_THREADS", "0"), ("NUMBA_NUM_THREADS", "-2")])
def test_a_bad_variable_is_blamed_by_its_name(tmp_path, pair_files, monkeypatch, variable,
                                              value):
    """Not on the image being read when the variable was (CSW_MAX_PIXELS was blamed on
    LEFT), and not taken as some other value (NUMBA_NUM_THREADS=0 ran on one thread)."""
    monkeypatch.setenv(variable, value)
    result = invoke("match", *pair_files, "-o", tmp_path / "d.pfm", "--dmax", 8)
    assert one_line(result) and result.exit_code == 2, result.output
    assert result.output.startswith(f"Error: {variable} must be") and len(result.output) < 200
    assert not (tmp_path / "d.pfm").exists()


@pytest.mark.parametrize("given", ["variable", "option", "a file"])
def test_a_data_folder_that_is_not_there_is_named_as_it_was_given(tmp_path, monkeypatch,
                                                                    given):
    """CSW_DATA_DIR's missing folder was reported as --data-dir's, after Click's usage
    lines."""
    (tmp_path / "file").write_text("")
    missing = tmp_path / "missing"
    if given == "variable":
        monkeypatch.setenv("CSW_DATA_DIR", str(missing))
        result, says = invoke("datasets"), "CSW_DATA_DIR names"
    else:
        folder = missing if given == "option" else tmp_path / "file"
        result, says = invoke("datasets", "--data-dir", folder), "--data-dir names"
    assert one_line(result) and result.exit_code == 2, result.output
    assert says in result.output
    assert ("not a folder" if given == "a file" else "does not exist") in result.output


def test_empty_or_bad_variables_are_one_line(tmp_path, pair_files, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("NUMBA_NUM_THREADS", "abc")
    result = invoke("match", *pair_files, "-o", "d.pfm", "--dmax", 8)
    assert one_line(result) and "NUMBA_NUM_THREADS" in result.output
    monkeypatch.delenv("NUMBA_NUM_THREADS")
    from csw.kernels import store

    monkeypatch.setenv("CSW_KERNEL_CACHE", "")
    assert store.cache_dir().parent != Path("")
    assert not str(store.cache_dir()).startswith(store._fingerprint())


def test_a_full_standard_output_is_one_line():
    out = subprocess.run(f"{sys.executable} -c 'from csw_cli.main import main; main()' "
                         "datasets > /dev/full", shell=True, capture_output=True, text=True)
    assert out.returncode == 1 and out.stderr.strip().splitlines() == [
        "Error: can't write standard output: No space left on device"]


@pytest.mark.parametrize("name", ["l.png", "d.pfm"])
def test_a_pipe_as_an_input_is_refused_at_once(tmp_path, pair_files, name):
    os.mkfifo(tmp_path / name)  # no writer: reading it would wait for ever
    result = invoke("match", tmp_path / name, pair_files[1], "-o", tmp_path / "o.pfm") \
        if name.endswith(".png") else invoke("score", tmp_path / name, "--gt", pair_files[0])
    assert one_line(result) and "is a pipe" in result.output

"""Every fenced shell and Python example in README.md and docs/*.md runs as printed, in a
folder holding the files the examples name (built from the synthetic scene: nothing is
downloaded).  Lines that can't run here are skipped, each for a reason in SKIP; lines
that need the registered datasets run when CSW_DATA_DIR names them."""

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import tifffile
from calib_fixtures import known_rig, views, write_views
from layout_fixtures import kitti, middlebury2014
from log_fixtures import write_bag
from rig_fixtures import random_rig, raw_from_rectified, ros_camera_info, write_opencv

from csw.data.synth import calib_text, render
from csw.io import write_float_pfm, write_png

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^```(sh|python)\n(.*?)^```", re.DOTALL | re.MULTILINE)

# Lines that can't run in a test, and why.
SKIP = {
    r"^make ": "a make target: the suite itself, or a report that takes minutes",
    r"^pip install": "installs csw",
    r"tls://|^export DASK_": "needs a Dask cluster behind TLS",
    r"^csw compile\s*(#|$)": "compiles every kernel into an empty cache, minutes "
                              "(tests/library/test_compile_all.py checks what it compiles)",
}
NEEDS_DATA = re.compile(r"--dataset (?!synthetic)|(^|\s)-d \w|load_dataset\(\"(?!synthetic)")
# Examples that take seconds or more: compiling, a cluster, a benchmark, rigs, video,
# robot logs, depth and clouds of several pairs.
SLOW = re.compile(r"csw compile|--workers|csw bench|--rig|--frames|\.mcap|--cloud")

WIDTH, HEIGHT, DMAX = 450, 375, 15  # d*16 fits an 8-bit PGM, as Tsukuba's truth does
BASELINE_M, FOCAL = 0.1, 450.0


def examples():
    return [pytest.param(page, found.group(1), found.group(2), id=f"{page.name}-{number}",
                         marks=[pytest.mark.slow] if SLOW.search(found.group(2)) else [])
            for page in PAGES
            for number, found in enumerate(FENCE.finditer(page.read_text()), 1)]


def shell_lines(text):
    """The block's commands, continuation lines joined."""
    return [line for line in text.replace("\\\n", " ").splitlines() if line.strip()]


def skipped(line, have_data):
    for pattern, why in SKIP.items():
        if re.search(pattern, line):
            return why
    if not have_data and NEEDS_DATA.search(line):
        return "needs the registered datasets (CSW_DATA_DIR)"
    return None


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    """The files the examples name, built once."""
    root = tmp_path_factory.mktemp("docs")
    left, right, gt, _ = render(WIDTH, HEIGHT, dmax=DMAX, seed=7)
    (root / "out" / "synthetic").mkdir(parents=True)  # where make run puts its pair
    for a, b in (("left.png", "right.png"), ("im0.png", "im1.png"), ("imL.png", "imR.png"),
                 ("out/synthetic/left.png", "out/synthetic/right.png")):
        write_png(root / a, left)
        write_png(root / b, right)
    (root / "calib.txt").write_text(calib_text(WIDTH, HEIGHT, DMAX))  # Middlebury, mm
    tifffile.imwrite(root / "big_left.tif", left, tile=(256, 256))
    tifffile.imwrite(root / "big_right.tif", right, tile=(256, 256))
    cx, cy = (WIDTH - 1) / 2, (HEIGHT - 1) / 2
    p2 = f"{FOCAL} 0 {cx} 0 0 {FOCAL} {cy} 0 0 0 1 0"
    p3 = f"{FOCAL} 0 {cx} {-FOCAL * BASELINE_M} 0 {FOCAL} {cy} 0 0 0 1 0"
    (root / "calib_cam_to_cam.txt").write_text(
        f"S_rect_02: {WIDTH:.6e} {HEIGHT:.6e}\nP_rect_02: {p2}\nP_rect_03: {p3}\n")
    q = [1, 0, 0, -cx, 0, 1, 0, -cy, 0, 0, 0, FOCAL, 0, 0, 1 / BASELINE_M, 0]
    (root / "stereo.yml").write_text(
        "%YAML:1.0\n---\nQ: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n   data: [ "
        + ", ".join(f"{v:g}" for v in q) + " ]\n")
    # A Tsukuba-sized map and its truth as Tsukuba stores it (d * 16, 8-bit PGM).
    _, _, small_gt, _ = render(384, 288, dmax=DMAX, seed=3)
    write_float_pfm(root / "disp.pfm", small_gt)
    import imageio.v3 as iio

    iio.imwrite(root / "truedisp.row3.col3.pgm", np.round(small_gt * 16).astype(np.uint8),
                extension=".pgm")
    # Benchmark folders in their layouts, many pairs, a manifest and maps to score.
    middlebury2014(root / "MiddEval3" / "trainingQ" / "Adirondack")
    frames = kitti(root / "data_scene_flow" / "training", size=(WIDTH, HEIGHT))
    for folder in ("lefts", "rights", "maps"):
        (root / folder).mkdir()
    for name, (frame_left, frame_right, frame_gt, _) in frames.items():
        write_png(root / "lefts" / f"{name}.png", frame_left)
        write_png(root / "rights" / f"{name}.png", frame_right)
        write_float_pfm(root / "maps" / f"{name}.pfm", frame_gt.astype(np.float32))
    (root / "pairs.csv").write_text("".join(f"lefts/{n}.png,rights/{n}.png\n"
                                            for n in frames))
    raw_rig(root, left, right)
    write_views(root, views(known_rig(), 6))  # left/, right/: chessboards for csw calibrate
    return root


def raw_rig(root, left, right):
    """raw_left.png, raw_right.png: the scene seen through a distorted, rotated rig, and
    the rig in each format the docs show: stereo_rig.yml (OpenCV), left.yaml and
    right.yaml (ROS camera_info), calib_cam_to_cam.txt's raw keys (KITTI), camchain.yaml
    (Kalibr)."""
    from csw.camera.rectify import stereo_rectify

    rig = random_rig(np.random.default_rng(1), size=(WIDTH, HEIGHT))
    r1, r2, p1, p2, _ = stereo_rectify(rig.k1, rig.d1, rig.k2, rig.d2, rig.size, rig.r,
                                       rig.t, 0.0)
    raw = (raw_from_rectified(left, rig.k1, rig.d1, r1, p1),
           raw_from_rectified(right, rig.k2, rig.d2, r2, p2))
    write_png(root / "raw_left.png", raw[0])
    write_png(root / "raw_right.png", raw[1])
    # drive.mcap: a robot's log of three such frames, with CameraInfo beside each topic
    write_bag(root / "drive.mcap", [raw] * 3, rig, (r1, r2, p1, p2))
    write_opencv(root / "stereo_rig.yml", rig)
    (root / "left.yaml").write_text(ros_camera_info(rig.k1, rig.d1, r1, p1, rig.size))
    (root / "right.yaml").write_text(ros_camera_info(rig.k2, rig.d2, r2, p2, rig.size))

    def row(values):
        return " ".join(f"{v:.17g}" for v in np.ravel(values))

    with open(root / "calib_cam_to_cam.txt", "a") as kitti_file:
        kitti_file.write(
            f"S_02: {WIDTH} {HEIGHT}\nK_02: {row(rig.k1)}\nD_02: {row(rig.d1)}\n"
            f"R_02: {row(np.eye(3))}\nT_02: 0 0 0\nS_03: {WIDTH} {HEIGHT}\n"
            f"K_03: {row(rig.k2)}\nD_03: {row(rig.d2)}\nR_03: {row(rig.r)}\n"
            f"T_03: {row(rig.t)}\n")
    transform = np.eye(4)
    transform[:3, :3], transform[:3, 3] = rig.r, rig.t

    def camera(k, d):
        return (f"  intrinsics: [{k[0, 0]:.17g}, {k[1, 1]:.17g}, {k[0, 2]:.17g}, "
                f"{k[1, 2]:.17g}]\n  distortion_model: radtan\n"
                f"  distortion_coeffs: [{row(d[:4]).replace(' ', ', ')}]\n"
                f"  resolution: [{WIDTH}, {HEIGHT}]\n")

    (root / "camchain.yaml").write_text(
        "cam0:\n" + camera(rig.k1, rig.d1) + "cam1:\n  T_cn_cnm1:\n"
        + "".join(f"  - [{row(r).replace(' ', ', ')}]\n" for r in transform)
        + camera(rig.k2, rig.d2))


@pytest.mark.parametrize("page, language, text", examples())
def test_the_example_runs_as_printed(workspace, tmp_path, page, language, text):
    folder = tmp_path / "work"
    shutil.copytree(workspace, folder)
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}"
                                f"{os.environ.get('PATH', '')}", MPLBACKEND="Agg")
    have_data = bool(os.environ.get("CSW_DATA_DIR"))
    if language == "python":
        if not have_data and NEEDS_DATA.search(text):
            pytest.skip("needs the registered datasets (CSW_DATA_DIR)")
        command = [sys.executable, "-c", text]
        ran = text
    else:
        kept = [line for line in shell_lines(text) if skipped(line, have_data) is None]
        if not kept:
            pytest.skip("; ".join(sorted({skipped(line, have_data)
                                          for line in shell_lines(text)})))
        ran = "\n".join(kept)
        command = ["bash", "-euo", "pipefail", "-c", ran]
    done = subprocess.run(command, cwd=folder, env=env, capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, f"{page.name}:\n{ran}\n---\n{done.stderr[-3000:]}"


def test_every_page_with_examples_is_found():
    pages = {p.values[0].name for p in examples()}
    assert {"README.md", "python.md", "usage.md", "datasets.md", "opencv.md"} <= pages

"""`make run`, the README's first command on a fresh machine: scripts/run.sh as a new user
runs it (an empty folder, the installed `csw` on PATH) finishes and writes what it says.
tests/library/test_docs_examples.py skips `make` lines, so this is its only check."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from csw.io.formats import read_disparity

ROOT = Path(__file__).resolve().parents[2]


def test_make_runs_script_finishes_and_writes_its_maps_depth_and_cloud(tmp_path):
    bin_dir = str(Path(sys.executable).parent)  # the venv's `csw`, as `make run` has it
    env = dict(os.environ, PATH=os.pathsep.join([bin_dir, os.environ.get("PATH", "")]))
    done = subprocess.run(["bash", str(ROOT / "scripts" / "run.sh")], cwd=tmp_path, env=env,
                          stdin=subprocess.DEVNULL, capture_output=True, text=True,
                          timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "Traceback" not in done.stderr
    out = tmp_path / "out"
    for name in ("synthetic-disp.pfm", "synthetic-disp-csw.pfm", "synthetic-depth.pfm",
                 "synthetic-cloud.ply", "synthetic-preview.png", "synthetic-depth.png",
                 "synthetic-preview-csw.png"):
        assert (out / name).stat().st_size > 0, name
    truth = read_disparity(out / "synthetic" / "gt.pfm")
    for name in ("synthetic-disp.pfm", "synthetic-disp-csw.pfm"):
        disparity = read_disparity(out / name)
        assert disparity.shape == truth.shape
        valid = np.isfinite(disparity) & np.isfinite(truth)
        assert valid.mean() > 0.8, name  # a map of the scene, not of holes
        assert np.median(np.abs(disparity[valid] - truth[valid])) < 1.0, name

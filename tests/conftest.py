import numpy as np
import pytest

from csw_cli.imageio_utils import write_png
from csw_cli.synth import render


@pytest.fixture(scope="session")
def small_scene():
    """A small synthetic pair: (left, right, gt, nonocc)."""
    return render(96, 64, dmax=16, seed=1)


@pytest.fixture
def pair_files(tmp_path, small_scene):
    """left.png and right.png of the small scene in a fresh folder."""
    left, right, _, _ = small_scene
    write_png(tmp_path / "left.png", left)
    write_png(tmp_path / "right.png", right)
    return tmp_path / "left.png", tmp_path / "right.png"

"""csw: fast stereo matching with the Constrained Sliding Window (CSW) algorithm.

The library under the ``csw`` command: each command calls these functions, with the
same defaults (:data:`csw.defaults.MATCH`).

>>> import csw
>>> scene = csw.load_dataset("synthetic")
>>> result = csw.match(scene.left, scene.right, dmax=scene.dmax)
>>> csw.score(result.disparity, scene.gt, scene.masks)["all"]["bad"][1.0] < 10
True
"""

from importlib.metadata import PackageNotFoundError, version

from . import defaults, kernels
from .batch import Job, jobs_from_folders, jobs_from_manifest, match_many
from .bench import bench_rows, total_rows
from .datasets import DataError, Pair
from .datasets import load as load_dataset
from .datasets import names as dataset_names
from .io import ImageError, read_disparity, read_image, write_disparity
from .layouts import scan as scan_folder
from .matching import Result, match
from .scoring import score
from .sweep import sweep_rows
from .synth import render as synthetic_pair
from .tiled import TiledResult, match_tiled

try:
    __version__ = version("csw")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0+unknown"

__all__ = ["DataError", "ImageError", "Job", "Pair", "Result", "TiledResult", "bench_rows",
           "dataset_names", "defaults", "jobs_from_folders", "jobs_from_manifest", "kernels",
           "load_dataset", "match", "match_many", "match_tiled", "read_disparity",
           "read_image", "scan_folder", "score", "sweep_rows", "synthetic_pair", "total_rows",
           "write_disparity"]

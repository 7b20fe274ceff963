"""csw: fast stereo matching with the Constrained Sliding Window (CSW) algorithm.

The library under the ``csw`` command: each command calls these functions, with the
same options and defaults (one table: :data:`csw.params.OPTIONS`).

>>> import csw
>>> scene = csw.load_dataset("synthetic")
>>> result = csw.match(scene.left, scene.right, dmax=scene.dmax)
>>> csw.score(result.disparity, scene.gt, scene.masks)["all"]["bad"][1.0] < 10
True

Layout: ``params`` (the options), ``whole`` (csw.match), ``tiled`` (row stripes),
``files`` (csw.match_files, which chooses between them), ``batch`` and ``executor``
(many pairs), ``prepare`` and ``pipeline`` (the stages around ``kernels``), ``io``
(images, formats, atomic writes), ``data`` (datasets, benchmark layouts, the synthetic
scene), ``eval`` (scoring, bench, sweep, histograms, plots).
"""

from importlib.metadata import PackageNotFoundError, version

from . import kernels, params
from .batch import Job, jobs_from_folders, jobs_from_manifest, match_many
from .data.datasets import DataError, Pair
from .data.datasets import load as load_dataset
from .data.datasets import names as dataset_names
from .data.layouts import scan as scan_folder
from .data.synth import render as synthetic_pair
from .eval.bench import bench_rows, run_bench, total_rows
from .eval.scoring import score
from .eval.sweep import sweep_rows
from .files import match_files
from .io import ImageError, read_disparity, read_image, write_disparity
from .params import OptionError
from .tiled import TiledResult, match_tiled
from .whole import Result, match

try:
    __version__ = version("csw")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0+unknown"

__all__ = ["DataError", "ImageError", "Job", "OptionError", "Pair", "Result", "TiledResult",
           "bench_rows", "dataset_names", "jobs_from_folders", "jobs_from_manifest",
           "kernels", "load_dataset", "match", "match_files", "match_many", "match_tiled",
           "params", "read_disparity", "read_image", "run_bench", "scan_folder", "score",
           "sweep_rows", "synthetic_pair", "total_rows", "write_disparity"]

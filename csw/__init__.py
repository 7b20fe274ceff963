"""csw: fast stereo matching with the Constrained Sliding Window (CSW) algorithm.

The library under the ``csw`` command: each command calls these functions, with the
same options and defaults (one table: :data:`csw.config.params.OPTIONS`).

>>> import csw
>>> scene = csw.load_dataset("synthetic")
>>> result = csw.match(scene.left, scene.right, dmax=scene.dmax)
>>> csw.score(result.disparity, scene.gt, scene.masks)["all"]["bad"][1.0] < 10
True

Layout, one folder a concept:
  config/    the option table and presets (params), tau, the paper's settings
  matching/  csw.Matcher and csw.match (matcher), what runs before the first row (setup),
             the stages around the kernels (stages, pipeline), the range found from the pair
             (disparity_range)
  scale/     a pair of files in and its outputs out (files: whole or in stripes), many
             pairs (batch, executor, distributed), pairs in row stripes (tiled), streams
  camera/    calibrations (calibration), depth and point clouds (geometry)
  io/        images, map formats, a pair's outputs (outputs), atomic writes, output safety
  data/      datasets, benchmark layouts, the synthetic scene
  eval/      scoring, bench, sweep, histograms, plots
  kernels/   the compiled kernels (installed from the source tree's top-level kernels/)

Names are imported on first use, so ``import csw`` costs only what a call needs.
"""

import importlib
from typing import TYPE_CHECKING

# Public name -> (module, attribute in it).
_PUBLIC = {
    "Calibration": ("camera.calibration", "Calibration"),
    "DataError": ("data.datasets", "DataError"),
    "ImageError": ("io.images", "ImageError"),
    "Job": ("scale.jobs", "Job"),
    "Matcher": ("matching.matcher", "Matcher"),
    "OptionError": ("config.params", "OptionError"),
    "Pair": ("data.datasets", "Pair"),
    "Rectifier": ("camera.rectify", "Rectifier"),
    "Rig": ("camera.rig", "Rig"),
    "Result": ("matching.matcher", "Result"),
    "TiledResult": ("scale.tiled.run", "TiledResult"),
    "bench_rows": ("eval.bench", "bench_rows"),
    "compile_kernels": ("matching.setup", "compile_kernels"),
    "dataset_names": ("data.datasets", "names"),
    "depth": ("camera.geometry", "depth"),
    "jobs_from_folders": ("scale.jobs", "jobs_from_folders"),
    "jobs_from_manifest": ("scale.jobs", "jobs_from_manifest"),
    "load_dataset": ("data.datasets", "load"),
    "match": ("matching.matcher", "match"),
    "match_files": ("scale.files", "match_files"),
    "match_log": ("scale.stream", "match_log"),
    "match_many": ("scale.batch", "match_many"),
    "match_tiled": ("scale.tiled.run", "match_tiled"),
    "point_cloud": ("camera.geometry", "point_cloud"),
    "read_calibration": ("camera.calibration", "read_calibration"),
    "read_disparity": ("io.formats", "read_disparity"),
    "read_image": ("io.images", "read_image"),
    "read_log": ("robot.logs", "read_log"),
    "read_rig": ("camera.rig", "read_rig"),
    "rectify_files": ("camera.rectify_files", "rectify_files"),
    "run_bench": ("eval.bench", "run_bench"),
    "scan_folder": ("data.layouts", "scan"),
    "score": ("eval.scoring", "score"),
    "sweep_rows": ("eval.sweep", "sweep_rows"),
    "synthetic_pair": ("data.synth", "render"),
    "total_rows": ("eval.bench", "total_rows"),
    "write_disparity": ("io.formats", "write_disparity"),
    "write_ply": ("camera.geometry", "write_ply"),
}
_SUBMODULES = {"camera", "config", "data", "eval", "io", "kernels", "matching", "robot",
               "scale"}

if TYPE_CHECKING:  # what the table above imports on first use, for readers and tools
    from .camera.calibration import Calibration, read_calibration
    from .camera.geometry import depth, point_cloud, write_ply
    from .camera.rectify import Rectifier
    from .camera.rectify_files import rectify_files
    from .camera.rig import Rig, read_rig
    from .config.params import OptionError
    from .data.datasets import DataError, Pair
    from .data.datasets import load as load_dataset
    from .data.datasets import names as dataset_names
    from .data.layouts import scan as scan_folder
    from .data.synth import render as synthetic_pair
    from .eval.bench import bench_rows, run_bench, total_rows
    from .eval.scoring import score
    from .eval.sweep import sweep_rows
    from .io.formats import read_disparity, write_disparity
    from .io.images import ImageError, read_image
    from .matching.matcher import Matcher, Result, match
    from .matching.setup import compile_kernels
    from .robot.logs import read_log
    from .scale.batch import match_many
    from .scale.files import match_files
    from .scale.jobs import Job, jobs_from_folders, jobs_from_manifest
    from .scale.stream import match_log
    from .scale.tiled.run import TiledResult, match_tiled


def __getattr__(name):
    if name in _PUBLIC:
        module, attribute = _PUBLIC[name]
        value = getattr(importlib.import_module(f".{module}", __name__), attribute)
    elif name in _SUBMODULES:
        value = importlib.import_module(f".{name}", __name__)
    elif name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            value = version("csw-stereo")  # the distribution, not the import name
        except PackageNotFoundError:  # a source tree that was not installed
            value = "0.0.0+unknown"
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted([*globals(), *_PUBLIC, *_SUBMODULES])


__all__ = sorted(_PUBLIC)

"""csw: fast stereo matching with the Constrained Sliding Window (CSW) algorithm.

The library under the ``csw`` command: each command calls these functions, with the
same options and defaults (one table: :data:`csw.params.OPTIONS`).

>>> import csw
>>> scene = csw.load_dataset("synthetic")
>>> result = csw.match(scene.left, scene.right, dmax=scene.dmax)
>>> csw.score(result.disparity, scene.gt, scene.masks)["all"]["bad"][1.0] < 10
True

Layout: ``params`` (the options), ``whole`` (csw.Matcher, csw.match), ``tiled`` (row
stripes),
``files`` (csw.match_files, which chooses between them), ``batch`` and ``executor``
(many pairs), ``prepare`` and ``pipeline`` (the stages around ``kernels``), ``io``
(images, formats, atomic writes), ``data`` (datasets, benchmark layouts, the synthetic
scene), ``eval`` (scoring, bench, sweep, histograms, plots).

Names are imported on first use, so ``import csw`` costs only what a call needs.
"""

import importlib

# Public name -> (module, attribute in it).
_PUBLIC = {
    "Calibration": ("calib", "Calibration"),
    "DataError": ("data.datasets", "DataError"),
    "ImageError": ("io.images", "ImageError"),
    "Job": ("batch", "Job"),
    "Matcher": ("whole", "Matcher"),
    "OptionError": ("params", "OptionError"),
    "Pair": ("data.datasets", "Pair"),
    "Result": ("whole", "Result"),
    "TiledResult": ("tiled.run", "TiledResult"),
    "bench_rows": ("eval.bench", "bench_rows"),
    "compile_kernels": ("prepare", "compile_kernels"),
    "dataset_names": ("data.datasets", "names"),
    "depth": ("geometry", "depth"),
    "jobs_from_folders": ("batch", "jobs_from_folders"),
    "jobs_from_manifest": ("batch", "jobs_from_manifest"),
    "load_dataset": ("data.datasets", "load"),
    "match": ("whole", "match"),
    "match_files": ("files", "match_files"),
    "match_many": ("batch", "match_many"),
    "match_tiled": ("tiled.run", "match_tiled"),
    "point_cloud": ("geometry", "point_cloud"),
    "read_calibration": ("calib", "read_calibration"),
    "read_disparity": ("io.formats", "read_disparity"),
    "read_image": ("io.images", "read_image"),
    "run_bench": ("eval.bench", "run_bench"),
    "scan_folder": ("data.layouts", "scan"),
    "score": ("eval.scoring", "score"),
    "sweep_rows": ("eval.sweep", "sweep_rows"),
    "synthetic_pair": ("data.synth", "render"),
    "total_rows": ("eval.bench", "total_rows"),
    "write_disparity": ("io.formats", "write_disparity"),
    "write_ply": ("geometry", "write_ply"),
}
_SUBMODULES = {"autorange", "batch", "calib", "data", "distributed", "eval", "executor",
               "geometry",
               "files", "io", "kernels", "paper", "params", "pipeline", "prepare", "tau",
               "tiled", "whole"}


def __getattr__(name):
    if name in _PUBLIC:
        module, attribute = _PUBLIC[name]
        value = getattr(importlib.import_module(f".{module}", __name__), attribute)
    elif name in _SUBMODULES:
        value = importlib.import_module(f".{name}", __name__)
    elif name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            value = version("csw")
        except PackageNotFoundError:  # a source tree that was not installed
            value = "0.0.0+unknown"
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted([*globals(), *_PUBLIC, *_SUBMODULES])


__all__ = sorted(_PUBLIC)

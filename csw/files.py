"""``csw.match_files``: a pair of image files in, the map and its companions written out.
This is where csw decides how a pair is matched: whole in memory (:mod:`csw.whole`), or in
row stripes (:mod:`csw.tiled`) when asked, when a format needs it, or when the pair would
not fit the memory limit.  Both give the same map, bit for bit.
"""

import os
from pathlib import Path

import numpy as np

from .io.atomic import atomic_write_all
from .io.formats import (
    check_range,
    colorize,
    disparity_writer,
    pfm_writer,
    png_writer,
    suffixes,
)
from .io.images import ImageError, read_image
from .params import OptionError, resolve
from .tiled import match_tiled, too_big_for_whole
from .whole import match

# What each companion output may be, by role (csw.io.formats.suffixes).
COMPANIONS = {"preview": (".png",), "cost_map": (".pfm",), "plot": (".png",)}


def match_files(left, right, output, *, confidence=None, preview=None, cost_map=None,
                memory_limit=None, client=None, progress=False, **options):
    """Match the pair in files ``left`` and ``right`` and write the map to ``output``.

    Parameters
    ----------
    left, right : path
        The images (any format csw reads: PNG, PPM/PGM, TIFF, BMP, JPEG, .npy, .zarr).
    output : path
        The disparity map: .pfm, .npy, .png (d x 256), .tif/.tiff or .zarr.
    confidence, preview, cost_map : path, optional
        Also write the confidence map (a float format), an 8-bit colour PNG of the map,
        and the minimum-cost map (PFM; whole-image matches only).
    memory_limit : int or str, optional
        Match in row stripes that fit this much working memory (see csw.match_tiled).
    client : dask.distributed.Client, optional
        Match in row stripes, as tasks on this cluster.
    progress : bool
        A progress bar over the stripes, on stderr.
    **options
        Matching options, as for :func:`csw.match`.

    Every output is checked before any work, and all of them are written together (all
    or none).  Returns the :class:`csw.Result` of a whole-image match or the
    :class:`csw.TiledResult` of a striped one; both have ``settings``, ``shape``,
    ``stripes`` (None when whole), ``seconds`` and ``invalid_share``.

    Raises
    ------
    ValueError
        Bad options or outputs (an :class:`csw.params.OptionError` naming the argument).
    csw.ImageError
        An input that can't be read (its ``option`` names it: "left" or "right").
    """
    opts = resolve(**options)
    outputs = {"output": output, "confidence": confidence, "preview": preview,
               "cost_map": cost_map}
    check_outputs({"left": left, "right": right}, outputs)
    try:
        check_range(output, opts["dmax"], opts["dmin"])
    except ValueError as exc:
        raise OptionError("dmax", str(exc)) from None
    if _use_stripes(left, right, output, confidence, memory_limit, client, opts):
        if cost_map is not None:
            raise OptionError("cost_map", "the cost map is not written for pairs matched in "
                                          "stripes (a large pair, a memory limit, a "
                                          "cluster, .tif/.zarr)")
        return match_tiled(left, right, output, confidence=confidence, preview=preview,
                           memory_limit=memory_limit, client=client, progress=progress,
                           **options)
    images = [_read(path, name) for name, path in (("left", left), ("right", right))]
    result = match(*images, want_confidence=confidence is not None, **options)
    disp = result.disparity
    writers = [(output, disparity_writer(output, disp))]
    if preview is not None:
        writers.append((preview, png_writer(colorize(disp, opts["dmax"], opts["dmin"]))))
    if cost_map is not None:
        m = np.where(result.min_cost >= 0, result.min_cost, np.inf).astype(np.float32)
        writers.append((cost_map, pfm_writer(m)))
    if confidence is not None:
        writers.append((confidence, pfm_writer(result.confidence)))
    atomic_write_all(writers)
    return result


def _read(path, name):
    try:
        return read_image(path)
    except ImageError as exc:
        exc.option = name
        raise


def _use_stripes(left, right, output, confidence, memory_limit, client, opts):
    """Asked for (a memory limit, a cluster), needed by a format only stripes read or
    write, or a pair whose whole-image match would not fit the default memory limit."""
    if memory_limit is not None or client is not None:
        return True
    whole_outputs = suffixes("whole")
    if Path(output).suffix.lower() not in whole_outputs or \
            (confidence is not None and Path(confidence).suffix.lower() != ".pfm"):
        return True
    if any(Path(p).suffix.lower() not in suffixes("decoded") for p in (left, right)):
        return True
    try:
        return too_big_for_whole(left, opts)
    except ImageError as exc:
        exc.option = "left"
        raise


def check_outputs(inputs, outputs):
    """Before any work: every output (name -> path or None) has a suffix its role allows,
    lies in a folder that exists and can be written, is not a folder (save a zarr store),
    and overwrites neither an input nor another output.  OptionError naming the output."""
    seen = {os.path.realpath(path): name for name, path in inputs.items()}
    for name, path in outputs.items():
        if path is None:
            continue
        path = Path(path)
        allowed = COMPANIONS.get(name) or suffixes("confidence" if name == "confidence"
                                                   else "map")
        if path.suffix.lower() not in allowed:
            raise OptionError(name, f"unknown extension {path.suffix or '(none)'!r}; use "
                                    f"{', '.join(allowed)}")
        folder = path.parent if str(path.parent) else Path(".")
        if not folder.is_dir():
            raise OptionError(name, f"folder {str(folder)!r} does not exist; create it first")
        if not os.access(folder, os.W_OK):
            raise OptionError(name, f"folder {str(folder)!r} is not writable")
        if path.is_dir() and not (path.suffix.lower() == ".zarr" and
                                  (path / "zarr.json").exists()):
            raise OptionError(name, f"{str(path)!r} is a directory")
        key = os.path.realpath(path)
        if key in seen:
            raise OptionError(name, f"{path} is also given as {seen[key]}; an output must "
                                    "not overwrite an input or another output")
        seen[key] = name


"""``csw.match_files``: a pair of image files in, the map and its companions written out.
This is where csw decides how a pair is matched: whole in memory
(:mod:`csw.matching.matcher`), or in row stripes (:mod:`csw.scale.tiled`) when asked, when
a format needs it, or when the pair would not fit the memory limit.  Both give the same
map, bit for bit.
"""

from pathlib import Path

import numpy as np

from .. import kernels
from ..camera import calibration as calib_module
from ..camera.geometry import check_max_depth
from ..camera.geometry import writers as three_d_writers
from ..config.params import OptionError, resolve
from ..io import safety
from ..io.atomic import atomic_write_all
from ..io.formats import (
    check_range,
    disparity_writer,
    pfm_writer,
    png_writer,
    suffixes,
)
from ..io.images import ImageError, read_colour, read_image
from ..io.pictures import disparity_picture
from ..io.sources import open_source
from ..scale.tiled import match_tiled, too_big_for_whole
from . import disparity_range
from .matcher import Matcher

# What each companion output may be, by role (csw.io.formats.suffixes).
COMPANIONS = {"preview": suffixes("picture"), "cost_map": suffixes("costs"),
              "plot": suffixes("picture"), "depth": suffixes("depth"),
              "cloud": suffixes("cloud"), "depth_preview": suffixes("picture"),
              "rectified_left": suffixes("picture")}


# An upper bound of each output's size, per pixel: float maps, a 16-bit PNG map, RGB
# pictures, a PLY's point (3 floats and 3 bytes).  A striped match keeps temporary
# stores of about 8 more beside its map.
BYTES_PER_PIXEL = {"output": 4, "confidence": 4, "preview": 3, "cost_map": 4, "depth": 4,
                   "cloud": 15, "depth_preview": 3, "rectified_left": 3}


def match_files(left, right, output, *, confidence=None, preview=None, cost_map=None,
                calib=None, depth=None, cloud=None, depth_preview=None, max_depth=None,
                units=None, memory_limit=None, client=None, progress=False,
                keep_scratch=False, config=None, rig=None, alpha=0.0, rectified_left=None,
                frame="rectified", **options):
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
    calib : path or csw.Calibration, optional
        The pair's calibration (csw.read_calibration); default: the calib.txt beside the
        left image, if any (Middlebury 2014's layout).  Its ``ndisp`` sets the range when
        the options give no dmax.
    depth, cloud, depth_preview : path, optional
        Also write the depth map (.pfm, .npy, .tif), the point cloud (binary PLY,
        coloured from the left image) and a colour picture of the depth (PNG), from the
        calibration (whole-image matches only).
    max_depth, units : optional
        Leave points farther than max_depth out of the cloud; give depth and points in
        these units ("m", "mm" ...) rather than the calibration's.
    rig : csw.Rig or csw.Rectifier, optional
        The pair is raw, from this calibrated rig: it is rectified first (``alpha`` as
        for csw.Rectifier), matched on the rectified left image's grid, with pixels that
        have no source invalid; the rectified calibration gives depth and clouds.
        ``rectified_left``: also write the rectified left image (PNG).  ``frame``:
        "rectified" (points in the rectified left camera's frame) or "camera" (back in
        the raw left camera's, R1^T).
    memory_limit : int or str, optional
        Match in row stripes that fit this much working memory (see csw.match_tiled).
    client : dask.distributed.Client, optional
        Match in row stripes, as tasks on this cluster.
    progress : bool
        A progress bar over the stripes, on stderr.
    keep_scratch : bool
        Keep this thread's scratch for a next match (a batch), rather than give it back
        before the outputs are written (one pair: a lower peak).
    **options
        Matching options, as for :func:`csw.match`; or ``config``, a
        csw.config.params.Config resolved already (a batch resolves once for all pairs).

    Every output is checked before any work, and all of them are written together (all
    or none).  Returns the :class:`csw.Result` of a whole-image match or the
    :class:`csw.TiledResult` of a striped one; both have ``settings``, ``shape``,
    ``stripes`` (None when whole), ``seconds`` and ``invalid_share``.

    Raises
    ------
    ValueError
        Bad options or outputs (an :class:`csw.config.params.OptionError` naming the argument).
    csw.ImageError
        An input that can't be read (its ``option`` names it: "left" or "right").
    """
    if config is not None and options:
        raise TypeError("give match_files its options or a resolved config, not both")
    # First, and once: a bad option fails before any file is read.
    config = resolve(**options) if config is None else config
    _check_rig_options(rig, calib, frame)
    try:
        shape = open_source(left, "left", probe=False, striped=memory_limit is not None).shape
    except ImageError as exc:
        exc.option = "left"
        raise
    if rig is not None:  # the rig's size against the image's, before its maps are built
        from ..camera.rectify import Rectifier

        try:
            getattr(rig, "rig", rig).check_size((shape[1], shape[0]))
        except ValueError as exc:
            raise OptionError("rig", str(exc)) from None
        rectifier = rig if isinstance(rig, Rectifier) else Rectifier(rig, alpha,
                                                                     config.threads)
    else:
        rectifier = None
    calibration = rectifier.calibration if rectifier else calib_module.resolve(calib, left)
    if calibration is not None:
        calibration.check_size(shape)
    config = disparity_range.decide(config, shape[1], calibration)
    outputs = {"output": output, "confidence": confidence, "preview": preview,
               "cost_map": cost_map, "depth": depth, "cloud": cloud,
               "depth_preview": depth_preview, "rectified_left": rectified_left}
    if rectified_left is not None and rectifier is None:
        raise OptionError("rectified_left", "the rectified left image needs a rig (--rig)")
    rig_files = {f"rig {i + 1}": path for i, path in
                 enumerate(rectifier.rig.paths if rectifier is not None else ())}
    check_pair_outputs({"left": left, "right": right,
                        "calib": calib if isinstance(calib, (str, Path)) else None,
                        **rig_files}, outputs)
    three_d = [name for name in ("depth", "cloud", "depth_preview") if outputs[name]]
    check_max_depth(max_depth)
    striped = _use_stripes(left, right, output, confidence, memory_limit, client, config)
    if striped and rectifier is not None:
        raise OptionError("rig", "a raw pair from a rig is matched whole: drop "
                                 "--memory-limit, --workers and .tif/.zarr outputs")
    safety.check_space((path, shape[0] * shape[1] * BYTES_PER_PIXEL[name]
                        + (8 * shape[0] * shape[1] if striped and name == "output" else 0))
                       for name, path in outputs.items() if path is not None)
    if three_d and calibration is None:
        raise OptionError("calib", f"the {three_d[0].replace('_', ' ')} needs the pair's "
                                   "calibration: give one (a calib.txt, KITTI calib, "
                                   "OpenCV Q, or the focal length and baseline)")
    try:
        check_range(output, config.dmax, config.dmin)
    except ValueError as exc:
        raise OptionError("dmax", str(exc)) from None
    if striped:
        for name in ("cost_map", *three_d):
            if outputs[name] is not None:
                raise OptionError(name, f"the {name.replace('_', ' ')} is not written for "
                                        "pairs matched in stripes (a large pair, a memory "
                                        "limit, a cluster, .tif/.zarr)")
        result = match_tiled(left, right, output, confidence=confidence, preview=preview,
                             memory_limit=memory_limit, client=client, progress=progress,
                             config=config)
        return _noted(result, calibration)
    images = [_read(path, name) for name, path in (("left", left), ("right", right))]
    if rectifier is not None:
        images = rectifier.rectify(*images)
    result = Matcher(pixels=None, config=config).match(*images, confidence is not None)
    if rectifier is not None:
        rectifier.invalidate(result.disparity)
    # One pair: its outputs are written next, and scratch kept for a next match would
    # only raise this process's peak memory (a batch keeps it: csw.scale.batch).
    if not keep_scratch:
        kernels.workspace.for_this_thread().release()
    disp = result.disparity
    writers = [(output, disparity_writer(output, disp))]
    if preview is not None:
        used = result.settings
        writers.append((preview, png_writer(disparity_picture(disp, used["dmin"],
                                                              used["dmax"]))))
    if cost_map is not None:
        m = np.where(result.min_cost >= 0, result.min_cost, np.inf).astype(np.float32)
        writers.append((cost_map, pfm_writer(m)))
    if confidence is not None:
        writers.append((confidence, pfm_writer(result.confidence)))
    colours = read_colour(left) if cloud is not None or rectified_left is not None \
        else None
    if rectifier is not None and colours is not None:
        colours = rectifier.rectify_one(colours, 0)
        if rectified_left is not None:
            writers.append((rectified_left, png_writer(colours)))
    if three_d:
        rotation = rectifier.r1.T if rectifier is not None and frame == "camera" else None
        writers += three_d_writers(disp, calibration, depth, cloud, depth_preview, colours,
                                   max_depth, units, rotation)
    atomic_write_all(writers)
    return _noted(result, calibration)


def _check_rig_options(rig, calib, frame):
    """The options around a rig, before any file is read."""
    if frame not in ("rectified", "camera"):
        raise OptionError("frame", f"frame must be 'rectified' or 'camera', got {frame!r}")
    if rig is not None and calib is not None:
        raise OptionError("calib", "a rig gives the rectified pair's calibration: drop "
                                   "--calib (or --rig)")


def _noted(result, calibration):
    """The result, its settings saying which calibration the pair had."""
    result.settings["calibration"] = calibration.describe() if calibration else None
    return result


def _read(path, name):
    try:
        return read_image(path)
    except ImageError as exc:
        exc.option = name
        raise


def _use_stripes(left, right, output, confidence, memory_limit, client, config):
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
        return too_big_for_whole(left, config)
    except ImageError as exc:
        exc.option = "left"
        raise


def role_suffixes(role):
    """The suffixes an output of ``role`` may have: a companion's (COMPANIONS), a
    confidence map's float formats, else the map formats."""
    return COMPANIONS.get(role) or suffixes("confidence" if role == "confidence" else "map")


def check_pair_outputs(inputs, outputs):
    """Before any work: csw.io.safety.check_outputs with each output's suffixes by its
    role (role_suffixes)."""
    safety.check_outputs(inputs, outputs, {name: role_suffixes(name) for name in outputs})

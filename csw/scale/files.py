"""``csw.match_files``: a pair of image files in, the map and its companions written out.
This is where csw decides how a pair is matched: whole in memory
(:mod:`csw.matching.matcher`), or in row stripes (:mod:`csw.scale.tiled`) when asked, when
a format needs it, or when the pair would not fit the memory limit.  Both give the same
map, bit for bit.  It sits in csw.scale, above both ways; a pair's outputs are checked
and written by csw.io.outputs.PairOutputs, as a batch's, a stripe plan's and a stream's.
"""

from pathlib import Path

from .. import kernels
from ..camera import calibration as calib_module
from ..camera.geometry import check_max_depth
from ..camera.geometry import writers as three_d_writers
from ..config.params import OptionError
from ..io.formats import png_writer, suffixes
from ..io.images import ImageError, read_colour, read_image
from ..io.outputs import PairOutputs
from ..io.sources import open_source
from ..matching import disparity_range
from ..matching.matcher import Matcher, resolved
from .tiled import match_tiled, too_big_for_whole


def match_files(left, right, output, *, confidence=None, preview=None, cost_map=None,
                calib=None, depth=None, cloud=None, depth_preview=None, max_depth=None,
                units=None, memory_limit=None, client=None, progress=False,
                keep_scratch=False, config=None, rig=None, alpha=0.0, rectified_left=None,
                frame="rectified", matcher=None, **options):
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
    matcher : csw.Matcher, optional
        Match a whole pair with this Matcher (a batch's, made once, whose set-ups are
        kept from pair to pair), its config the one given.
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
    # First, and once: a bad option fails before any file is read.
    config = resolved(config, options, "match_files")
    _check_rig_options(rig, calib, frame)
    try:
        shape = open_source(left, "left", probe=False, striped=memory_limit is not None,
                            can_stripe=True).shape
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
    paths = {"output": output, "confidence": confidence, "preview": preview,
             "cost_map": cost_map, "depth": depth, "cloud": cloud,
             "depth_preview": depth_preview, "rectified_left": rectified_left}
    if rectified_left is not None and rectifier is None:
        raise OptionError("rectified_left", "the rectified left image needs a rig (--rig)")
    rig_files = {f"rig {i + 1}": path for i, path in
                 enumerate(rectifier.rig.paths if rectifier is not None else ())}
    outputs = PairOutputs(paths, {"left": left, "right": right,
                                  "calib": calib if isinstance(calib, (str, Path)) else None,
                                  **rig_files})
    outputs.check_paths()
    three_d = [name for name in ("depth", "cloud", "depth_preview") if name in outputs]
    check_max_depth(max_depth)
    # The range as far as it is known before the pixels (None: found from the pair);
    # it is decided once, in the match's set-up.
    known = disparity_range.known_range(config, shape[1], calibration)
    striped = _use_stripes(left, right, output, confidence, memory_limit, client,
                           disparity_range.assumed_range(config, shape[1], calibration))
    if striped and rectifier is not None:
        raise OptionError("rig", "a raw pair from a rig is matched whole: drop "
                                 "--memory-limit, --workers and .tif/.zarr outputs")
    outputs.check_space(shape, striped)
    if three_d and calibration is None:
        raise OptionError("calib", f"the {three_d[0].replace('_', ' ')} needs the pair's "
                                   "calibration: give one (a calib.txt, KITTI calib, "
                                   "OpenCV Q, or the focal length and baseline)")
    outputs.check_range(known)
    if striped:
        for name in ("cost_map", *three_d):
            if name in outputs:
                raise OptionError(name, f"the {name.replace('_', ' ')} is not written for "
                                        "pairs matched in stripes (a large pair, a memory "
                                        "limit, a cluster, .tif/.zarr)")
        result = match_tiled(left, right, output, confidence=confidence, preview=preview,
                             memory_limit=memory_limit, client=client, progress=progress,
                             config=config, outputs=outputs, calibration=calibration)
        return _noted(result, calibration)
    images = [_read(path, name) for name, path in (("left", left), ("right", right))]
    if rectifier is not None:
        images = rectifier.rectify(*images)
    matcher = matcher or Matcher(pixels=None, config=config)
    result = matcher.match(*images, confidence is not None, calibration=calibration)
    if rectifier is not None:
        rectifier.invalidate(result.disparity)
    # One pair: its outputs are written next, and scratch kept for a next match would
    # only raise this process's peak memory (a batch keeps it: csw.scale.batch).
    if not keep_scratch:
        kernels.workspace.for_this_thread().release()
    disp = result.disparity
    outputs.add_map(disp)
    outputs.add_preview(disp, result.settings["dmin"], result.settings["dmax"])
    outputs.add_cost_map(result.min_cost)
    outputs.add_float_map("confidence", result.confidence)
    colours = read_colour(left) if cloud is not None or rectified_left is not None \
        else None
    if rectifier is not None and colours is not None:
        colours = rectifier.rectify_one(colours, 0)
        if rectified_left is not None:
            outputs.add("rectified_left", png_writer(colours))
    if three_d:
        rotation = rectifier.r1.T if rectifier is not None and frame == "camera" else None
        outputs.add_items(three_d_writers(disp, calibration, depth, cloud, depth_preview,
                                          colours, max_depth, units, rotation))
    outputs.write()
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


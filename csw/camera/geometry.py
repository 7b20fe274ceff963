"""From disparity to 3-D: depth maps, point clouds as binary PLY, and a depth preview.

Depth is Z = f B / (d + doffs) in the calibration's units (csw.camera.calibration); points are
OpenCV's reprojection, [X Y Z W] = Q [x y d 1] (x right, y down, z forward, in the left
camera's frame), so they equal cv2.reprojectImageTo3D's for the same Q.
"""

import math
from pathlib import Path

import numpy as np

from ..config.params import OptionError
from ..io.formats import as_float_disparity, suffixes


def _homogeneous(disparity, calib):
    """(X, Y, Z, W) of every pixel, float64 (H, W) each, and the valid pixels: a finite
    disparity whose W is positive (the point lies in front of the cameras)."""
    disp = as_float_disparity(disparity)
    calib.check_size(disp.shape)
    q = calib.matrix(disp.shape)
    y, x = np.indices(disp.shape, dtype=np.float64)
    d = np.nan_to_num(disp)
    out = [q[i, 0] * x + q[i, 1] * y + q[i, 2] * d + q[i, 3] for i in range(4)]
    with np.errstate(divide="ignore", invalid="ignore"):
        valid = np.isfinite(disp) & (out[3] * np.sign(q[2, 3]) > 0)
    if not valid.any() and np.isfinite(disp).any():
        raise OptionError("calib", f"{calib.source}: with it no disparity of the map gives "
                                   "a point in front of the cameras (d + doffs is never "
                                   f"positive: focal {calib.focal:g}, baseline "
                                   f"{calib.baseline:g}, doffs {calib.doffs:g}); check the "
                                   "calibration's signs and that it is this pair's")
    return out, valid


def check_max_depth(max_depth):
    """ValueError unless max_depth is None or a positive finite number."""
    if max_depth is not None and not (isinstance(max_depth, (int, float, np.number))
                                      and math.isfinite(max_depth) and max_depth > 0):
        raise OptionError("max_depth", f"max_depth must be a positive finite number, got "
                                       f"{max_depth!r}")


def depth(disparity, calib, units=None):
    """The depth map of ``disparity`` (float or int, any of csw's conventions) with a
    csw.camera.calibration.Calibration: float32 (H, W), Z = f B / (d + doffs), in the calibration's
    units or ``units`` ("m", "mm" ...); NaN where the disparity is invalid or the point
    would not lie in front of the cameras (d + doffs <= 0)."""
    scale = calib.scale_to(units)
    (_, _, z, w), valid = _homogeneous(disparity, calib)
    out = np.full(z.shape, np.nan, np.float32)
    with np.errstate(over="ignore"):  # a point too far for float32 is inf: invalid
        out[valid] = (z[valid] / w[valid] * scale).astype(np.float32)
    return out


def point_cloud(disparity, calib, image=None, max_depth=None, units=None, rotation=None):
    """The 3-D points of the valid pixels, row by row: (points float32 (N, 3), colours
    uint8 (N, 3) or None).  image: the left image (H, W) gray or (H, W, 3|4) colour,
    8 or 16 bits, for the colours.  max_depth: drop points farther than this (in the
    output's units).  rotation: (3, 3) applied to every point (a rectified camera's
    points back in its raw frame: R1^T).  Pixels with no valid disparity, or behind the
    cameras, are left out."""
    check_max_depth(max_depth)
    scale = calib.scale_to(units)
    (x, y, z, w), valid = _homogeneous(disparity, calib)
    if max_depth is not None:
        with np.errstate(divide="ignore", invalid="ignore"):
            valid &= z / w * scale <= max_depth
    points = np.stack([x[valid], y[valid], z[valid]], axis=1) / w[valid][:, None] * scale
    if rotation is not None:
        points = points @ np.asarray(rotation, np.float64).T
    with np.errstate(over="ignore"):  # as depth's
        return points.astype(np.float32), _colours(image, valid)


def _colours(image, valid):
    if image is None:
        return None
    image = np.asarray(image)
    if image.shape[:2] != valid.shape:
        raise OptionError("image", f"the image is {image.shape[1]}x{image.shape[0]} but "
                                   f"the disparity map is {valid.shape[1]}x{valid.shape[0]}")
    if image.dtype == np.uint16:
        image = (image >> 8).astype(np.uint8)
    if image.dtype != np.uint8:
        raise OptionError("image", f"the image must be 8- or 16-bit, got {image.dtype}")
    if image.ndim == 2:
        image = np.repeat(image[..., None], 3, axis=2)
    return np.ascontiguousarray(image[..., :3][valid])


def ply_writer(points, colours=None):
    """A ``write_to(tmp)`` for a binary little-endian PLY: float32 x, y, z per vertex,
    and uchar red, green, blue where colours are given."""
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if colours is not None:
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    vertices = np.empty(len(points), fields)
    for i, axis in enumerate("xyz"):
        vertices[axis] = points[:, i]
    if colours is not None:
        for i, channel in enumerate(("red", "green", "blue")):
            vertices[channel] = colours[:, i]
    properties = "".join(f"property {'float' if t == '<f4' else 'uchar'} {name}\n"
                         for name, t in fields)
    header = (f"ply\nformat binary_little_endian 1.0\ncomment written by csw\n"
              f"element vertex {len(points)}\n{properties}end_header\n").encode("ascii")

    def write(tmp):
        with open(tmp, "wb") as f:
            f.write(header)
            f.write(vertices.tobytes())
    return write


def write_ply(path, points, colours=None):
    """Write a point cloud as binary PLY, atomically (see ply_writer)."""
    from ..io.atomic import atomic_write

    atomic_write(path, ply_writer(points, colours))


def preview(depth_map, units=None):
    """uint8 (H + bar, W, 3): the depth map in Turbo, near red and far blue, over its 1st
    to 99th percentile, invalid black, with a colour bar of depths in ``units``
    (csw.io.pictures.depth_picture)."""
    from ..io.pictures import depth_picture

    return depth_picture(depth_map, units)


DEPTH_SUFFIXES = suffixes("depth")  # float maps written whole
CLOUD_SUFFIXES = suffixes("cloud")


def writers(disparity, calib, depth_path=None, cloud_path=None, preview_path=None,
            image=None, max_depth=None, units=None, rotation=None):
    """(path, write_to) for each 3-D output asked for, to be written together with the
    map (csw.io.atomic.atomic_write_all): the depth map (DEPTH_SUFFIXES), its preview
    (PNG) and the point cloud (PLY, coloured from ``image`` where given)."""
    items = []
    if depth_path is not None or preview_path is not None:
        items += _depth_writers(depth(disparity, calib, units), depth_path, preview_path,
                                units or calib.units)
    if cloud_path is not None:
        points, colours = point_cloud(disparity, calib, image, max_depth, units, rotation)
        items.append((Path(cloud_path), ply_writer(points, colours)))
    return items


def _depth_writers(z, depth_path, preview_path, units=None):
    """(path, write_to) of the depth map z (in ``units``, None: unknown) and of its
    preview, where asked for."""
    from ..io.formats import float_map_writer, png_writer

    items = []
    if depth_path is not None:
        items.append((Path(depth_path), float_map_writer(depth_path, z)))
    if preview_path is not None:
        items.append((Path(preview_path), png_writer(preview(z, units))))
    return items


def depth_file(disparity, output, calib, units=None, preview_path=None):
    """Read a disparity map file, write its depth map (and preview), atomically; returns
    the depth map (float32, NaN invalid).  calib: a csw.Calibration."""
    from ..io.atomic import atomic_write_all
    from ..io.formats import read_disparity

    z = depth(read_disparity(disparity), calib, units)
    atomic_write_all(_depth_writers(z, output, preview_path, units or calib.units))
    return z


def cloud_file(disparity, output, calib, image=None, max_depth=None, units=None):
    """Read a disparity map file (and the left image, for colours), write the point cloud
    as binary PLY, atomically; returns the number of points."""
    from ..io.formats import read_disparity
    from ..io.images import ImageError, read_colour

    disp = read_disparity(disparity)
    if image is not None:
        try:
            image = read_colour(image)
        except ImageError as exc:
            exc.option = "image"  # the error is the image's, not the disparity map's
            raise
    points, colours = point_cloud(disp, calib, image, max_depth, units)
    write_ply(output, points, colours)
    return len(points)

"""Resampling a raw image through undistort-rectify maps (csw.camera.rectify): bilinear,
in parallel stripes of rows, with a mask of the pixels that have a source in the raw
image.  The worker is kernels/jit/remap.py."""

from dataclasses import dataclass

import numpy as np

from . import native, runtime
from .catalogue import entry

# About 4 ns a pixel in one thread (four gathers), in runtime.DIRECT_WORK's units.
REMAP_WORK = 20
FIXED_WORK = 10  # about 2 ns a pixel


@dataclass(frozen=True)
class FixedMaps:
    """Undistort-rectify maps made once into what the remap reads (OpenCV's fixed point):
    offset uint32 (H, W), the flat index in the raw image of the top-left of the four
    pixels blended; weights uint16 (H, W), wx | wy << 6, the point's fraction in 1/32 of
    a pixel (0..32: a point on the image's last column or row takes the pixel before it
    with weight 0 and itself with 32); valid uint8 (H, W), 1 where the map points inside
    the raw image; raw: the raw image's (h, w)."""

    offset: np.ndarray
    weights: np.ndarray
    valid: np.ndarray
    raw: tuple


def fixed_maps(map_x, map_y, raw, threads=None):
    """The FixedMaps of float64 or float32 (H, W) maps (csw.camera.rectify.rectify_maps)
    for raw images of shape ``raw`` (h, w), each at least 2 x 2: the point rounded to
    1/32 pixel as OpenCV rounds (float32 maps as cv2.remap, float64 ones as
    initUndistortRectifyMap's fixed-point maps)."""
    height, width = raw
    if height < 2 or width < 2:
        raise ValueError(f"a raw image must be at least 2x2 to resample, got {width}x{height}")
    map_x = np.ascontiguousarray(map_x, np.float64)
    map_y = np.ascontiguousarray(map_y, np.float64)
    if map_x.shape != map_y.shape or map_x.ndim != 2:
        raise ValueError(f"the maps must be two (H, W) arrays of one shape, got "
                         f"{map_x.shape} and {map_y.shape}")
    shape = map_x.shape
    out = FixedMaps(np.empty(shape, np.uint32), np.empty(shape, np.uint16),
                    np.empty(shape, np.uint8), (height, width))
    run = native.entry(*entry("remap", "fixed"))
    work = map_x.size * FIXED_WORK
    count = 1 if work < runtime.DIRECT_WORK else min(runtime.thread_count(threads),
                                                     shape[0])
    edges = runtime.even_split(shape[0], count)
    runtime.run_stripes(
        lambda i, stop: run(map_x=map_x, map_y=map_y, offset=out.offset,
                            weights=out.weights, valid=out.valid, y0=edges[i],
                            y1=edges[i + 1], width=width, height=height),
        count, count, work)
    return out


def remap(image, map_x, map_y, threads=None, out=None):
    """(rectified, valid): ``image`` (uint8 or uint16 (h, w)) sampled at (map_x, map_y)
    (float32 (H, W) each, in the raw image's pixels, or ``map_x`` a FixedMaps made once
    by :func:`fixed_maps` and ``map_y`` None) by bilinear interpolation in OpenCV's fixed
    point (the point to 1/32 pixel, integer weights), rounded; valid: bool (H, W), where
    the map points inside the raw image (elsewhere the value is 0).  out: an (H, W) array
    of the image's type to write into, else a new one.  threads: as for csw.match."""
    image = np.ascontiguousarray(image)
    if image.ndim != 2 or image.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"remap takes a uint8 or uint16 (H, W) image, got {image.dtype} "
                         f"{image.shape}")
    fixed = map_x if isinstance(map_x, FixedMaps) else fixed_maps(map_x, map_y, image.shape)
    if fixed.raw != image.shape:
        raise ValueError(f"the maps are for {fixed.raw[1]}x{fixed.raw[0]} images, not "
                         f"{image.shape[1]}x{image.shape[0]}")
    shape = fixed.offset.shape
    out = np.empty(shape, image.dtype) if out is None else out
    if out.shape != shape or out.dtype != image.dtype or not out.flags.c_contiguous:
        raise ValueError("out must be a C-contiguous (H, W) array of the image's type")
    run = native.entry(*entry("remap", image.dtype))
    height = shape[0]
    work = out.size * REMAP_WORK
    count = 1 if work < runtime.DIRECT_WORK else min(runtime.thread_count(threads), height)
    edges = runtime.even_split(height, count)
    flat = image.reshape(-1)

    def stripe(i, stop):
        return run(image=flat, offset=fixed.offset, weights=fixed.weights,
                   valid=fixed.valid, out=out, y0=edges[i], y1=edges[i + 1],
                   width=image.shape[1])

    runtime.run_stripes(stripe, count, count, work)
    return out, fixed.valid.view(np.bool_)


# About 10 ns a pixel in one thread: a division, the distortion's polynomials.
MAPS_WORK = 40


def undistort_rectify_maps(inverse, camera, distortion, size, threads=None):
    """(map_x, map_y), float64 (H, W) each, for a (width, height) ``size``: for each
    rectified pixel (u, v), where it comes from in the raw image of a pinhole camera
    (``camera`` (3, 3), ``distortion`` (8,) k1 k2 p1 p2 k3 k4 k5 k6), ``inverse`` (3, 3)
    being (P R)^-1 (csw.camera.rectify.rectify_maps validates and calls it)."""
    width, height = size
    map_x = np.empty((height, width), np.float64)
    map_y = np.empty((height, width), np.float64)
    arrays = dict(inverse=np.ascontiguousarray(inverse, np.float64),
                  camera=np.ascontiguousarray(camera, np.float64),
                  distortion=np.ascontiguousarray(distortion, np.float64),
                  map_x=map_x, map_y=map_y)
    run = native.entry(*entry("remap", "maps"))
    work = width * height * MAPS_WORK
    count = 1 if work < runtime.DIRECT_WORK else min(runtime.thread_count(threads), height)
    edges = runtime.even_split(height, count)
    runtime.run_stripes(lambda i, stop: run(**arrays, y0=edges[i], y1=edges[i + 1]), count,
                        count, work)
    return map_x, map_y

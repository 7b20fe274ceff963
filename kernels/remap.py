"""Resampling a raw image through undistort-rectify maps (csw.camera.rectify): bilinear,
in parallel stripes of rows, with a mask of the pixels that have a source in the raw
image.  The worker is kernels/jit/remap.py."""

import numpy as np

from . import native, runtime
from .contract import dtype_name

# About 6 ns a pixel in one thread (four gathers), in runtime.DIRECT_WORK's units.
REMAP_WORK = 30


def entries(pixels=None):
    """The (kernel, variant) entries a remap of images of type ``pixels`` loads (None:
    the maps' builder)."""
    return [("remap", ("maps",) if pixels is None else ("remap", dtype_name(pixels)))]


def remap(image, map_x, map_y, threads=None, out=None, valid=None):
    """(rectified, valid): ``image`` (uint8 or uint16 (h, w)) sampled at (map_x, map_y)
    (float32 (H, W) each, in the raw image's pixels) by bilinear interpolation in
    OpenCV's fixed point (the point to 1/32 pixel, integer weights), rounded;
    valid: bool (H, W), where the map points inside the raw image (elsewhere the value is
    0).  out (H, W) of the image's type and valid uint8 (H, W): arrays of the caller's to
    write into, else new ones.  threads: as for csw.match."""
    image = np.ascontiguousarray(image)
    if image.ndim != 2 or image.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"remap takes a uint8 or uint16 (H, W) image, got {image.dtype} "
                         f"{image.shape}")
    map_x = np.ascontiguousarray(map_x, np.float32)
    map_y = np.ascontiguousarray(map_y, np.float32)
    if map_x.shape != map_y.shape or map_x.ndim != 2:
        raise ValueError(f"the maps must be two (H, W) arrays of one shape, got "
                         f"{map_x.shape} and {map_y.shape}")
    shape = map_x.shape
    out = np.empty(shape, image.dtype) if out is None else out
    mask = np.empty(shape, np.uint8) if valid is None else valid
    if out.shape != shape or out.dtype != image.dtype or mask.shape != shape or \
            mask.dtype != np.uint8 or not (out.flags.c_contiguous and mask.flags.c_contiguous):
        raise ValueError("out and valid must be C-contiguous (H, W) arrays of the image's "
                         "type and uint8")
    run = native.entry(*entries(image.dtype)[0])
    height = shape[0]
    work = map_x.size * REMAP_WORK
    count = 1 if work < runtime.DIRECT_WORK else min(runtime.thread_count(threads), height)
    edges = runtime.even_split(height, count)

    def stripe(i, stop):
        return run(image=image, map_x=map_x, map_y=map_y, out=out, valid=mask,
                   y0=edges[i], y1=edges[i + 1])

    runtime.run_stripes(stripe, count, count, work)
    return out, mask.view(np.bool_)


# About 10 ns a pixel in one thread: a division, the distortion's polynomials.
MAPS_WORK = 40


def undistort_rectify_maps(inverse, camera, distortion, size, threads=None):
    """(map_x, map_y), float32 (H, W) each, for a (width, height) ``size``: for each
    rectified pixel (u, v), where it comes from in the raw image of a pinhole camera
    (``camera`` (3, 3), ``distortion`` (8,) k1 k2 p1 p2 k3 k4 k5 k6), ``inverse`` (3, 3)
    being (P R)^-1 (csw.camera.rectify.rectify_maps validates and calls it)."""
    width, height = size
    map_x = np.empty((height, width), np.float32)
    map_y = np.empty((height, width), np.float32)
    arrays = dict(inverse=np.ascontiguousarray(inverse, np.float64),
                  camera=np.ascontiguousarray(camera, np.float64),
                  distortion=np.ascontiguousarray(distortion, np.float64),
                  map_x=map_x, map_y=map_y)
    run = native.entry(*entries()[0])
    work = width * height * MAPS_WORK
    count = 1 if work < runtime.DIRECT_WORK else min(runtime.thread_count(threads), height)
    edges = runtime.even_split(height, count)
    runtime.run_stripes(lambda i, stop: run(**arrays, y0=edges[i], y1=edges[i + 1]), count,
                        count, work)
    return map_x, map_y

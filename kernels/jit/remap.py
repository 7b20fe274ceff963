"""The remap's workers (see kernels/remap.py): the undistort-rectify maps of a pinhole
camera (plumb bob or rational distortion), and the bilinear resampling through them in
fixed point (the maps made once into source offsets and integer weights)."""

import numpy as np
from numba import njit

from ..signature import Signature, Spec, arg, scalar_index
from .common import dtype_of
from .options import SERIAL

# The scalars of a stripe of rows (the entries' records; see kernels/signature.py):
# width is the raw image's.
SC = scalar_index(("y0", "y1", "width"))
MAPS = scalar_index(("y0", "y1"))
FIXED = scalar_index(("y0", "y1", "width", "height"))


def spec(kind, pixels=None):
    """The worker of ``kind``: "remap" for images of type ``pixels`` (uint8 or uint16),
    "maps", or "fixed" (float maps into offsets and weights)."""
    if kind == "fixed":
        arrays = (arg("map_x", np.float64, 2), arg("map_y", np.float64, 2),
                  arg("offset", np.uint32, 2), arg("weights", np.uint16, 2),
                  arg("valid", np.uint8, 2))
        return Spec(fixed, Signature(arrays, FIXED._fields))
    if kind == "maps":
        # inverse (3, 3) of P R; camera (3, 3) K; distortion (8,) k1 k2 p1 p2 k3 k4 k5 k6
        arrays = (arg("inverse", np.float64, 2), arg("camera", np.float64, 2),
                  arg("distortion", np.float64, 1), arg("map_x", np.float64, 2),
                  arg("map_y", np.float64, 2))
        return Spec(maps, Signature(arrays, MAPS._fields))
    image = dtype_of(pixels)
    arrays = (arg("image", image, 1), arg("offset", np.uint32, 2),
              arg("weights", np.uint16, 2), arg("valid", np.uint8, 2), arg("out", image, 2))
    return Spec(rows, Signature(arrays, SC._fields))


@njit(**SERIAL)
def rows(image, offset, weights, valid, out, sc):
    """Rows y0 <= y < y1 of ``out`` (sc: SC): the bilinear blend of the four raw pixels
    at image[offset], image[offset + 1] and the two below them (a row, w, further), with
    the weights (32 - wx, wx) across and (32 - wy, wy) down, rounded half up; 0 where
    ``valid`` is 0.  image: the raw image flat, (h * w,); offset: uint32 (H, W); weights:
    uint16 (H, W), wx | wy << 6; valid: uint8 (H, W) (kernels/remap.py's fixed maps)."""
    width = np.uint64(sc[SC.width])
    one = np.uint64(1)
    for row in range(sc[SC.y0], sc[SC.y1]):
        y = np.uint64(row)
        for column in range(out.shape[1]):
            x = np.uint64(column)
            # Unsigned indices: Numba skips its wrap-around test for negative ones; the
            # fixed maps keep every index inside the image.
            o = np.uint64(offset[y, x])
            w = np.int32(weights[y, x])
            wx, wy = w & 63, w >> 6
            upper = np.int32(image[o]) * (32 - wx) + np.int32(image[o + one]) * wx
            lower = np.int32(image[o + width]) * (32 - wx) + \
                np.int32(image[o + width + one]) * wx
            out[y, x] = ((upper * (32 - wy) + lower * wy + 512) >> 10) * np.int32(valid[y, x])
    return 0


@njit(**SERIAL)
def maps(inverse, camera, distortion, map_x, map_y, sc):
    """Rows y0 <= v < y1 of the maps (sc: MAPS): for rectified pixel (u, v), the ray
    inverse @ (u, v, 1), through the lens (distortion), through the camera matrix: where
    it lies in the raw image (cv2.initUndistortRectifyMap's formula)."""
    k1, k2, p1, p2 = distortion[0], distortion[1], distortion[2], distortion[3]
    k3, k4, k5, k6 = distortion[4], distortion[5], distortion[6], distortion[7]
    fx, skew, cx = camera[0, 0], camera[0, 1], camera[0, 2]
    fy, cy = camera[1, 1], camera[1, 2]
    for v in range(sc[MAPS.y0], sc[MAPS.y1]):
        xs = inverse[0, 1] * v + inverse[0, 2]
        ys = inverse[1, 1] * v + inverse[1, 2]
        ws = inverse[2, 1] * v + inverse[2, 2]
        for u in range(map_x.shape[1]):
            w = 1.0 / (ws + inverse[2, 0] * u)
            x = (xs + inverse[0, 0] * u) * w
            y = (ys + inverse[1, 0] * u) * w
            x2, y2 = x * x, y * y
            r2 = x2 + y2
            xy2 = 2.0 * x * y
            radial = (1.0 + ((k3 * r2 + k2) * r2 + k1) * r2) / \
                (1.0 + ((k6 * r2 + k5) * r2 + k4) * r2)
            xd = x * radial + p1 * xy2 + p2 * (r2 + 2.0 * x2)
            yd = y * radial + p1 * (r2 + 2.0 * y2) + p2 * xy2
            map_x[v, u] = fx * xd + skew * yd + cx
            map_y[v, u] = fy * yd + cy
    return 0


@njit(**SERIAL)
def fixed(map_x, map_y, offset, weights, valid, sc):
    """Rows y0 <= y < y1 of the fixed maps of float64 maps (sc: FIXED; width, height:
    the raw image's, each at least 2): valid where the point is inside the raw image; the
    point rounded to 1/32 pixel as OpenCV rounds (cvRound: to the nearest, halves to
    even; from the maps' doubles, as initUndistortRectifyMap makes its CV_16SC2 maps, and
    exact for float32 maps, as cv2.remap rounds them); offset the flat index of the
    top-left pixel blended, kept one short of the last column and row (a point on them
    then takes weight 32 on the next pixel); weights wx | wy << 6."""
    width, height = sc[FIXED.width], sc[FIXED.height]
    top_x, top_y = np.float64(width - 1), np.float64(height - 1)
    for y in range(sc[FIXED.y0], sc[FIXED.y1]):
        for x in range(map_x.shape[1]):
            sx, sy = map_x[y, x], map_y[y, x]
            inside = 0.0 <= sx <= top_x and 0.0 <= sy <= top_y  # NaN: outside
            ix = np.int64(np.rint(sx * 32.0)) if inside else 0
            iy = np.int64(np.rint(sy * 32.0)) if inside else 0
            x0 = min(ix >> 5, width - 2)
            y0 = min(iy >> 5, height - 2)
            offset[y, x] = np.uint32(y0 * width + x0)
            weights[y, x] = np.uint16((ix - x0 * 32) | ((iy - y0 * 32) << 6))
            valid[y, x] = 1 if inside else 0
    return 0

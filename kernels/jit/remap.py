"""The remap's workers (see kernels/remap.py): the undistort-rectify maps of a pinhole
camera (plumb bob or rational distortion), and the bilinear resampling through them,
whose output pixels are valid where the map points inside the raw image, so that pixels
with no source are never matched as black."""

import numpy as np
from numba import njit

from ..config import SERIAL
from ..signature import Signature, Spec, arg, scalar_index
from .common import dtype_of

# The scalars of a stripe of rows (the entries' records; see kernels/signature.py).
SC = scalar_index(("y0", "y1"))


def spec(kind, pixels=None):
    """The worker of ``kind``: "remap" for images of type ``pixels`` (uint8 or uint16),
    or "maps"."""
    if kind == "maps":
        # inverse (3, 3) of P R; camera (3, 3) K; distortion (8,) k1 k2 p1 p2 k3 k4 k5 k6
        arrays = (arg("inverse", np.float64, 2), arg("camera", np.float64, 2),
                  arg("distortion", np.float64, 1), arg("map_x", np.float32, 2),
                  arg("map_y", np.float32, 2))
        return Spec(maps, Signature(arrays, SC._fields))
    image = dtype_of(pixels)
    arrays = (arg("image", image, 2), arg("map_x", np.float32, 2),
              arg("map_y", np.float32, 2), arg("out", image, 2), arg("valid", np.uint8, 2))
    return Spec(rows, Signature(arrays, SC._fields))


# The sampling point's fraction in 1/TAB of a pixel, and the weights' product in
# 1/TAB^2, as OpenCV's remap (INTER_TAB_SIZE = 32): integer arithmetic throughout.
TAB, SHIFT = 32, 5


@njit(**SERIAL)
def rows(image, map_x, map_y, out, valid, sc):
    """Rows y0 <= y < y1 of ``out`` and ``valid`` (sc: SC).  image: (h, w) raw; map_x,
    map_y: float32 (H, W), where each output pixel comes from; out: (H, W) of the image's
    type, the bilinear value at the point rounded to 1/32 pixel, with integer weights,
    rounded half up (0 where invalid); valid: uint8 (H, W), 1 where 0 <= map_x <= w - 1
    and 0 <= map_y <= h - 1."""
    height, width = image.shape
    top_x, top_y = np.float32(width - 1), np.float32(height - 1)
    # Unsigned indices: Numba then skips its wrap-around test for negative ones, a third
    # of the time here; every index below is inside the arrays by construction.
    one, shift, mask = np.uint64(1), np.uint64(SHIFT), np.uint64(TAB - 1)
    last_x, last_y = np.uint64(width - 1), np.uint64(height - 1)
    for row in range(sc[SC.y0], sc[SC.y1]):
        y = np.uint64(row)
        for column in range(out.shape[1]):
            x = np.uint64(column)
            sx, sy = map_x[y, x], map_y[y, x]
            if not (0.0 <= sx <= top_x and 0.0 <= sy <= top_y):  # NaN too
                out[y, x] = 0
                valid[y, x] = 0
                continue
            ix = np.uint64(sx * np.float32(TAB) + np.float32(0.5))
            iy = np.uint64(sy * np.float32(TAB) + np.float32(0.5))
            x0, y0 = ix >> shift, iy >> shift
            wx, wy = np.int32(ix & mask), np.int32(iy & mask)
            x1 = x0 + one if x0 < last_x else x0
            y1 = y0 + one if y0 < last_y else y0
            upper = np.int32(image[y0, x0]) * (TAB - wx) + np.int32(image[y0, x1]) * wx
            lower = np.int32(image[y1, x0]) * (TAB - wx) + np.int32(image[y1, x1]) * wx
            out[y, x] = (upper * (TAB - wy) + lower * wy + TAB * TAB // 2) >> (2 * SHIFT)
            valid[y, x] = 1
    return 0


@njit(**SERIAL)
def maps(inverse, camera, distortion, map_x, map_y, sc):
    """Rows y0 <= v < y1 of the maps (sc: SC): for rectified pixel (u, v), the ray
    inverse @ (u, v, 1), through the lens (distortion), through the camera matrix: where
    it lies in the raw image (cv2.initUndistortRectifyMap's formula)."""
    k1, k2, p1, p2 = distortion[0], distortion[1], distortion[2], distortion[3]
    k3, k4, k5, k6 = distortion[4], distortion[5], distortion[6], distortion[7]
    fx, skew, cx = camera[0, 0], camera[0, 1], camera[0, 2]
    fy, cy = camera[1, 1], camera[1, 2]
    for v in range(sc[SC.y0], sc[SC.y1]):
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
            map_x[v, u] = np.float32(fx * xd + skew * yd + cx)
            map_y[v, u] = np.float32(fy * yd + cy)
    return 0

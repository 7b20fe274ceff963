"""Post filters on disparity maps that have no library equivalent: speckle removal over
regions of similar disparity (as OpenCV's filterSpeckles), a median over valid pixels
only, and the background fill of the Middlebury and KITTI evaluation kits.

Maps are float32 (H, W) with NaN where invalid.  Each function is a per-map worker with
no checks; csw.pipeline validates and calls them.
"""

import numpy as np
from numba import njit, prange

from .config import PARALLEL, SERIAL


@njit(**SERIAL)
def speckle_mask(disp, max_size, max_diff):
    """bool (H, W): True for valid pixels in regions of fewer than ``max_size`` pixels,
    where a region is a 4-connected set of valid pixels whose neighbours differ by at
    most ``max_diff``.  One flood fill per region, a stack of (H * W,) int64 scratch."""
    height, width = disp.shape
    label = np.full((height, width), -1, np.int64)
    small = np.zeros((height, width), np.bool_)
    stack = np.empty(height * width, np.int64)
    members = np.empty(height * width, np.int64)
    regions = 0
    for start in range(height * width):
        y0, x0 = start // width, start % width
        if label[y0, x0] >= 0 or np.isnan(disp[y0, x0]):
            continue
        label[y0, x0] = regions
        top, count = 1, 0
        stack[0] = start
        while top > 0:
            top -= 1
            p = stack[top]
            members[count] = p
            count += 1
            y, x = p // width, p % width
            for dy, dx in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                yy, xx = y + dy, x + dx
                if 0 <= yy < height and 0 <= xx < width and label[yy, xx] < 0:
                    v = disp[yy, xx]
                    if not np.isnan(v) and abs(v - disp[y, x]) <= max_diff:
                        label[yy, xx] = regions
                        stack[top] = yy * width + xx
                        top += 1
        if count < max_size:
            for i in range(count):
                small[members[i] // width, members[i] % width] = True
        regions += 1
    return small


@njit(**PARALLEL)
def median_valid(disp, size):
    """float32 (H, W): each valid pixel becomes the median of the valid pixels in its
    size x size window (the lower middle for an even count); invalid pixels stay NaN."""
    height, width = disp.shape
    h = size // 2
    out = np.full((height, width), np.nan, np.float32)
    for y in prange(height):
        window = np.empty(size * size, np.float32)
        for x in range(width):
            if np.isnan(disp[y, x]):
                continue
            n = 0
            for yy in range(max(y - h, 0), min(y + h + 1, height)):
                for xx in range(max(x - h, 0), min(x + h + 1, width)):
                    v = disp[yy, xx]
                    if not np.isnan(v):
                        window[n] = v
                        n += 1
            values = np.sort(window[:n])
            out[y, x] = values[(n - 1) // 2]
    return out


@njit(**PARALLEL)
def fill_background(disp):
    """float32 (H, W) with no invalid pixel: along each row, an invalid pixel takes the
    smaller of the nearest valid disparities to its left and right (the background side);
    at a row's end, the one valid neighbour; a row with none becomes 0 (the KITTI
    devkit's interpolation, used by the Middlebury kit for sparse results too)."""
    height, width = disp.shape
    out = disp.copy()
    for y in prange(height):
        last = np.nan  # the nearest valid value to the left
        x = 0
        while x < width:
            if not np.isnan(disp[y, x]):
                last = disp[y, x]
                x += 1
                continue
            end = x
            while end < width and np.isnan(disp[y, end]):
                end += 1
            right = disp[y, end] if end < width else np.nan
            if np.isnan(last) and np.isnan(right):
                value = 0.0
            elif np.isnan(last):
                value = right
            elif np.isnan(right):
                value = last
            else:
                value = min(last, right)
            for i in range(x, end):
                out[y, i] = value
            x = end
    return out


@njit(**PARALLEL)
def lr_consistent(disp, right_disp, limit):
    """bool (H, W): d = disp[y, x] is valid (>= 0) and its right pixel's own match,
    right_disp[y, x - d] (-1: none), differs from it by at most ``limit``.

    disp, right_disp: int32 (H, W)."""
    height, width = disp.shape
    out = np.zeros((height, width), np.bool_)
    for y in prange(height):
        for x in range(width):
            d = disp[y, x]
            if d >= 0:
                back = right_disp[y, x - d]
                out[y, x] = back >= 0 and abs(d - back) <= limit
    return out

"""The OpenCV peers the reports measure csw against, built in one place so that every
report runs the same StereoBM and SGBM with the same settings (issue 40 item 7).

OpenCV's matchers return 16 x d in int16, negative for invalid; :func:`float_map` turns
that into csw's float map (NaN invalid) so csw's own scoring applies to them alike.
Both need a number of disparities that is a multiple of 16 (:func:`ndisp16`).
"""

import sys

import numpy as np

try:
    import cv2
except ImportError:
    sys.exit("the peer reports need OpenCV: pip install '.[bench]'")

# OpenCV's stereo_match sample for a gray pair (cn = 1, block 5): P1 = 8 * cn * block^2,
# P2 = 32 * cn * block^2, its prefilter cap, uniqueness, speckle and left-right settings.
# These reproduce issue 41's SGBM figures (without the cap of 63, OpenCV's 15 gives
# KITTI 80.8 / 5.34 / 15.17 against 80.5 / 4.92 / 14.73).
SGBM_SAMPLE = dict(block=5, P1=8 * 25, P2=32 * 25, preFilterCap=63, uniquenessRatio=10,
                   speckleWindowSize=100, speckleRange=32, disp12MaxDiff=1)


def ndisp16(dmax):
    """The number of disparities covering 0..dmax, rounded up to a multiple of 16."""
    return -(-(dmax + 1) // 16) * 16


# StereoBM with its own filters on, as a robot user sets it (issue 42): its default
# uniqueness ratio (15), prefilter and texture threshold, plus its speckle filter (windows
# under 100 pixels, steps of 32 / 16 = 2 px) and its left-right check (disp12MaxDiff 1),
# which its defaults leave off.
BM_FILTERS = dict(uniquenessRatio=15, speckleWindowSize=100, speckleRange=32,
                  disp12MaxDiff=1)


def stereo_bm(ndisp, block=9, filters=True):
    """StereoBM; filters=False turns off its texture and uniqueness tests, "all" turns
    on its speckle filter and left-right check as well (:data:`BM_FILTERS`)."""
    bm = cv2.StereoBM_create(numDisparities=ndisp, blockSize=block)
    if not filters:
        bm.setTextureThreshold(0)
        bm.setUniquenessRatio(0)
    if filters == "all":
        bm.setUniquenessRatio(BM_FILTERS["uniquenessRatio"])
        bm.setSpeckleWindowSize(BM_FILTERS["speckleWindowSize"])
        bm.setSpeckleRange(BM_FILTERS["speckleRange"])
        bm.setDisp12MaxDiff(BM_FILTERS["disp12MaxDiff"])
    return bm


def sgbm(ndisp, block=5, P1=None, P2=None, **settings):  # noqa: N803 (OpenCV's names)
    """StereoSGBM (MODE_SGBM); P1 and P2 default to OpenCV's documented 8 and 32 x
    block^2; ``settings`` are StereoSGBM_create's other keywords."""
    return cv2.StereoSGBM_create(0, ndisp, block, P1=8 * block * block if P1 is None else P1,
                                 P2=32 * block * block if P2 is None else P2, **settings)


def sgbm_sample(ndisp):
    """SGBM with the settings of OpenCV's stereo_match sample (:data:`SGBM_SAMPLE`)."""
    return sgbm(ndisp, **SGBM_SAMPLE)


def float_map(raw):
    """OpenCV's int16 16 x d (negative invalid) as float32 d, NaN invalid."""
    disp = raw.astype(np.float32) / 16
    disp[raw < 0] = np.nan
    return disp


def whole_map(raw):
    """OpenCV's int16 16 x d as int32 whole disparities (nearest), -1 invalid: the
    kernels' map format."""
    disp = raw.astype(np.int32)
    return np.where(disp >= 0, (disp + 8) // 16, -1)


def as_function(matcher):
    """A peer as a function (left, right) -> float map, NaN invalid."""
    return lambda left, right: float_map(matcher.compute(left, right))

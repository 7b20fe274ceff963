"""A calibrated rig's raw pairs rectified: :class:`Rectifier` (the rectification and the
undistort-rectify maps made once, each pair resampled by the remap kernel).  The maths
(Bouguet's method, distortion, the maps) is csw.camera.rectification's; the files and
folders of ``csw rectify``, csw.camera.rectify_files'.
"""

import numpy as np

from .calibration import rectified_calibration
from .rectification import (  # noqa: F401 (callers' and tests' names for the maths)
    fisheye_rectify_maps,
    fisheye_stereo_rectify,
    rectification,
    rectify_maps,
    rodrigues,
    stereo_rectify,
    undistort_points,
)


class Rectifier:
    """Rectifies a rig's raw pairs: the rectification computed once (or taken from the
    rig's file as given, so that it equals the calibrator's own), the undistort-rectify
    maps built once, and each pair resampled by the remap kernel.

    >>> rect = csw.Rectifier(csw.read_rig("stereo.yml"), alpha=0)
    >>> left_r, right_r = rect.rectify(left, right)       # raw (H, W) uint8/uint16
    >>> rect.valid                                         # bool (H, W) each: has a source
    >>> rect.calibration                                   # for csw.depth, csw.point_cloud

    alpha: 0 (the default, as ROS's calibrator) keeps only pixels with a source, no black
    border; 1 keeps every raw pixel; between, in proportion (for a fisheye rig, OpenCV's
    "balance").  Ignored when the rig's file gives the rectification.  threads: as for
    csw.match.
    """

    def __init__(self, rig, alpha=0.0, threads=None):
        if not (isinstance(alpha, (int, float)) and -1 <= alpha <= 1):
            raise ValueError(f"alpha must be a number from 0 to 1 (or -1: no scaling), got "
                             f"{alpha!r}")
        from ..io.images import check_pixels

        # The maps take 12 bytes a pixel: a rig's declared size is held to the images'
        # pixel limit before they are built.
        check_pixels(rig.size[::-1], rig.source)
        self.rig, self.alpha, self.threads = rig, alpha, threads
        fisheye = rig.model == "equidistant"
        r1, r2, p1, p2 = rectification(rig, alpha)
        for which, r, p in (("left", r1, p1), ("right", r2, p2)):
            # The maps invert P x R: a file's matrices may be anything (zeros, 1e300).
            with np.errstate(all="ignore"):
                product = np.asarray(p, np.float64)[:3, :3] @ np.asarray(r, np.float64)
            finite = np.isfinite(product).all()
            if not finite or np.linalg.matrix_rank(product) < 3:
                raise ValueError(f"{rig.source}: the {which} camera's rectification (P x R) "
                                 f"is {'singular' if finite else 'not finite'}; check the "
                                 "rig's R1/R2 and P1/P2")
        self.r1, self.r2, self.p1, self.p2 = r1, r2, p1, p2
        from ..kernels.remap import fixed_maps

        width, height = rig.size
        # Only the fixed-point maps are kept: the float ones are a step to them, in double
        # precision, rounded to 1/32 pixel as OpenCV's fixed-point maps are.
        self.fixed = tuple(
            fixed_maps(*(fisheye_rectify_maps(k, d, rr, p, rig.size, np.float64) if fisheye
                         else rectify_maps(k, d, rr, p, rig.size, threads, np.float64)),
                       (height, width), threads)
            for k, d, rr, p in ((rig.k1, rig.d1, r1, p1), (rig.k2, rig.d2, r2, p2)))
        self.valid = tuple(f.valid.view(np.bool_) for f in self.fixed)
        if not all(v.any() for v in self.valid):  # only black images would follow
            raise ValueError(f"{rig.source}: no pixel of the rectified images has a source "
                             "in the raw ones; check the rig (its size, R and T) and alpha")
        self._all_valid = tuple(bool(v.all()) for v in self.valid)
        self.calibration = rectified_calibration(rig, p1, p2)

    def rectify(self, left, right):
        """(left_r, right_r): a raw pair (uint8/uint16, gray (H, W) or colour (H, W, C),
        the rig's size) rectified; pixels without a source are 0 (see ``valid``)."""
        out = []
        for which, (image, name) in enumerate(((left, "left"), (right, "right"))):
            try:
                out.append(self.rectify_one(image, which))
            except ValueError as exc:
                raise ValueError(f"the {name} {str(exc)[4:]}") from None
        return tuple(out)

    def rectify_one(self, image, which):
        """One raw image (``which``: 0 left, 1 right) rectified, as :meth:`rectify`."""
        image = np.asarray(image)
        width, height = self.rig.size
        if image.shape[:2] != (height, width):
            raise ValueError(f"the image is {image.shape[1]}x{image.shape[0]} but "
                             f"{self.rig.source} is for {width}x{height} images")
        return self.remap(image, self.fixed[which])

    def invalidate(self, disparity):
        """Make NaN, in place, the disparities (float32 (H, W), the rectified left's grid)
        of left pixels without a source, or whose match in the right image has none."""
        valid_left, valid_right = self.valid
        if not self._all_valid[0]:
            disparity[~valid_left] = np.nan
        if self._all_valid[1]:  # alpha 0: every rectified pixel has a source
            return
        height, width = disparity.shape
        found = np.isfinite(disparity)
        y, x = np.nonzero(found)
        column = np.round(x - disparity[found]).astype(np.int64)
        inside = (column >= 0) & (column < width)
        has_source = np.zeros(y.size, bool)
        has_source[inside] = valid_right[y[inside], column[inside]]
        disparity[y[~has_source], x[~has_source]] = np.nan

    def remap(self, image, fixed):
        from ..kernels.remap import remap

        if image.ndim == 2:
            return remap(image, fixed, None, self.threads)[0]
        return np.stack([remap(np.ascontiguousarray(image[..., c]), fixed, None,
                               self.threads)[0] for c in range(image.shape[2])], axis=2)

    def calib_text(self):
        """The rectified pair's calibration as a Middlebury calib.txt (baseline in mm where
        the rig says its units, else in its own), for ``csw match`` beside the images.
        Its ``units=`` line (mm, or none: a key Middlebury's files don't have, which csw's
        reader honours) keeps a rig without units from being read as mm."""
        from .calibration import UNITS

        c = self.calibration
        scale = UNITS[c.units] / UNITS["mm"] if c.units else 1.0
        cam = f"[{c.focal:.10g} 0 {c.cx:.10g}; 0 {c.focal:.10g} {c.cy:.10g}; 0 0 1]"
        cam1 = f"[{c.focal:.10g} 0 {c.cx + c.doffs:.10g}; 0 {c.focal:.10g} {c.cy:.10g}; 0 0 1]"
        return (f"cam0={cam}\ncam1={cam1}\ndoffs={c.doffs:.10g}\n"
                f"baseline={c.baseline * scale:.10g}\nwidth={c.width}\nheight={c.height}\n"
                f"units={'mm' if c.units else 'none'}\n")

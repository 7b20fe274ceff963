"""Rectification of a calibrated stereo rig, in NumPy: Bouguet's method as OpenCV's
``stereoRectify`` computes it (zero disparity at infinity), lens distortion and its
inverse, and the undistort-rectify maps (``initUndistortRectifyMap``) that the remap
kernel (kernels/remap.py) resamples raw images with.

Conventions are OpenCV's: R and T take a point from the left camera's frame to the
right's (X_right = R X_left + T); distortion coefficients are (k1, k2, p1, p2[, k3[, k4,
k5, k6]]) (plumb bob / radtan, rational), extra zero terms allowed.
"""

import math

import numpy as np

# Iterations of the inverse distortion, as OpenCV's undistortPoints' default criteria.
UNDISTORT_ITERATIONS = 5
RECTANGLE_GRID = 9  # points per side of the grid that bounds the valid region


def rodrigues(vector_or_matrix):
    """The rotation matrix of a rotation vector (3,), or the vector of a matrix (3, 3)."""
    a = np.asarray(vector_or_matrix, np.float64)
    if a.shape == (3, 3):
        cos = np.clip((np.trace(a) - 1) / 2, -1.0, 1.0)
        angle = math.acos(cos)
        axis = np.array([a[2, 1] - a[1, 2], a[0, 2] - a[2, 0], a[1, 0] - a[0, 1]])
        if angle < 1e-12:
            return axis / 2
        sin = math.sin(angle)
        if sin > 1e-6:
            return axis * (angle / (2 * sin))
        # near pi: from the diagonal
        v = np.sqrt(np.clip((np.diag(a) + 1) / 2, 0, None))
        v[1] = math.copysign(v[1], a[0, 1] + a[1, 0]) if v[0] else v[1]
        v[2] = math.copysign(v[2], a[0, 2] + a[2, 0]) if v[0] else \
            math.copysign(v[2], a[1, 2] + a[2, 1])
        return v * angle
    angle = float(np.linalg.norm(a))
    if angle < 1e-300:
        return np.eye(3)
    k = a / angle
    cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * cross + (1 - math.cos(angle)) * cross @ cross


def coefficients(distortion):
    """The 8 coefficients (k1, k2, p1, p2, k3, k4, k5, k6) of an OpenCV distortion vector
    (4, 5, 8, 12 or 14 of them; the thin-prism and tilt terms of the longer ones must be
    zero).  ValueError otherwise."""
    d = np.asarray(distortion, np.float64).ravel()
    if d.size not in (0, 4, 5, 8, 12, 14):
        raise ValueError(f"a distortion vector holds 4, 5, 8, 12 or 14 coefficients, not "
                         f"{d.size}")
    if d.size > 8 and np.any(d[8:] != 0):
        raise ValueError("thin-prism and tilt distortion terms (coefficients 9 to 14) are "
                         "not supported; they must be 0")
    out = np.zeros(8)
    out[:min(d.size, 8)] = d[:8]
    return out


def distort(x, y, d):
    """Normalised image coordinates through the lens: (x, y) arrays, d the 8
    coefficients."""
    k1, k2, p1, p2, k3, k4, k5, k6 = d
    r2 = x * x + y * y
    radial = (1 + ((k3 * r2 + k2) * r2 + k1) * r2) / (1 + ((k6 * r2 + k5) * r2 + k4) * r2)
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return xd, yd


def undistort_points(points, k, distortion, r=None, p=None):
    """Pixels (n, 2) of a camera (k (3, 3), distortion) to the ideal camera: normalised
    coordinates, or rotated by ``r`` and projected by ``p`` (3x3 or 3x4) when given, as
    OpenCV's undistortPoints (its fixed 5 iterations)."""
    pts = np.asarray(points, np.float64).reshape(-1, 2)
    d = coefficients(distortion)
    fx, fy, cx, cy, skew = k[0, 0], k[1, 1], k[0, 2], k[1, 2], k[0, 1]
    y = (pts[:, 1] - cy) / fy
    x = (pts[:, 0] - cx - skew * y) / fx
    x0, y0 = x.copy(), y.copy()
    if np.any(d):
        k1, k2, p1, p2, k3, k4, k5, k6 = d
        stopped = np.zeros(x.shape, bool)
        for _ in range(UNDISTORT_ITERATIONS):
            r2 = x * x + y * y
            icdist = (1 + ((k6 * r2 + k5) * r2 + k4) * r2) / \
                (1 + ((k3 * r2 + k2) * r2 + k1) * r2)
            # Where the model folds over, OpenCV gives up on the point for good and keeps
            # its distorted coordinates.
            stopped |= icdist < 0
            dx = 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
            dy = p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
            x = np.where(stopped, x0, (x0 - dx) * icdist)
            y = np.where(stopped, y0, (y0 - dy) * icdist)
    rr = np.eye(3) if r is None else np.asarray(r, np.float64)
    if p is not None:
        rr = np.asarray(p, np.float64)[:3, :3] @ rr
    xx = rr[0, 0] * x + rr[0, 1] * y + rr[0, 2]
    yy = rr[1, 0] * x + rr[1, 1] * y + rr[1, 2]
    ww = 1.0 / (rr[2, 0] * x + rr[2, 1] * y + rr[2, 2])
    return np.stack([xx * ww, yy * ww], axis=1)


def _rectangles(k, distortion, r, p, size):
    """(inner, outer) rectangles (x0, y0, x1, y1) of the rectified image that the raw
    image's pixels cover: inside the grid's edges, and around all of them."""
    width, height = size
    n = RECTANGLE_GRID
    grid = np.array([(x * (width - 1) / (n - 1), y * (height - 1) / (n - 1))
                     for y in range(n) for x in range(n)], np.float64)
    pts = undistort_points(grid, k, distortion, r, p).reshape(n, n, 2)
    inner = (pts[:, 0, 0].max(), pts[0, :, 1].max(), pts[:, -1, 0].min(), pts[-1, :, 1].min())
    outer = (pts[..., 0].min(), pts[..., 1].min(), pts[..., 0].max(), pts[..., 1].max())
    return [float(v) for v in inner], [float(v) for v in outer]


def stereo_rectify(k1, d1, k2, d2, size, r, t, alpha=0.0):
    """Bouguet's rectification with zero disparity at infinity, as cv2.stereoRectify(...,
    flags=cv2.CALIB_ZERO_DISPARITY, alpha=alpha): (R1, R2, P1, P2, Q), float64.

    k1, k2: (3, 3) camera matrices; d1, d2: distortion vectors; size: (width, height);
    r (3, 3), t (3,): from the left camera to the right.  alpha: 0 keeps only valid
    pixels, 1 every source pixel, between them in proportion; negative: no scaling."""
    k1, k2, r = (np.asarray(a, np.float64) for a in (k1, k2, r))
    t = np.asarray(t, np.float64).reshape(3)
    width, height = size
    om = rodrigues(r) * -0.5  # half the rotation for each camera
    r_r = rodrigues(om)
    tt = r_r @ t
    idx = 0 if abs(tt[0]) > abs(tt[1]) else 1
    c = tt[idx]
    nt = float(np.linalg.norm(tt))
    if not nt > 0:
        raise ValueError("the rig's translation is zero: no baseline")
    uu = np.zeros(3)
    uu[idx] = 1.0 if c > 0 else -1.0
    ww = np.cross(tt, uu)
    nw = float(np.linalg.norm(ww))
    if nw > 0:
        ww *= math.acos(abs(c) / nt) / nw
    w_r = rodrigues(ww)
    r1 = w_r @ r_r.T
    r2 = w_r @ r_r
    tt = r2 @ t
    ratio = 0.5  # the new image size is the old
    fc_new = (k1[idx ^ 1, idx ^ 1] + k2[idx ^ 1, idx ^ 1]) * ratio
    centres = []
    for k, d, rk in ((k1, d1, r1), (k2, d2, r2)):
        corners = np.array([[0, 0], [width - 1, 0], [0, height - 1],
                            [width - 1, height - 1]], np.float32)
        ideal = undistort_points(corners, k, d).astype(np.float32)
        rays = np.column_stack([ideal, np.ones(4, np.float32)]).astype(np.float64) @ rk.T
        projected = (fc_new * rays[:, :2] / rays[:, 2:3]).astype(np.float32)
        avg = projected.astype(np.float64).mean(axis=0)
        centres.append([(width - 1) / 2 - avg[0], (height - 1) / 2 - avg[1]])
    cx = (centres[0][0] + centres[1][0]) * 0.5
    cy = (centres[0][1] + centres[1][1]) * 0.5
    p1 = np.array([[fc_new, 0, cx, 0], [0, fc_new, cy, 0], [0, 0, 1, 0]], np.float64)
    p2 = p1.copy()
    p2[idx, 3] = tt[idx] * fc_new
    if alpha >= 0:
        alpha = min(alpha, 1.0)
        scales_in, scales_out = [], []
        for k, d, rk, pk in ((k1, d1, r1, p1), (k2, d2, r2, p2)):
            (ix0, iy0, ix1, iy1), (ox0, oy0, ox1, oy1) = _rectangles(k, d, rk, pk, size)
            scales_in += [cx / (cx - ix0), cy / (cy - iy0), (width - 1 - cx) / (ix1 - cx),
                          (height - 1 - cy) / (iy1 - cy)]
            scales_out += [cx / (cx - ox0), cy / (cy - oy0), (width - 1 - cx) / (ox1 - cx),
                           (height - 1 - cy) / (oy1 - cy)]
        s = max(scales_in) * (1 - alpha) + min(scales_out) * alpha
        fc_new *= s
        for p in (p1, p2):
            p[0, 0] = p[1, 1] = fc_new
        p2[idx, 3] *= s
    q = np.array([[1, 0, 0, -cx], [0, 1, 0, -cy], [0, 0, 0, fc_new],
                  [0, 0, -1 / tt[idx], 0]], np.float64)
    if idx == 1:  # a vertical rig: the baseline along y
        q[3, 3] = 0.0
    return r1, r2, p1, p2, q


# ------------------------------------------------------------------ fisheye (equidistant)

FISHEYE_ITERATIONS, FISHEYE_EPS = 10, 1e-8  # cv2.fisheye.undistortPoints' defaults


def fisheye_undistort_points(points, k, distortion, r=None, p=None):
    """Pixels (n, 2) of an equidistant fisheye camera (k (3, 3), distortion k1..k4) to
    the ideal camera, rotated by ``r`` and projected by ``p`` when given, as
    cv2.fisheye.undistortPoints (Newton's method on theta); points it can't undistort
    come out at (-1e6, -1e6), as OpenCV's."""
    pts = np.asarray(points, np.float64).reshape(-1, 2)
    k1, k2, k3, k4 = np.asarray(distortion, np.float64).ravel()
    x = (pts[:, 0] - k[0, 2]) / k[0, 0]
    y = (pts[:, 1] - k[1, 2]) / k[1, 1]
    rr = np.eye(3) if r is None else np.asarray(r, np.float64)
    if p is not None:
        rr = np.asarray(p, np.float64)[:3, :3] @ rr
    out = np.full((len(pts), 2), -1e6)
    for i in range(len(pts)):
        theta_d = min(max(-math.pi / 2, math.hypot(x[i], y[i])), math.pi / 2)
        theta, converged, scale = theta_d, False, 0.0
        if abs(theta_d) > FISHEYE_EPS:
            for _ in range(FISHEYE_ITERATIONS):
                t2 = theta * theta
                t4, t6, t8 = t2 * t2, t2 * t2 * t2, t2 * t2 * t2 * t2
                fix = (theta * (1 + k1 * t2 + k2 * t4 + k3 * t6 + k4 * t8) - theta_d) / \
                    (1 + 3 * k1 * t2 + 5 * k2 * t4 + 7 * k3 * t6 + 9 * k4 * t8)
                theta -= fix
                if abs(fix) < FISHEYE_EPS:
                    converged = True
                    break
            scale = math.tan(theta) / theta_d
        else:
            converged = True
        flipped = (theta_d < 0 < theta) or (theta < 0 < theta_d)
        if converged and not flipped:
            u, v = x[i] * scale, y[i] * scale
            w = rr[2, 0] * u + rr[2, 1] * v + rr[2, 2]
            out[i] = ((rr[0, 0] * u + rr[0, 1] * v + rr[0, 2]) / w,
                      (rr[1, 0] * u + rr[1, 1] * v + rr[1, 2]) / w)
    return out


def _fisheye_new_camera(k, distortion, size, r, balance, fov_scale=1.0):
    """The rectified camera matrix cv2.fisheye.estimateNewCameraMatrixForUndistortRectify
    gives (balance 0: only valid pixels, 1: every pixel kept)."""
    width, height = size
    balance = min(max(balance, 0.0), 1.0)
    pts = fisheye_undistort_points([(width // 2, 0), (width, height // 2),
                                    (width // 2, height), (0, height // 2)], k, distortion, r)
    centre = pts.mean(axis=0)
    aspect = k[0, 0] / k[1, 1]  # y scaled to x's focal length, centre and points alike
    centre[1] *= aspect
    pts[:, 1] *= aspect
    (min_x, min_y), (max_x, max_y) = pts.min(axis=0), pts.max(axis=0)
    focals = (width * 0.5 / (centre[0] - min_x), width * 0.5 / (max_x - centre[0]),
              height * 0.5 * aspect / (centre[1] - min_y),
              height * 0.5 * aspect / (max_y - centre[1]))
    f = balance * min(focals) + (1.0 - balance) * max(focals)
    f *= 1.0 / fov_scale if fov_scale > 0 else 1.0
    cx = -centre[0] * f + width * 0.5
    cy = (-centre[1] * f + height * aspect * 0.5) / aspect
    return np.array([[f, 0, cx], [0, f / aspect, cy], [0, 0, 1]])


def fisheye_stereo_rectify(k1, d1, k2, d2, size, r, t, balance=0.0):
    """As cv2.fisheye.stereoRectify(..., flags=cv2.CALIB_ZERO_DISPARITY, balance=balance):
    (R1, R2, P1, P2, Q), float64, for an equidistant fisheye rig."""
    k1, k2, r = (np.asarray(a, np.float64) for a in (k1, k2, r))
    t = np.asarray(t, np.float64).reshape(3)
    r_r = rodrigues(rodrigues(r) * -0.5)
    tt = r_r @ t
    uu = np.array([1.0 if tt[0] > 0 else -1.0, 0, 0])
    ww = np.cross(tt, uu)
    nw = float(np.linalg.norm(ww))
    if nw > 0:
        ww *= math.acos(abs(tt[0]) / np.linalg.norm(tt)) / nw
    w_r = rodrigues(ww)
    r1, r2 = w_r @ r_r.T, w_r @ r_r
    tnew = r2 @ t
    new1 = _fisheye_new_camera(k1, d1, size, r1, balance)
    new2 = _fisheye_new_camera(k2, d2, size, r2, balance)
    fc = min(new1[1, 1], new2[1, 1])
    cx = (new1[0, 2] + new2[0, 2]) * 0.5
    cy = (new1[1, 2] + new2[1, 2]) * 0.5
    p1 = np.array([[fc, 0, cx, 0], [0, fc, cy, 0], [0, 0, 1, 0]])
    p2 = p1.copy()
    p2[0, 3] = tnew[0] * fc
    q = np.array([[1, 0, 0, -cx], [0, 1, 0, -cy], [0, 0, 0, fc], [0, 0, -1 / tnew[0], 0]])
    return r1, r2, p1, p2, q


def fisheye_rectify_maps(k, distortion, r, p, size):
    """(map_x, map_y), float32 (H, W), as cv2.fisheye.initUndistortRectifyMap (CV_32FC1)."""
    width, height = size
    k = np.asarray(k, np.float64)
    k1, k2, k3, k4 = np.asarray(distortion, np.float64).ravel()
    inverse = np.linalg.inv(np.asarray(p, np.float64)[:3, :3] @ np.asarray(r, np.float64))
    u, v = np.meshgrid(np.arange(width, dtype=np.float64),
                       np.arange(height, dtype=np.float64))
    w = inverse[2, 0] * u + inverse[2, 1] * v + inverse[2, 2]
    x = (inverse[0, 0] * u + inverse[0, 1] * v + inverse[0, 2]) / w
    y = (inverse[1, 0] * u + inverse[1, 1] * v + inverse[1, 2]) / w
    radius = np.hypot(x, y)
    theta = np.arctan(radius)
    t2 = theta * theta
    theta_d = theta * (1 + k1 * t2 + k2 * t2 ** 2 + k3 * t2 ** 3 + k4 * t2 ** 4)
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(radius == 0, 1.0, theta_d / radius)
    map_x = k[0, 0] * x * scale + k[0, 2]
    map_y = k[1, 1] * y * scale + k[1, 2]
    return map_x.astype(np.float32), map_y.astype(np.float32)


def rectify_maps(k, distortion, r, p, size, threads=None):
    """(map_x, map_y), float32 (H, W) each: for every pixel of the rectified image, where
    it comes from in the raw image (cv2.initUndistortRectifyMap's maps, CV_32FC1; built
    by the kernel csw.kernels.remap.undistort_rectify_maps).

    k (3, 3), distortion: the raw camera; r (3, 3): its rectifying rotation; p (3, 3) or
    (3, 4): the rectified camera; size: (width, height) of the rectified image."""
    from ..kernels.remap import undistort_rectify_maps

    inverse = np.linalg.inv(np.asarray(p, np.float64)[:3, :3] @ np.asarray(r, np.float64))
    return undistort_rectify_maps(inverse, np.asarray(k, np.float64),
                                  coefficients(distortion), size, threads)


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
        from .calibration import Calibration

        if not (isinstance(alpha, (int, float)) and -1 <= alpha <= 1):
            raise ValueError(f"alpha must be a number from 0 to 1 (or -1: no scaling), got "
                             f"{alpha!r}")
        from ..io.images import check_pixels

        # The maps take 12 bytes a pixel: a rig's declared size is held to the images'
        # pixel limit before they are built.
        check_pixels(rig.size[::-1], rig.source)
        self.rig, self.alpha, self.threads = rig, alpha, threads
        fisheye = rig.model == "equidistant"
        if rig.rectification is not None:
            r1, r2, p1, p2 = (np.asarray(m, np.float64) for m in rig.rectification)
        else:
            solve = fisheye_stereo_rectify if fisheye else stereo_rectify
            r1, r2, p1, p2, _ = solve(rig.k1, rig.d1, rig.k2, rig.d2, rig.size, rig.r,
                                      rig.t, max(alpha, 0.0) if fisheye else alpha)
        self.r1, self.r2, self.p1, self.p2 = r1, r2, p1, p2
        from ..kernels.remap import fixed_maps

        width, height = rig.size
        # Only the fixed-point maps are kept: the float ones are a step to them.
        self.fixed = tuple(
            fixed_maps(*(fisheye_rectify_maps(k, d, rr, p, rig.size) if fisheye else
                         rectify_maps(k, d, rr, p, rig.size, threads)),
                       (height, width), threads)
            for k, d, rr, p in ((rig.k1, rig.d1, r1, p1), (rig.k2, rig.d2, r2, p2)))
        self.valid = tuple(f.valid.view(np.bool_) for f in self.fixed)
        if not all(v.any() for v in self.valid):  # only black images would follow
            raise ValueError(f"{rig.source}: no pixel of the rectified images has a source "
                             "in the raw ones; check the rig (its size, R and T) and alpha")
        self._all_valid = tuple(bool(v.all()) for v in self.valid)
        focal = float(p1[0, 0])
        self.calibration = Calibration(
            focal, float(-(p2[0, 3] - p1[0, 3]) / p2[0, 0]), float(p1[0, 2]),
            float(p1[1, 2]), float(p2[0, 2] - p1[0, 2]), rig.units, width, height,
            source=f"{rig.source}, rectified")

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
        the rig says its units, else in its own), for ``csw match`` beside the images."""
        from .calibration import UNITS

        c = self.calibration
        scale = UNITS[c.units] / UNITS["mm"] if c.units else 1.0
        cam = f"[{c.focal:.10g} 0 {c.cx:.10g}; 0 {c.focal:.10g} {c.cy:.10g}; 0 0 1]"
        cam1 = f"[{c.focal:.10g} 0 {c.cx + c.doffs:.10g}; 0 {c.focal:.10g} {c.cy:.10g}; 0 0 1]"
        return (f"cam0={cam}\ncam1={cam1}\ndoffs={c.doffs:.10g}\n"
                f"baseline={c.baseline * scale:.10g}\nwidth={c.width}\nheight={c.height}\n")


def _folder(path):
    """``path`` as a folder, created with its parents if missing; OptionError naming it
    when it is something else or can't be made."""
    from pathlib import Path

    from ..config.params import OptionError

    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OptionError("output_dir", f"{path} exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OptionError("output_dir", f"can't create the folder {path} "
                                        f"({exc.strerror or exc})") from None
    return path


def _rig_files(rig):
    """The files a rig was read from, as named inputs (csw.io.safety.check_outputs)."""
    return {f"rig {i + 1}": path for i, path in enumerate(getattr(rig, "paths", ()))}


def check_images(rig, *paths):
    """Each image file's size, as its header gives it, against the rig's, before any
    map is built: OptionError naming the image ("left", "right") that can't be read,
    or the rig when the sizes differ."""
    from ..config.params import OptionError
    from ..io.images import ImageError
    from ..io.sources import open_source

    for path, name in zip(paths, ("left", "right"), strict=False):
        try:
            height, width = open_source(path, name, probe=False).shape[:2]
        except ImageError as exc:
            exc.option = name
            raise
        try:
            rig.check_size((width, height), f"the {name} image")
        except ValueError as exc:
            raise OptionError("rig", str(exc)) from None


def rectify_files(left, right, rig, out_dir, alpha=0.0, threads=None):
    """Rectify a raw pair of image files with ``rig`` (a Rig) into ``out_dir``:
    left.png, right.png (the images' own type, gray or colour) and calib.txt (the
    rectified pair's calibration, Middlebury style, so that ``csw match
    out_dir/left.png out_dir/right.png --depth z.pfm`` uses it), all or none written.
    Returns the Rectifier."""

    from ..io.atomic import atomic_write_all
    from ..io.formats import png_writer
    from ..io.images import ImageError, read_colour
    from ..io.safety import check_outputs

    out_dir = _folder(out_dir)
    outputs = {"left": out_dir / "left.png", "right": out_dir / "right.png",
               "calib": out_dir / "calib.txt"}
    check_outputs({"left_raw": left, "right_raw": right, **_rig_files(rig)}, outputs,
                  {"left": (".png",), "right": (".png",), "calib": (".txt",)})
    check_images(rig, left, right)
    rect = Rectifier(rig, alpha, threads)
    images = []
    for path, name in ((left, "left"), (right, "right")):
        try:
            images.append(read_colour(path))
        except ImageError as exc:
            exc.option = name
            raise
    left_r, right_r = rect.rectify(*images)
    text = rect.calib_text().encode()

    def write_text(tmp):
        with open(tmp, "wb") as f:
            f.write(text)

    atomic_write_all([(outputs["left"], png_writer(left_r)),
                      (outputs["right"], png_writer(right_r)),
                      (outputs["calib"], write_text)])
    return rect


def rectify_many(jobs, rig, out_dir, alpha=0.0, threads=None, progress=False):
    """Rectify every pair of ``jobs`` (csw.Job, from csw.jobs_from_folders or
    csw.jobs_from_manifest) with one Rectifier, its maps built once, into
    ``out_dir/left/NAME.png`` and ``out_dir/right/NAME.png``, with the rectified
    calibration in ``out_dir/left/calib.txt`` (where ``csw match out_dir/left
    out_dir/right -O maps`` finds it beside each left image).  Each pair is written whole
    or not at all; a pair that fails is reported and the others go on.  Returns
    {"ok": count, "failed": [(name, one-line error), ...], "rectifier": the Rectifier}.
    progress: a progress bar on stderr."""
    from pathlib import Path

    from ..io.atomic import atomic_write_all
    from ..io.formats import png_writer
    from ..io.images import read_colour
    from ..io.safety import check_outputs

    rect = Rectifier(rig, alpha, threads)
    out_dir = _folder(out_dir)
    folders = {side: _folder(out_dir / side) for side in ("left", "right")}
    calib = folders["left"] / "calib.txt"
    text = rect.calib_text().encode()
    check_outputs(_rig_files(rig), {"calib": calib}, {"calib": (".txt",)})
    atomic_write_all([(calib, lambda tmp: Path(tmp).write_bytes(text))])
    from ..scale.executor import progress_bar

    done, failed = 0, []
    bar = progress_bar(len(jobs), "csw rectify", "pair", progress)
    for job in jobs:
        try:
            if job.problem:
                raise ValueError(job.problem)
            outputs = {side: folders[side] / f"{job.name}.png" for side in folders}
            check_outputs({"left_raw": job.left, "right_raw": job.right,
                           **_rig_files(rig)}, outputs,
                          {"left": (".png",), "right": (".png",)})
            pair = rect.rectify(read_colour(job.left), read_colour(job.right))
            atomic_write_all([(outputs[side], png_writer(image))
                              for side, image in zip(folders, pair, strict=True)])
            done += 1
        except (ValueError, OSError) as exc:
            failed.append((job.name, str(exc).splitlines()[0] if str(exc) else
                           type(exc).__name__))
        bar.update(1)
    bar.close()
    return {"ok": done, "failed": failed, "rectifier": rect}

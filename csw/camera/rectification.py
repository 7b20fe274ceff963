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


def fisheye_rectify_maps(k, distortion, r, p, size, dtype=np.float32):
    """(map_x, map_y), float32 (H, W), as cv2.fisheye.initUndistortRectifyMap (CV_32FC1);
    dtype float64: the doubles OpenCV rounds its fixed-point maps from."""
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
    return map_x.astype(dtype), map_y.astype(dtype)


def rectify_maps(k, distortion, r, p, size, threads=None, dtype=np.float32):
    """(map_x, map_y), float32 (H, W) each: for every pixel of the rectified image, where
    it comes from in the raw image (cv2.initUndistortRectifyMap's maps, CV_32FC1; built
    by the kernel csw.kernels.remap.undistort_rectify_maps).  dtype float64: the doubles
    OpenCV rounds its fixed-point maps (CV_16SC2) from, which the Rectifier rounds alike.

    k (3, 3), distortion: the raw camera; r (3, 3): its rectifying rotation; p (3, 3) or
    (3, 4): the rectified camera; size: (width, height) of the rectified image."""
    from ..kernels.remap import undistort_rectify_maps

    inverse = np.linalg.inv(np.asarray(p, np.float64)[:3, :3] @ np.asarray(r, np.float64))
    maps = undistort_rectify_maps(inverse, np.asarray(k, np.float64),
                                  coefficients(distortion), size, threads)
    return tuple(m.astype(dtype, copy=False) for m in maps)


def rectification(rig, alpha=0.0):
    """(R1, R2, P1, P2) of a rig: its file's where it gives them, else Bouguet's (fisheye:
    OpenCV's fisheye.stereoRectify, alpha as its balance)."""
    if rig.rectification is not None:
        return tuple(np.asarray(m, np.float64) for m in rig.rectification)
    fisheye = rig.model == "equidistant"
    solve = fisheye_stereo_rectify if fisheye else stereo_rectify
    return solve(rig.k1, rig.d1, rig.k2, rig.d2, rig.size, rig.r, rig.t,
                 max(alpha, 0.0) if fisheye else alpha)[:4]

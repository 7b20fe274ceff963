"""Calibrated rigs for the rectification tests, written on the fly in each format's own
conventions (OpenCV's FileStorage, ROS camera_info), and raw images made through them."""

import cv2
import numpy as np

from csw.camera.rectification import rodrigues
from csw.camera.rig import Rig

SIZE = (320, 240)


def random_rig(rng, model="plumb_bob", size=SIZE):
    """A plausible rig: focal length 300 px, a few pixels of centre offset, mild
    distortion, a 12 cm baseline, a small relative rotation."""
    width, height = size

    def camera():
        return np.array([[300 + rng.uniform(-10, 10), 0, width / 2 + rng.uniform(-5, 5)],
                         [0, 300 + rng.uniform(-10, 10), height / 2 + rng.uniform(-5, 5)],
                         [0, 0, 1]])

    n = {"rational_polynomial": 8, "equidistant": 4}.get(model, 5)
    d1, d2 = (rng.uniform(-0.05, 0.05, n) for _ in range(2))
    if model == "rational_polynomial":
        d1[5:], d2[5:] = rng.uniform(-0.01, 0.01, 3), rng.uniform(-0.01, 0.01, 3)
    t = np.array([-0.12, rng.uniform(-0.004, 0.004), rng.uniform(-0.004, 0.004)])
    return Rig(camera(), d1, camera(), d2, rodrigues(rng.uniform(-0.03, 0.03, 3)), t, size,
               model, source="a random rig")


def write_opencv(path, rig, given=None, keys=("M1", "D1", "M2", "D2", "R", "T")):
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    values = {"M1": rig.k1, "D1": rig.d1.reshape(1, -1), "M2": rig.k2,
              "D2": rig.d2.reshape(1, -1), "R": rig.r, "T": rig.t.reshape(3, 1)}
    if given:
        values.update(given)
    for key in keys:
        storage.write(key, values[key])
    storage.write("width", rig.size[0])
    storage.write("height", rig.size[1])
    storage.release()


def ros_camera_info(k, d, r, p, size):
    def block(rows, cols, values):
        data = ", ".join(f"{v:.17g}" for v in np.ravel(values))
        return f"\n  rows: {rows}\n  cols: {cols}\n  data: [{data}]"

    return (f"image_width: {size[0]}\nimage_height: {size[1]}\ncamera_name: cam\n"
            f"camera_matrix:{block(3, 3, k)}\ndistortion_model: plumb_bob\n"
            f"distortion_coefficients:{block(1, len(d), d)}\n"
            f"rectification_matrix:{block(3, 3, r)}\nprojection_matrix:{block(3, 4, p)}\n")


def raw_from_rectified(rectified, k, d, r, p):
    """The raw image a camera (k, d) sees of a rectified image (r, p): each raw pixel
    looks up where it lands once rectified (OpenCV's undistortPoints)."""
    height, width = rectified.shape
    grid = np.stack(np.meshgrid(np.arange(width), np.arange(height)), -1).astype(np.float64)
    where = cv2.undistortPoints(grid.reshape(-1, 1, 2), k, d, R=r, P=p,
                                criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS,
                                          50, 1e-12)).reshape(height, width, 2)
    return cv2.remap(rectified, where[..., 0].astype(np.float32),
                     where[..., 1].astype(np.float32), cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REFLECT)


def numbers(values):
    return " ".join(f"{v:.17g}" for v in np.ravel(values))


def kitti_text(rig, r02=None, t02=None, rect=None):
    """A KITTI calib_cam_to_cam.txt of ``rig`` (cameras 02 and 03), camera 0 at (r02,
    t02) from the left one (default: the left one itself); rect: (R_rect_02, R_rect_03,
    P_rect_02, P_rect_03), else only identity P_rect matrices."""
    r02 = np.eye(3) if r02 is None else r02
    t02 = np.zeros(3) if t02 is None else t02
    r03, t03 = rig.r @ r02, rig.r @ t02 + rig.t
    text = (f"S_02: {rig.size[0]} {rig.size[1]}\nK_02: {numbers(rig.k1)}\n"
            f"D_02: {numbers(rig.d1)}\nR_02: {numbers(r02)}\nT_02: {numbers(t02)}\n"
            f"S_03: {rig.size[0]} {rig.size[1]}\nK_03: {numbers(rig.k2)}\n"
            f"D_03: {numbers(rig.d2)}\nR_03: {numbers(r03)}\nT_03: {numbers(t03)}\n")
    if rect is None:
        return text + f"P_rect_02: {numbers(np.eye(3, 4))}\nP_rect_03: {numbers(np.eye(3, 4))}\n"
    return text + "".join(f"{key}: {numbers(m)}\n" for key, m in zip(
        ("R_rect_02", "R_rect_03", "P_rect_02", "P_rect_03"), rect, strict=True))


def kalibr_text(rig):
    """A Kalibr camchain of ``rig`` (radtan, its first 4 coefficients)."""
    transform = np.eye(4)
    transform[:3, :3], transform[:3, 3] = rig.r, rig.t
    cams = [f"  camera_model: pinhole\n"
            f"  intrinsics: [{k[0, 0]}, {k[1, 1]}, {k[0, 2]}, {k[1, 2]}]\n"
            f"  distortion_model: radtan\n"
            f"  distortion_coeffs: [{', '.join(map(str, d[:4]))}]\n"
            f"  resolution: [{rig.size[0]}, {rig.size[1]}]\n"
            for k, d in ((rig.k1, rig.d1), (rig.k2, rig.d2))]
    rows = "".join(f"  - [{numbers(r).replace(' ', ', ')}]\n" for r in transform)
    return f"cam0:\n{cams[0]}cam1:\n  T_cn_cnm1:\n{rows}{cams[1]}"

"""Chessboard pairs made on the fly through a known rig: each raw pixel's ray (OpenCV's
undistortPoints, through the lens model) meets the board's plane, and the square there
gives its gray level (2x2 samples a pixel), so the tests need no data."""

import cv2
import numpy as np

from csw.camera.rectification import rodrigues
from csw.camera.rig import Rig

BOARD = (9, 6)
SQUARE = 25.0  # mm
SIZE = (480, 360)


def known_rig(model="plumb_bob", size=SIZE):
    """A rig in mm: f 420 px, mild distortion, a 60 mm baseline, a small rotation."""
    width, height = size
    k1 = np.array([[420.0, 0, width / 2 + 3], [0, 420.0, height / 2 - 2], [0, 0, 1]])
    k2 = np.array([[415.0, 0, width / 2 - 4], [0, 415.0, height / 2 + 3], [0, 0, 1]])
    if model == "equidistant":
        d1, d2 = np.array([0.02, -0.01, 0.0, 0.0]), np.array([0.015, -0.005, 0.0, 0.0])
    else:
        d1, d2 = np.array([-0.12, 0.05, 0.0, 0.0, 0.0]), np.array([-0.1, 0.04, 0.0, 0.0, 0.0])
    r = rodrigues(np.array([0.01, -0.02, 0.005]))
    return Rig(k1, d1, k2, d2, r, np.array([-60.0, 0.5, 1.0]), size, model, units="mm",
               source="a known rig")


def _rays(size, k, d, fisheye):
    width, height = size
    grid = np.stack(np.meshgrid((np.arange(2 * width) + 0.5) / 2 - 0.5,
                                (np.arange(2 * height) + 0.5) / 2 - 0.5), -1)
    pts = grid.reshape(-1, 1, 2).astype(np.float64)
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-12)
    if fisheye:
        norm = cv2.fisheye.undistortPoints(pts, k, d, criteria=crit)
    else:
        norm = cv2.undistortPoints(pts, k, d, criteria=crit)
    return norm.reshape(2 * height, 2 * width, 2)


def render(rays, rvec, tvec, rot=None, move=None):
    """A gray view of the board (pose rvec, tvec in the left camera's frame) by a camera
    at (rot, move) from the left one, its rays given; 2x2 samples averaged."""
    rb = rodrigues(rvec)
    rot = np.eye(3) if rot is None else rot
    move = np.zeros(3) if move is None else move
    # The board in this camera's frame: X = rot (rb P + tvec) + move.
    r_cam, t_cam = rot @ rb, rot @ tvec + move
    normal = r_cam[:, 2]
    dirs = np.concatenate([rays, np.ones(rays.shape[:2] + (1,))], axis=2)
    scale = (normal @ t_cam) / (dirs @ normal)
    points = dirs * scale[..., None] - t_cam
    local = points @ r_cam  # board coordinates (mm)
    u, v = local[..., 0] / SQUARE, local[..., 1] / SQUARE
    inside = (u > -2) & (u < BOARD[0] + 1) & (v > -2) & (v < BOARD[1] + 1) & (scale > 0)
    square = (np.floor(u) + np.floor(v)) % 2 == 0
    board = (u > -1) & (u < BOARD[0]) & (v > -1) & (v < BOARD[1])
    gray = np.where(inside, np.where(board & square, 30.0, 225.0), 120.0)
    h, w = gray.shape
    return gray.reshape(h // 2, 2, w // 2, 2).mean(axis=(1, 3)).round().astype(np.uint8)


def poses(count, rng):
    """Board poses ``count`` of them, 330..480 mm ahead, tilted up to 30 degrees, spread
    over the view of both cameras."""
    out = []
    centre = np.array([(BOARD[0] - 1) * SQUARE / 2, (BOARD[1] - 1) * SQUARE / 2, 0])
    for _ in range(count):
        rvec = np.radians(rng.uniform(-30, 30, 3) * np.array([1, 1, 0.4]))
        where = np.array([rng.uniform(-30, 90), rng.uniform(-60, 60), rng.uniform(330, 480)])
        out.append((rvec, where - rodrigues(rvec) @ centre))
    return out


def views(rig, count=8, seed=3):
    """``count`` (name, left, right) chessboard pairs through ``rig``."""
    rng = np.random.default_rng(seed)
    fisheye = rig.model == "equidistant"
    rays = [_rays(rig.size, k, d, fisheye) for k, d in ((rig.k1, rig.d1), (rig.k2, rig.d2))]
    return [(f"{i:02d}", render(rays[0], rvec, tvec), render(rays[1], rvec, tvec, rig.r, rig.t))
            for i, (rvec, tvec) in enumerate(poses(count, rng))]


def write_views(folder, pairs):
    """The pairs as folder/left/NAME.png and folder/right/NAME.png."""
    for side, index in (("left", 1), ("right", 2)):
        (folder / side).mkdir(parents=True, exist_ok=True)
        for pair in pairs:
            cv2.imwrite(str(folder / side / f"{pair[0]}.png"), pair[index])
    return folder / "left", folder / "right"

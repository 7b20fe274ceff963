"""Small benchmark folders in the published layouts, built from the synthetic scene, so
layout tests need no download: Middlebury 2014 scene folders and KITTI training folders."""

import numpy as np

from csw.data.synth import render
from csw.io import write_float_pfm, write_png


def middlebury2014(folder, seed=1, ndisp=24, mask=True, size=(96, 64)):
    """A scene folder: im0.png, im1.png (RGB), disp0.pfm (inf where unknown), calib.txt,
    mask0nocc.png (255 visible, 128 occluded).  Returns (left gray, right gray, gt)."""
    left, right, gt, nonocc = render(*size, dmax=16, seed=seed)
    folder.mkdir(parents=True)
    # RGB files whose luma is the gray scene: three equal channels.
    write_png(folder / "im0.png", np.repeat(left[..., None], 3, axis=2))
    write_png(folder / "im1.png", np.repeat(right[..., None], 3, axis=2))
    gt = gt.copy()
    gt[:4, :4] = np.inf  # a patch of unknown ground truth
    write_float_pfm(folder / "disp0.pfm", gt)
    (folder / "calib.txt").write_text(
        "cam0=[100 0 48; 0 100 32; 0 0 1]\ncam1=[100 0 48; 0 100 32; 0 0 1]\ndoffs=0\n"
        f"baseline=100\nwidth={size[0]}\nheight={size[1]}\nndisp={ndisp}\nisint=0\n"
        "vmin=0\nvmax=16\n")
    if mask:
        write_png(folder / "mask0nocc.png", np.where(nonocc, 255, 128).astype(np.uint8))
    return left, right, np.where(np.isfinite(gt), gt, np.nan)


def kitti(root, frames=2, year=2015, size=(96, 64)):
    """A training folder with ``frames`` frames NNNNNN_10.png: left/right images, disp_occ
    (all known) and disp_noc (visible only) as uint16 d*256, 0 unknown."""
    names = {2015: ("image_2", "image_3", "disp_occ_0", "disp_noc_0"),
             2012: ("colored_0", "colored_1", "disp_occ", "disp_noc")}[year]
    for name in names:
        (root / name).mkdir(parents=True, exist_ok=True)
    scenes = {}
    for i in range(frames):
        left, right, gt, nonocc = render(*size, dmax=16, seed=10 + i)
        frame = f"{i:06d}_10.png"
        occ = np.round(gt * 256).astype(np.uint16)
        occ[-3:, :] = 0  # KITTI leaves rows without ground truth
        write_png(root / names[0] / frame, left)
        write_png(root / names[1] / frame, right)
        write_png(root / names[2] / frame, occ)
        write_png(root / names[3] / frame, np.where(nonocc, occ, 0).astype(np.uint16))
        # A frame 11 with no ground truth is not a scene.
        write_png(root / names[0] / f"{i:06d}_11.png", left)
        scenes[frame[:-4]] = (left, right, np.where(occ > 0, occ / 256.0, np.nan),
                              nonocc & (occ > 0))
    return scenes

"""Benchmark folders in the layouts people download them in.

  Middlebury 2014 / 2021 / MiddEval3: one folder per scene with im0.png, im1.png, the left
      ground truth disp0.pfm (MiddEval3: disp0GT.pfm; inf = unknown), calib.txt (its
      ``ndisp`` bounds the disparities: d in 0..ndisp-1) and, where present,
      mask0nocc.png (255 = not occluded).
  KITTI 2012 / 2015 training folders: left/right image folders (2015: image_2/image_3;
      2012: colored_0/colored_1 or image_0/image_1), ground truth disp_occ_0/disp_noc_0
      (2012: disp_occ/disp_noc) as 16-bit PNG, disparity = value / 256, 0 = unknown.
      Scenes are the frames ``NNNNNN_10`` that have ground truth.  KITTI states no
      disparity range; csw searches d 0..255 (everything a KITTI PNG can hold).

:func:`scan` finds every scene under a folder, whichever of these it is; a scene loads
as a :class:`csw.datasets.Pair`, scored like the registry's pairs.
"""

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..io import ImageError, read_disparity, read_image
from .datasets import DataError, Pair, check_sizes, region_masks

KITTI_DMAX = 255
MIDDLEBURY_GT = ("disp0.pfm", "disp0GT.pfm")
KITTI_FOLDERS = (  # (layout, left, right, all known, non-occluded)
    ("kitti2015", "image_2", "image_3", "disp_occ_0", "disp_noc_0"),
    ("kitti2012", "colored_0", "colored_1", "disp_occ", "disp_noc"),
    ("kitti2012", "image_0", "image_1", "disp_occ", "disp_noc"),
)


@dataclass(frozen=True)
class Scene:
    """One scene found on disk, not yet loaded: ``load()`` reads it."""

    name: str
    layout: str
    left: Path
    right: Path
    gt: Path | None
    nonocc: Path | None = None
    calib: Path | None = None

    def load(self):
        """Read the scene as a :class:`Pair`; DataError when a file is unusable."""
        try:
            left, right = read_image(self.left), read_image(self.right)
            if self.gt is None:
                gt = np.full(left.shape, np.nan, np.float32)
            elif self.layout.startswith("kitti"):
                gt = read_disparity(self.gt, 256.0)
            else:
                gt = read_disparity(self.gt)
            masks = {}
            if self.nonocc is not None:
                image = read_image(self.nonocc)
                # KITTI's noc ground truth: known there = not occluded.
                masks["nonocc"] = (image > 0).astype(np.uint8) * 255 \
                    if self.layout.startswith("kitti") else image
        except ImageError as exc:
            raise DataError(str(exc)) from None
        check_sizes(self.name, left, right, gt)
        return Pair(self.name, left, right, gt, region_masks(np.isfinite(gt), 0, masks),
                    self.dmax(left.shape[1], gt), None, self.layout)

    def dmax(self, width, gt):
        """The range to search: calib.txt's ndisp - 1, KITTI's 0..255, else one that covers
        the ground truth; never past the image's width."""
        if self.layout.startswith("kitti"):
            top = KITTI_DMAX
        elif self.calib is not None and (ndisp := read_ndisp(self.calib)) is not None:
            top = ndisp - 1
        elif np.isfinite(gt).any():
            top = math.ceil(float(np.nanmax(gt)))
        else:
            raise DataError(f"{self.name}: no calib.txt and no ground truth to take a "
                            "disparity range from; pass --dmax")
        return max(0, min(top, width - 1))


def read_ndisp(path):
    """``ndisp`` from a Middlebury calib.txt, or None if it has none; DataError if bad."""
    from ..io.safety import read_small

    text = read_small(path, "a calib.txt", DataError).decode(errors="replace")
    found = re.search(r"^[^\S\n]*ndisp\s*=\s*(\S+)", text, re.MULTILINE)
    if not found:
        return None
    try:
        ndisp = int(float(found.group(1)))
    except ValueError:
        raise DataError(f"{path}: ndisp={found.group(1)!r} is not a number") from None
    if ndisp < 1:
        raise DataError(f"{path}: ndisp must be at least 1, got {ndisp}")
    return ndisp


def _middlebury_scene(folder):
    if not ((folder / "im0.png").is_file() and (folder / "im1.png").is_file()):
        return None
    gt = next((folder / g for g in MIDDLEBURY_GT if (folder / g).is_file()), None)
    nonocc = folder / "mask0nocc.png"
    calib = folder / "calib.txt"
    return Scene(folder.name, "middlebury2014", folder / "im0.png", folder / "im1.png", gt,
                 nonocc if nonocc.is_file() else None, calib if calib.is_file() else None)


def _kitti_scenes(folder):
    for layout, left, right, occ, noc in KITTI_FOLDERS:
        if not ((folder / left).is_dir() and (folder / right).is_dir() and
                (folder / occ).is_dir()):
            continue
        scenes = []
        for gt in sorted((folder / occ).glob("*_10.png")):
            name = gt.stem
            pair = folder / left / gt.name, folder / right / gt.name
            if not all(p.is_file() for p in pair):
                continue
            nonocc = folder / noc / gt.name
            scenes.append(Scene(name, layout, *pair, gt,
                                nonocc if nonocc.is_file() else None))
        return scenes
    return None


def scan(path):
    """Every scene under ``path``: a Middlebury scene folder, a folder of them, or a KITTI
    training folder (or the folder holding ``training/``).  Sorted by name.
    Raises DataError when nothing is recognised."""
    root = Path(path)
    if not root.is_dir():
        raise DataError(f"{root}: not a folder")
    for candidate in (root, root / "training"):
        scenes = _kitti_scenes(candidate)
        if scenes is not None:
            if not scenes:
                raise DataError(f"{candidate}: a KITTI folder with no NNNNNN_10.png frame "
                                "that has both images and ground truth")
            return scenes
    single = _middlebury_scene(root)
    if single is not None:
        return [single]
    scenes = [s for s in (_middlebury_scene(sub) for sub in sorted(root.iterdir())
                          if sub.is_dir()) if s is not None]
    if not scenes:
        raise DataError(
            f"{root}: no scene found; expected a Middlebury scene folder (im0.png, im1.png, "
            "disp0.pfm, calib.txt), a folder of such scenes, or a KITTI training folder "
            "(image_2, image_3, disp_occ_0)")
    return scenes


def find_scene(path, name=None):
    """The one scene under ``path``, or the one called ``name``; DataError otherwise."""
    scenes = scan(path)
    if name is not None:
        chosen = [s for s in scenes if s.name == name]
        if not chosen:
            raise DataError(f"{path}: no scene {name!r}; it has "
                            f"{', '.join(s.name for s in scenes[:8])}"
                            + (", ..." if len(scenes) > 8 else ""))
        return chosen[0]
    if len(scenes) > 1:
        raise DataError(f"{path} holds {len(scenes)} scenes; choose one with --scene, or "
                        "score a folder of maps")
    return scenes[0]


def map_for(folder, scene):
    """The map for ``scene`` in a folder of maps (as a batch writes them): SCENE.pfm,
    .npy or .png, the first found; None if there is none."""
    from ..io.formats import suffixes

    found = [Path(folder) / f"{scene}{s}" for s in suffixes("whole")
             if (Path(folder) / f"{scene}{s}").is_file()]
    return found[0] if found else None

"""A deterministic synthetic stereo scene with exact ground truth.

The scene is a stack of textured planar layers seen by a rectified pair.  Each layer has
an affine disparity d(x, y) = a*x + b*y + c in left-image coordinates (a = b = 0 is a
fronto-parallel plane, a != 0 a slanted one) and a support region in the left image.
A larger disparity is nearer the cameras.  The texture is a smooth function of the
surface point, so the same point has the same brightness in both views, and fronto-
parallel layers with integer disparity appear shifted by exactly d pixels.

Rendering is exact ray casting, not warping:
  left pixel (x, y):   the nearest layer whose support contains (x, y);
  right pixel (xr, y): for each layer, the left coordinate x = (xr + b*y + c) / (1 - a)
                       that lands on xr; the nearest layer that contains it wins.
A left pixel is occluded when the nearest surface at its right position is another layer
(or it falls outside the right image).
"""

from dataclasses import dataclass

import numpy as np


@dataclass
class Layer:
    a: float  # disparity slope along x
    b: float  # disparity slope along y
    c: float  # disparity offset
    x0: float  # support: an axis-aligned box (x0..x1, y0..y1) in left coordinates,
    x1: float  # or an ellipse inscribed in it when ``round`` is set
    y0: float
    y1: float
    round: bool
    seed: int

    def disparity(self, x, y):
        return self.a * x + self.b * y + self.c

    def contains(self, x, y):
        if self.round:
            cx, cy = (self.x0 + self.x1) / 2, (self.y0 + self.y1) / 2
            rx, ry = (self.x1 - self.x0) / 2, (self.y1 - self.y0) / 2
            return ((x - cx) / rx) ** 2 + ((y - cy) / ry) ** 2 <= 1.0
        return (x >= self.x0) & (x <= self.x1) & (y >= self.y0) & (y <= self.y1)


def _value_noise(seed, x, y, cell):
    """Smooth random texture in 0..1: bilinear interpolation of a random lattice."""
    rng = np.random.default_rng(seed)
    lattice = rng.random((64, 64))
    gx, gy = x / cell, y / cell
    ix, iy = np.floor(gx).astype(np.int64), np.floor(gy).astype(np.int64)
    fx, fy = gx - ix, gy - iy
    v00 = lattice[iy % 64, ix % 64]
    v01 = lattice[iy % 64, (ix + 1) % 64]
    v10 = lattice[(iy + 1) % 64, ix % 64]
    v11 = lattice[(iy + 1) % 64, (ix + 1) % 64]
    return (v00 * (1 - fx) + v01 * fx) * (1 - fy) + (v10 * (1 - fx) + v11 * fx) * fy


def texture(layer, x, y):
    """Brightness 0..255 of the layer's surface point seen at left coords (x, y)."""
    v = (0.45 * _value_noise(layer.seed, x, y, 2.0)
         + 0.35 * _value_noise(layer.seed + 1, x, y, 6.0)
         + 0.20 * _value_noise(layer.seed + 2, x, y, 17.0))
    # Each layer has its own mean brightness so the objects stand out to a viewer.
    mean = 60.0 + (layer.seed % 1000) / 1000.0 * 140.0
    return mean + 150.0 * (v - 0.5)


def make_layers(width, height, dmax, seed):
    """Back to front: a slanted background, then fronto-parallel boxes and discs."""
    rng = np.random.default_rng(seed)
    top = max(dmax, 4)
    # Background: slanted plane spanning roughly [0.05, 0.3] * dmax left to right.
    lo, hi = 0.05 * top, 0.3 * top
    a = (hi - lo) / max(width - 1, 1)
    layers = [Layer(a, 0.0, lo, -1e9, 1e9, -1e9, 1e9, False, int(rng.integers(1 << 30)))]
    # Foreground objects at integer disparities, nearer ones later.
    depths = np.linspace(0.4 * top, 0.9 * top, 4)
    for i, d in enumerate(depths):
        w = rng.uniform(0.18, 0.32) * width
        h = rng.uniform(0.25, 0.45) * height
        x0 = rng.uniform(0.1 * width, 0.9 * width - w)
        y0 = rng.uniform(0.05 * height, 0.95 * height - h)
        layers.append(Layer(0.0, 0.0, float(np.round(d)), x0, x0 + w, y0, y0 + h,
                            bool(i % 2), int(rng.integers(1 << 30))))
    return layers


def moving_layers(width, height, dmax, seed, phase):
    """The scene's layers at ``phase`` (0..1, one loop of a sequence): each box and disc
    swings across the image and in depth on its own cycle (its disparity stays within
    0.35..0.95 of dmax, nearer than the background), the background stays."""
    layers = make_layers(width, height, dmax, seed)
    top = max(dmax, 4)
    moved = [layers[0]]
    for i, layer in enumerate(layers[1:]):
        angle = 2 * np.pi * (phase * (1 + i % 2) + i / 4)
        dx = 0.12 * width * np.sin(angle)
        depth = min(max(layer.c + 0.15 * top * np.cos(angle), 0.35 * top), 0.95 * top)
        moved.append(Layer(0.0, 0.0, float(depth), layer.x0 + dx, layer.x1 + dx, layer.y0,
                           layer.y1, layer.round, layer.seed))
    return moved


def render(width=450, height=375, dmax=64, seed=0, rows=None, phase=None):
    """Render the scene, or rows ``rows = (first, end)`` of it (every pixel depends on its
    own coordinates only, so a band equals those rows of the whole scene); ``phase``
    (0..1): the moving scene of :func:`moving_layers` at that point of its loop.

    Returns (left uint8 (H, W), right uint8 (H, W), gt float32 (H, W) left disparity,
    nonocc bool (H, W): True where the left pixel is visible in the right image).
    """
    if width < 8 or height < 8:
        raise ValueError("the synthetic scene needs at least 8x8 pixels")
    if not 1 <= dmax < width:
        raise ValueError(f"dmax must be between 1 and width - 1 ({width - 1})")
    layers = make_layers(width, height, dmax, seed) if phase is None else \
        moving_layers(width, height, dmax, seed, phase)
    first, end = (0, height) if rows is None else rows
    ys, xs = np.mgrid[first:end, 0:width].astype(np.float64)
    shape = ys.shape

    # Left view: nearest layer covering each pixel.  Layers are back to front, and nearer
    # layers have larger disparity, so later layers overwrite earlier ones.
    owner = np.full(shape, -1)
    gt = np.zeros(shape)
    for k, layer in enumerate(layers):
        inside = layer.contains(xs, ys)
        d = layer.disparity(xs, ys)
        take = inside & ((owner < 0) | (d > gt))
        owner[take], gt[take] = k, d[take]
    left = np.zeros(shape)
    for k, layer in enumerate(layers):
        sel = owner == k
        left[sel] = texture(layer, xs[sel], ys[sel])

    # Right view: for each layer, the left coordinate that projects to xr.
    right_d = np.full(shape, -np.inf)
    right = np.zeros(shape)
    for layer in layers:
        x_left = (xs + layer.b * ys + layer.c) / (1.0 - layer.a)
        inside = layer.contains(x_left, ys)
        d = layer.disparity(x_left, ys)
        take = inside & (d > right_d)
        right_d[take] = d[take]
        right[take] = texture(layer, x_left[take], ys[take])

    # Occlusion: the right image, at the left pixel's match, shows a nearer surface.
    xr = xs - gt
    visible = xr >= 0
    xr_near = np.clip(np.round(xr).astype(np.int64), 0, width - 1)
    shown = right_d[ys.astype(np.int64) - first, xr_near]
    nonocc = visible & (shown <= gt + 0.5)
    to8 = lambda img: np.clip(np.round(img), 0, 255).astype(np.uint8)  # noqa: E731
    return to8(left), to8(right), gt.astype(np.float32), nonocc


# The synthetic rig: a focal length of one image width, 100 mm between the cameras.
BASELINE_MM = 100.0


def calib_text(width, height, dmax):
    """The scene's calibration as a Middlebury 2014 calib.txt: focal length = width
    pixels, the principal point at the centre, the baseline BASELINE_MM, ndisp dmax + 1."""
    cam = f"[{width} 0 {(width - 1) / 2:g}; 0 {width} {(height - 1) / 2:g}; 0 0 1]"
    return (f"cam0={cam}\ncam1={cam}\ndoffs=0\nbaseline={BASELINE_MM:g}\nwidth={width}\n"
            f"height={height}\nndisp={dmax + 1}\nisint=0\nvmin=0\nvmax={dmax}\n")


def write_scene(directory, width=450, height=375, dmax=64, seed=0):
    """Write left.png, right.png, gt.pfm (all pixels known), nonocc.png (255 where the
    left pixel is visible in the right image, Middlebury's mask convention) and calib.txt
    (the rig, see calib_text)."""
    from pathlib import Path

    from ..io import atomic_write_all, pfm_writer, png_writer

    left, right, gt, nonocc = render(width, height, dmax, seed)
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    # All or none: a scene missing a file would be scored wrongly.
    calib = calib_text(width, height, dmax)
    atomic_write_all([(directory / "left.png", png_writer(left)),
                      (directory / "right.png", png_writer(right)),
                      (directory / "gt.pfm", pfm_writer(gt)),
                      (directory / "nonocc.png", png_writer((nonocc * 255).astype(np.uint8))),
                      (directory / "calib.txt", lambda tmp: Path(tmp).write_text(calib))])
    return left, right, gt, nonocc


def write_sequence(directory, frames, width=450, height=375, dmax=64, seed=0, video=False,
                   rate=30.0):
    """A moving scene (:func:`moving_layers`, one loop over the frames): left/NNNNNN.png,
    right/NNNNNN.png and gt/NNNNNN.pfm per frame, and calib.txt; with ``video``, instead
    of the images, sbs.mp4 (the pair side by side, H.264) beside gt/.  Each file is
    written atomically; a rerun writes the sequence again.  Returns the paths written
    (the video, or the left folder)."""
    from pathlib import Path

    from ..io import atomic_write, pfm_writer, png_writer

    directory = Path(directory)
    for folder in (["gt"] if video else ["left", "right", "gt"]):
        (directory / folder).mkdir(parents=True, exist_ok=True)
    atomic_write(directory / "calib.txt",
                 lambda tmp: Path(tmp).write_text(calib_text(width, height, dmax)))

    def pairs():
        for index in range(frames):
            left, right, gt, _ = render(width, height, dmax, seed, phase=index / frames)
            name = f"{index:06d}"
            atomic_write(directory / "gt" / f"{name}.pfm", pfm_writer(gt))
            if not video:
                atomic_write(directory / "left" / f"{name}.png", png_writer(left))
                atomic_write(directory / "right" / f"{name}.png", png_writer(right))
            yield left, right

    if not video:
        for _ in pairs():
            pass
        return directory / "left"
    from ..io.video import write_video

    path = directory / "sbs.mp4"
    write_video(path, (np.concatenate(pair, axis=1) for pair in pairs()), rate,
                quality=12)
    return path


def _band(args):
    """render() of rows (first, end): a picklable task for a process pool."""
    width, height, dmax, seed, first, end = args
    return render(width, height, dmax, seed, rows=(first, end))[:3]


def write_tiff_scene(directory, width, height, dmax=64, seed=0, band=256, processes=None):
    """Write left.tif, right.tif (uint8) and gt.tif (float32) as tiled TIFFs (BigTIFF when
    large), rendered ``band`` rows at a time by a pool of processes, each band once, so
    that a scene bigger than memory can be made: memory follows width x band x the
    processes.  All three files or none.  Returns their paths."""
    import os
    import queue
    import threading
    from concurrent.futures import ProcessPoolExecutor
    from pathlib import Path

    import tifffile

    from ..io.atomic import atomic_write_all
    from ..io.formats import tiff_tiles

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    tile = 256
    band = max(tile, band // tile * tile)  # whole rows of tiles per band
    dtypes = (np.uint8, np.uint8, np.float32)
    paths = [directory / name for name in ("left.tif", "right.tif", "gt.tif")]
    done = object()

    def tiles(q):
        while (item := q.get()) is not done:
            yield item

    def write_all(tmps):
        # One thread per file consumes its tiles; this thread renders and deals them out.
        queues = [queue.Queue(maxsize=4 * -(-width // tile)) for _ in paths]
        errors = []

        def write(tmp, q, dtype):
            try:
                tifffile.imwrite(tmp, tiles(q), shape=(height, width), dtype=dtype,
                                 tile=(tile, tile), photometric="minisblack",
                                 bigtiff=height * width * np.dtype(dtype).itemsize > 2**31)
            except BaseException as exc:  # reported by the renderer below
                errors.append(exc)
                while q.get() is not done:  # drain, so the renderer never blocks
                    pass

        threads = [threading.Thread(target=write, args=(t, q, d))
                   for t, q, d in zip(tmps, queues, dtypes, strict=True)]
        for t in threads:
            t.start()
        try:
            jobs = [(width, height, dmax, seed, first, min(height, first + band))
                    for first in range(0, height, band)]
            with ProcessPoolExecutor(processes or os.cpu_count() or 1) as pool:
                for images in pool.map(_band, jobs):
                    for image, q, dtype in zip(images, queues, dtypes, strict=True):
                        blocks = (image[top:top + tile] for top in range(0, len(image), tile))
                        for piece in tiff_tiles(blocks, width, dtype, tile=tile):
                            q.put(piece)
        finally:
            for q in queues:
                q.put(done)
            for t in threads:
                t.join()
        if errors:
            raise errors[0]

    # atomic_write_all writes its files one after another; here one call writes all
    # three, into the temporary paths it hands out.
    staged = []

    def stage(tmp):
        staged.append(tmp)
        if len(staged) == len(paths):
            write_all(staged)

    atomic_write_all([(path, stage) for path in paths])
    return paths

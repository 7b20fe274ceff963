"""Reading stereo images and writing disparity maps, atomically.

Conventions:
  * input images become uint8/uint16 gray: colour by ITU-R 601-2 luma with Pillow's
    integer rounding (``convert("L")``), alpha dropped, palettes expanded to values;
  * disparity maps are float32 with inf (PFM) or 0 (PNG) for invalid pixels.
"""

import os
import tempfile
from pathlib import Path

import numpy as np


class ImageError(Exception):
    """An input file that can't be used as a stereo image; the message says why."""


def luma(rgb):
    """ITU-R 601-2 luma of an (H, W, 3) uint8/uint16 array, rounded as Pillow does.

    Pillow's convert("L") computes (R*19595 + G*38470 + B*7471 + 0x8000) >> 16.
    """
    r, g, b = (rgb[..., i].astype(np.int64) for i in range(3))
    return ((r * 19595 + g * 38470 + b * 7471 + 0x8000) >> 16).astype(rgb.dtype)


def to_gray(image, name="image"):
    """Normalise a decoded image array to uint8/uint16 (H, W)."""
    image = np.asarray(image)
    if image.dtype == np.bool_:
        image = image.astype(np.uint8) * 255
    if image.dtype not in (np.uint8, np.uint16):
        raise ImageError(f"{name}: pixels are {image.dtype}; csw reads 8- or 16-bit images")
    if image.ndim == 3:
        channels = image.shape[2]
        if channels == 1:
            image = image[..., 0]
        elif channels == 2:  # gray + alpha
            image = image[..., 0]
        elif channels in (3, 4):  # RGB(A): alpha dropped
            image = luma(image[..., :3])
        else:
            raise ImageError(f"{name}: {channels} channels; expected gray, RGB or RGBA")
    if image.ndim != 2:
        raise ImageError(f"{name}: expected a single 2-D image, got shape {image.shape}")
    if min(image.shape) < 1:
        raise ImageError(f"{name}: the image is empty")
    return np.ascontiguousarray(image)


def read_image(path):
    """Read an image file as uint8/uint16 gray (H, W); raise ImageError when unusable."""
    import imageio.v3 as iio

    path = Path(path)
    if path.suffix.lower() == ".pfm":
        raise ImageError(f"{path}: PFM holds float data; give an 8- or 16-bit image")
    try:
        # Pillow decodes every format csw reads (PNG, PPM/PGM, TIFF, BMP, JPEG), expands
        # palettes to their colours, and fails fast on anything else; index=0 takes the
        # first frame of multi-frame files.
        image = iio.imread(path, plugin="pillow", index=0)
    except FileNotFoundError:
        raise ImageError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise ImageError(f"{path}: is a directory, not an image") from None
    except PermissionError:
        raise ImageError(f"{path}: permission denied") from None
    except Exception as exc:  # imageio raises many types for undecodable data
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ImageError(f"{path}: not a readable image ({reason[:120]})") from None
    return to_gray(image, str(path))


def read_pfm(path):
    """Read a PFM file as float32 (H, W) (top row first); raise ImageError if malformed."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            kind = f.readline().strip()
            if kind not in (b"Pf", b"PF"):
                raise ImageError(f"{path}: not a PFM file")
            dims = f.readline().split()
            while not dims:  # tolerate blank lines
                dims = f.readline().split()
            width, height = int(dims[0]), int(dims[1])
            scale = float(f.readline().strip())
            channels = 3 if kind == b"PF" else 1
            dtype = "<f4" if scale < 0 else ">f4"
            data = np.fromfile(f, dtype=dtype, count=width * height * channels)
    except (OSError, ValueError, IndexError) as exc:
        raise ImageError(f"{path}: not a readable PFM ({exc})") from None
    if data.size != width * height * channels:
        raise ImageError(f"{path}: PFM is truncated")
    data = data.reshape(height, width, channels)[..., 0] if channels == 3 else \
        data.reshape(height, width)
    return np.flipud(data).astype(np.float32)


def read_disparity(path, scale=None):
    """Read a disparity map as float32 (H, W) with nan for unknown.

    PFM: as stored, inf/nan unknown.  PNG 16-bit: KITTI value/256, 0 unknown.
    8-bit images (Middlebury GT): value / scale, 0 unknown.  ``scale`` overrides.
    .npy: as stored, negative or non-finite unknown.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".pfm":
        disp = read_pfm(path)
        disp = np.where(np.isfinite(disp), disp, np.nan).astype(np.float32)
        return disp / scale if scale else disp
    if suffix == ".npy":
        try:
            disp = np.load(path, allow_pickle=False).astype(np.float32)
        except Exception as exc:
            raise ImageError(f"{path}: not a readable .npy array ({exc})") from None
        if disp.ndim != 2:
            raise ImageError(f"{path}: expected a 2-D array, got shape {disp.shape}")
        disp[~np.isfinite(disp) | (disp < 0)] = np.nan
        return disp / scale if scale else disp
    raw = read_image(path)
    if scale is None:
        scale = 256.0 if raw.dtype == np.uint16 else 1.0
    disp = raw.astype(np.float32) / float(scale)
    disp[raw == 0] = np.nan
    return disp


def _pfm_bytes(disp):
    """Middlebury v3 PFM: 'Pf', width height, -1 (little-endian), rows bottom to top."""
    disp = np.asarray(disp, dtype="<f4")
    height, width = disp.shape
    header = f"Pf\n{width} {height}\n-1\n".encode("ascii")
    return header + np.flipud(disp).tobytes()


def as_float_disparity(disp, dtype=np.float64):
    """A disparity map in any of csw's conventions (int with -1 invalid, float with
    NaN/inf or negative invalid) -> float (H, W) with NaN invalid."""
    out = np.asarray(disp).astype(dtype)
    out[~np.isfinite(out) | (out < 0)] = np.nan
    return out


def disparity_to_file_float(disp):
    """float32 (H, W) with inf invalid: what PFM and NPY outputs hold."""
    out = as_float_disparity(disp, np.float32)
    out[np.isnan(out)] = np.inf
    return out


def atomic_write(path, write_to):
    """Write ``path`` by calling ``write_to(tmp_path)`` then renaming, so a failure or an
    interrupt never leaves a partial file at ``path``."""
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    os.close(fd)
    try:
        write_to(tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


OUTPUT_SUFFIXES = (".pfm", ".png", ".npy")
PNG_MAX_DISPARITY = 65535 / 256  # KITTI: uint16 value = d * 256


def write_disparity(path, disp):
    """Write a disparity map (H, W), int with -1 invalid or float with NaN/inf invalid,
    in the format of path's suffix.

    .pfm float32, inf invalid; .png uint16 round(d*256), 0 invalid; .npy float32, inf invalid.
    """
    import imageio.v3 as iio

    suffix = Path(path).suffix.lower()
    if suffix == ".pfm":
        payload = _pfm_bytes(disparity_to_file_float(disp))
        atomic_write(path, lambda tmp: Path(tmp).write_bytes(payload))
    elif suffix == ".png":
        values = as_float_disparity(disp)
        if np.nanmax(values, initial=0) > PNG_MAX_DISPARITY:
            raise ValueError("disparities above 255 don't fit a 16-bit PNG; write .pfm")
        # KITTI stores 0 for invalid, so d = 0 is indistinguishable from invalid there.
        png = np.where(np.isfinite(values), np.round(values * 256), 0).astype(np.uint16)
        atomic_write(path, lambda tmp: iio.imwrite(tmp, png, extension=".png"))
    elif suffix == ".npy":
        arr = disparity_to_file_float(disp)

        def save(tmp):
            with open(tmp, "wb") as f:
                np.save(f, arr)

        atomic_write(path, save)
    else:
        raise ValueError(f"unknown output extension {suffix!r}; use .pfm, .png or .npy")


def write_float_pfm(path, values):
    """Write a float32 (H, W) map to PFM atomically (inf where not finite)."""
    values = np.where(np.isfinite(values), values, np.inf).astype(np.float32)
    payload = _pfm_bytes(values)
    atomic_write(path, lambda tmp: Path(tmp).write_bytes(payload))


def colorize(disp, dmax):
    """uint8 (H, W, 3) visualisation of a disparity map (any of csw's conventions): a
    blue-to-red ramp, invalid black. Piecewise-linear 'jet' anchors, so no plotting
    library is needed."""
    anchors = np.array([[0, 0, 128], [0, 0, 255], [0, 255, 255], [255, 255, 0],
                        [255, 0, 0], [128, 0, 0]], dtype=np.float64)
    disp = as_float_disparity(disp)
    invalid = np.isnan(disp)
    t = np.clip(np.nan_to_num(disp) / max(dmax, 1), 0, 1) * (len(anchors) - 1)
    lo = np.floor(t).astype(int)
    hi = np.minimum(lo + 1, len(anchors) - 1)
    frac = (t - lo)[..., None]
    rgb = anchors[lo] * (1 - frac) + anchors[hi] * frac
    rgb[invalid] = 0
    return np.round(rgb).astype(np.uint8)


def write_png(path, image):
    import imageio.v3 as iio

    atomic_write(path, lambda tmp: iio.imwrite(tmp, image, extension=".png"))

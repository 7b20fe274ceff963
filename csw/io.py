"""Reading stereo images and writing disparity maps, atomically.

Conventions:
  * input images become uint8/uint16 gray: colour by ITU-R 601-2 luma with Pillow's
    integer rounding (``convert("L")``), alpha dropped, palettes expanded to values;
    16-bit colour PNGs keep their 16 bits (read with pypng: Pillow would cut them to 8);
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
    _pixel_limit()
    if _is_16bit_colour_png(path):
        return to_gray(_read_png16(path), str(path))
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
        too_large = _too_large(exc)
        if too_large:
            raise ImageError(f"{path}: {too_large}") from None
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ImageError(f"{path}: not a readable image ({reason[:120]})") from None
    return to_gray(image, str(path))


def _is_16bit_colour_png(path):
    """Whether ``path`` is a PNG with 16-bit RGB(A) pixels, which Pillow would cut to 8
    bits: its IHDR says bit depth 16 and colour type 2 (RGB) or 6 (RGBA)."""
    try:
        with open(path, "rb") as f:
            head = f.read(26)
    except OSError:
        return False  # the normal path reports the error
    return (len(head) == 26 and head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR"
            and head[24] == 16 and head[25] in (2, 6))


def _read_png16(path):
    """A 16-bit RGB(A) PNG as uint16 (H, W, 3|4), with pypng (Pillow has no such mode)."""
    import png

    try:
        width, height, rows, info = png.Reader(filename=str(path)).asDirect()
        planes = info["planes"]
        image = np.vstack([np.asarray(row, np.uint16) for row in rows])
    except (png.Error, ValueError, OSError) as exc:
        raise ImageError(f"{path}: not a readable image ({str(exc)[:120]})") from None
    return image.reshape(height, width, planes)


def _pixel_limit():
    """Pillow's decompression-bomb limit, raised by CSW_MAX_PIXELS where set."""
    from PIL import Image

    value = os.environ.get("CSW_MAX_PIXELS")
    if value:
        try:
            Image.MAX_IMAGE_PIXELS = int(value) // 2  # Pillow refuses at twice this
        except ValueError:
            raise ImageError(f"CSW_MAX_PIXELS must be a whole number, got {value!r}") from None


def _too_large(exc):
    """The message for an image over Pillow's decompression-bomb limit, else None.
    imageio wraps Pillow's error, so the chain is searched."""
    from PIL import Image

    while exc is not None:
        if isinstance(exc, Image.DecompressionBombError):
            return (f"the image is larger than the decoder's safety limit of "
                    f"{Image.MAX_IMAGE_PIXELS * 2} pixels ({exc}); set "
                    "CSW_MAX_PIXELS to a larger number to allow it")
        exc = exc.__cause__ or exc.__context__
    return None


def read_pfm(path):
    """Read a PFM file as float32 (H, W) (top row first); raise ImageError if malformed.

    The header is checked against the file's size before anything is allocated, so a
    header that claims a huge image fails at once."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            kind = f.readline(16).strip()
            if kind not in (b"Pf", b"PF"):
                raise ImageError(f"{path}: not a PFM file")
            dims = f.readline(64).split()
            while not dims:  # tolerate blank lines
                dims = f.readline(64).split()
            width, height = int(dims[0]), int(dims[1])
            scale = float(f.readline(64).strip())
            channels = 3 if kind == b"PF" else 1
            if width < 1 or height < 1 or len(dims) != 2:
                raise ImageError(f"{path}: PFM header gives a size of {width}x{height}")
            if not np.isfinite(scale) or scale == 0:
                raise ImageError(f"{path}: PFM scale must be a non-zero number (its sign "
                                 f"gives the byte order), got {scale}")
            expected = width * height * channels * 4
            available = os.fstat(f.fileno()).st_size - f.tell()
            if available < expected:
                raise ImageError(f"{path}: PFM header says {width}x{height}, which needs "
                                 f"{expected} bytes of data; the file has {available}")
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


def pfm_header(width, height):
    """Middlebury v3 PFM's header: 'Pf', width height, -1 (little-endian); the rows
    follow bottom to top."""
    return f"Pf\n{width} {height}\n-1\n".encode("ascii")


def _pfm_bytes(disp):
    disp = np.asarray(disp, dtype="<f4")
    height, width = disp.shape
    return pfm_header(width, height) + np.flipud(disp).tobytes()


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


TMP_PREFIX = ".csw-tmp."  # temporary files: .csw-tmp.<name>.<random>.tmp beside the target
STALE_SECONDS = 24 * 3600  # a temporary file this old was left by a killed process


def _mode_for(path):
    """The mode a plain open() would give ``path``: an existing file keeps its own, a new
    one gets 0666 less the umask (mkstemp's files are 0600 whatever the umask)."""
    try:
        return os.stat(path).st_mode & 0o7777
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def _clean_stale(directory, name):
    """Remove this target's temporary files that a killed process left behind (older
    than a day, so that a concurrent writer's file is never touched)."""
    import time

    now = time.time()
    for old in Path(directory).glob(f"{TMP_PREFIX}{name}.*.tmp"):
        try:
            if now - old.stat().st_mtime > STALE_SECONDS:
                old.unlink()
        except OSError:
            pass


def remove_temporaries(path):
    """Remove every temporary file of target ``path``, whatever its age: for a caller that
    knows no writer of it is still running (a batch whose tasks have all finished, after
    a killed worker left one behind)."""
    path = Path(path)
    for tmp in path.parent.glob(f"{TMP_PREFIX}{path.name}.*.tmp"):
        try:
            tmp.unlink()
        except OSError:
            pass


def atomic_write(path, write_to):
    """Write ``path`` by calling ``write_to(tmp_path)`` then renaming, so a failure or an
    interrupt never leaves a partial file at ``path``.

    The file gets the mode a normal write gives (an existing file's, else 0666 less the
    umask); a symlink is followed, and its target written (atomically) in place.
    """
    atomic_write_all([(path, write_to)])


def atomic_write_all(items):
    """Several files as one: every ``(path, write_to)`` is written to its temporary file
    first, and only when all succeeded are they renamed into place, so an error or a
    Ctrl-C leaves either all of them or none (save for the instant of the renames)."""
    staged = []
    try:
        for path, write_to in items:
            path = Path(os.path.realpath(path)) if os.path.islink(path) else Path(path)
            directory = path.parent if str(path.parent) else Path(".")
            _clean_stale(directory, path.name)
            fd, tmp = tempfile.mkstemp(prefix=f"{TMP_PREFIX}{path.name}.", suffix=".tmp",
                                       dir=directory)
            os.close(fd)
            staged.append((tmp, path))
            write_to(tmp)
            os.chmod(tmp, _mode_for(path))
        for tmp, path in staged:
            os.replace(tmp, path)
    except BaseException:
        for tmp, _ in staged:
            if os.path.exists(tmp):
                os.unlink(tmp)
        raise


OUTPUT_SUFFIXES = (".pfm", ".png", ".npy")
PNG_MAX_DISPARITY = 65535 / 256  # KITTI: uint16 value = d * 256


def disparity_writer(path, disp):
    """A ``write_to(tmp)`` that writes a disparity map (H, W) in the format of path's
    suffix: int with -1 invalid or float with NaN/inf invalid, as
    .pfm float32, inf invalid; .png uint16 round(d*256), 0 invalid; .npy float32, inf
    invalid.  ValueError for an unknown suffix or a map a PNG can't hold."""
    suffix = Path(path).suffix.lower()
    if suffix == ".pfm":
        return pfm_writer(disparity_to_file_float(disp))
    if suffix == ".png":
        return png_writer(kitti_png_values(disp))
    if suffix == ".npy":
        arr = disparity_to_file_float(disp)

        def save(tmp):
            with open(tmp, "wb") as f:
                np.save(f, arr)

        return save
    raise ValueError(f"unknown output extension {suffix!r}; use .pfm, .png or .npy")


def kitti_png_values(disp):
    """A disparity map (any of csw's conventions) as KITTI's uint16 round(d * 256), 0
    where invalid; ValueError when a disparity is too large for 16 bits."""
    values = as_float_disparity(disp)
    if np.nanmax(values, initial=0) > PNG_MAX_DISPARITY:
        raise ValueError("disparities above 255 don't fit a 16-bit PNG; write .pfm")
    # KITTI stores 0 for invalid, so d = 0 is indistinguishable from invalid there.
    return np.where(np.isfinite(values), np.round(values * 256), 0).astype(np.uint16)


def tiff_tiles(blocks, width, dtype, fill=0, tile=256):
    """(tile, tile) tiles in a TIFF's order from row blocks of ``tile`` rows each (the
    last may be shorter), padded with ``fill`` past the image's edges: what tifffile
    writes a tiled image from, a band at a time."""
    for block in blocks:
        padded = np.full((tile, -(-width // tile) * tile), fill, dtype)
        padded[:block.shape[0], :width] = block
        for x in range(0, width, tile):
            yield padded[:, x:x + tile]


def pfm_writer(values):
    """A ``write_to(tmp)`` for a float32 (H, W) map as PFM (inf where not finite)."""
    payload = _pfm_bytes(np.where(np.isfinite(values), values, np.inf).astype(np.float32))
    return lambda tmp: Path(tmp).write_bytes(payload)


def png_writer(image):
    """A ``write_to(tmp)`` for a uint8/uint16 image as PNG."""
    import imageio.v3 as iio

    return lambda tmp: iio.imwrite(tmp, image, extension=".png")


def write_disparity(path, disp):
    """Write a disparity map atomically; formats as for :func:`disparity_writer`."""
    atomic_write(path, disparity_writer(path, disp))


def write_float_pfm(path, values):
    """Write a float32 (H, W) map to PFM atomically (inf where not finite)."""
    atomic_write(path, pfm_writer(values))


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
    """Write a uint8/uint16 image as PNG atomically."""
    atomic_write(path, png_writer(image))

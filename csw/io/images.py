"""Reading stereo images as gray uint8/uint16 arrays.

Conventions: colour by ITU-R 601-2 luma with Pillow's integer rounding
(``convert("L")``), alpha dropped, palettes expanded to values; 16-bit colour PNGs keep
their 16 bits (read with pypng: Pillow would cut them to 8).
"""

import os
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


def read_colour(path):
    """An image file as it is, for colours: uint8/uint16 (H, W) gray or (H, W, 3) RGB
    (alpha dropped, palettes expanded); ImageError when unusable."""
    import imageio.v3 as iio

    path = Path(path)
    if _is_16bit_colour_png(path):
        image = _read_png16(path)
    else:
        try:
            image = iio.imread(path, plugin="pillow", index=0)
        except FileNotFoundError:
            raise ImageError(f"{path}: no such file") from None
        except Exception as exc:
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise ImageError(f"{path}: not a readable image ({reason[:120]})") from None
    if image.ndim == 3 and image.shape[2] == 2:  # gray + alpha
        image = image[..., 0]
    return np.ascontiguousarray(image[..., :3] if image.ndim == 3 else image)


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



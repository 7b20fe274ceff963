"""Reading stereo images as gray uint8/uint16 arrays.

Conventions: colour by ITU-R 601-2 luma with Pillow's integer rounding
(``convert("L")``), alpha dropped, palettes expanded to values; 16-bit colour PNGs keep
their 16 bits (read with pypng: Pillow would cut them to 8).
"""

import contextlib
import logging
import os
import threading
from pathlib import Path

import numpy as np

from ..kernels import colour
from . import safety


class ImageError(ValueError):
    """An input file that can't be used as a stereo image; the message says why (a
    ValueError, as every bad input to csw is)."""


def luma(rgb):
    """ITU-R 601-2 luma of an (H, W, 3) RGB or (H, W, 4) RGBA uint8/uint16 array (alpha
    dropped), rounded as Pillow's convert("L"): (R*19595 + G*38470 + B*7471 + 0x8000)
    >> 16, in csw's colour kernel (kernels/colour.py).  At 1282x1110 it takes about 0.9
    ms here, where Pillow (in two row bands on two threads, with its copies in and out)
    took 2.3-6 ms, and the formula in numpy's 64-bit lanes 5.5."""
    return colour.luma(rgb)


def to_gray(image, name="image"):
    """Normalise a decoded image array to uint8/uint16 (H, W), in the machine's byte
    order (a big-endian 16-bit TIFF's pixels are byte-swapped, not refused)."""
    image = np.asarray(image)
    if image.dtype == np.bool_:
        image = image.astype(np.uint8) * 255
    if image.dtype.kind == "u" and not image.dtype.isnative:
        image = image.astype(image.dtype.newbyteorder("="))
    if image.dtype not in (np.uint8, np.uint16):
        raise ImageError(f"{name}: pixels are {image.dtype}; csw reads 8- or 16-bit images")
    if image.ndim == 3:
        channels = image.shape[2]
        if channels == 1:
            image = image[..., 0]
        elif channels == 2:  # gray + alpha
            image = image[..., 0]
        elif channels in (3, 4):  # RGB(A): alpha dropped (not copied: luma skips it)
            image = luma(image)
        else:
            raise ImageError(f"{name}: {channels} channels; expected gray, RGB or RGBA")
    if image.ndim != 2:
        raise ImageError(f"{name}: expected a single 2-D image, got shape {image.shape}")
    if min(image.shape) < 1:
        raise ImageError(f"{name}: the image is empty")
    return np.ascontiguousarray(image)


# Pillow's own refusal point for decompression bombs (twice its MAX_IMAGE_PIXELS): the
# largest image csw decodes unless CSW_MAX_PIXELS says otherwise.
DEFAULT_MAX_PIXELS = 178_956_970


def max_pixels():
    """The pixel limit: CSW_MAX_PIXELS where set, else DEFAULT_MAX_PIXELS; a ValueError
    whose ``variable`` names CSW_MAX_PIXELS when it is no limit (the CLI then blames the
    variable, not the image it was reading)."""
    value = os.environ.get("CSW_MAX_PIXELS", "").strip()
    if not value:
        return DEFAULT_MAX_PIXELS
    try:
        limit = int(value)
    except ValueError:
        limit = None
    if limit is None or limit < 1:
        error = ValueError(f"CSW_MAX_PIXELS must be a whole number of at least 1, got "
                           f"{value[:40]!r}")
        error.variable = "CSW_MAX_PIXELS"
        raise error
    return limit


def check_pixels(shape, path, striped=False, can_stripe=False):
    """ImageError when an image of ``shape`` (H, W), as its header declares it, is over
    the pixel limit: a hostile or mistaken header must not start a run that allocates
    or writes without bound.  striped: the user asked for a striped match with a memory
    limit, which bounds its memory, so the limit does not apply.  can_stripe: the
    caller could match it so (a pair's match), and the message says how."""
    height, width = (int(n) for n in shape[:2])
    limit = max_pixels()
    if height * width > limit and not striped:
        raise ImageError(f"{path}: the image is {width}x{height}, {height * width} pixels, "
                         f"more than the safety limit of {limit}; set CSW_MAX_PIXELS to a "
                         "larger number" + (", or give a memory limit (--memory-limit) to "
                                            "match it in stripes" if can_stripe else ""))


def read_image(path):
    """Read an image file as uint8/uint16 gray (H, W); raise ImageError when unusable."""
    path = Path(path)
    safety.protect(path)
    if path.suffix.lower() == ".pfm":
        raise ImageError(f"{path}: PFM holds float data; give an 8- or 16-bit image")
    return to_gray(_decode(path, gray=True), str(path))


def read_colour(path):
    """An image file as it is, for colours: uint8/uint16 (H, W) gray or (H, W, 3) RGB
    (alpha dropped, palettes expanded, CMYK converted); ImageError when unusable."""
    path = Path(path)
    safety.protect(path)
    image = _decode(path)
    if image.dtype.kind == "u" and not image.dtype.isnative:
        image = image.astype(image.dtype.newbyteorder("="))
    if image.ndim == 3 and image.shape[2] == 2:  # gray + alpha
        image = image[..., 0]
    return np.ascontiguousarray(image[..., :3] if image.ndim == 3 else image)


def _decode(path, gray=False):
    """An image file's pixels as stored (H, W) or (H, W, C), after its header passed the
    pixel limit; ImageError, one line, when it can't be read.  gray: an 8-bit RGB or
    RGBA file may come as its luma (H, W), converted by Pillow from the decoded image,
    which spares a copy of the colour pixels into numpy and back (luma's own path).

    16-bit PNGs with colour or alpha are read with pypng (Pillow cuts them to 8 bits),
    TIFFs with tifffile (as the striped path reads them, so both see the same pixels),
    CMYK (JPEG) converted to RGB, everything else by Pillow through imageio (palettes
    expanded, the first frame of multi-frame files)."""
    png16 = png16_header(path)  # the file's kind checked first, in png16_header
    if png16 is not None:
        check_pixels(png16, path)
        return _read_png16(path)
    mode, kind, shape = image_header(path)
    check_pixels(shape, path)
    if kind == "TIFF":
        tiff = Tiff(path)
        try:
            return tiff.rows(0, tiff.shape[0])
        except ImageError:
            raise
        except Exception as exc:  # decoders raise many types for damaged data
            raise ImageError(f"{path}: not a readable TIFF ({error_reason(exc)})") from None
    try:
        with quiet_decoders():
            if mode == "CMYK" or (gray and mode in ("RGB", "RGBA")):
                from PIL import Image

                with Image.open(path) as image:
                    return np.asarray(image.convert("L" if gray and mode != "CMYK"
                                                    else "RGB"))
            import imageio.v3 as iio

            return iio.imread(path, plugin="pillow", index=0)
    except Exception as exc:  # decoders raise many types for damaged data
        raise ImageError(f"{path}: not a readable image ({error_reason(exc)})") from None


def error_reason(exc):
    """An error's first line (or its type's name) for a one-line message."""
    return (str(exc).splitlines()[0] if str(exc) else type(exc).__name__)[:120]


def image_header(path):
    """(mode, format, (H, W)) from the file's header, read by Pillow without decoding
    the pixels; ImageError saying why when it can't be opened."""
    from PIL import Image

    safety.check_input(path, "an image file", ImageError)  # before open: a pipe blocks it
    try:
        with quiet_decoders(), Image.open(path) as image:
            return image.mode, image.format, (image.height, image.width)
    except FileNotFoundError:
        raise ImageError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise ImageError(f"{path}: is a directory, not an image") from None
    except PermissionError:
        raise ImageError(f"{path}: permission denied") from None
    except OSError as exc:
        if exc.errno is not None and exc.strerror:  # a system error, not the data's
            raise ImageError(f"{path}: can't read it ({exc.strerror})") from None
        raise ImageError(f"{path}: not a readable image ({error_reason(exc)})") from None
    except Exception as exc:
        raise ImageError(f"{path}: not a readable image ({error_reason(exc)})") from None


def png16_header(path):
    """(H, W) of a PNG with 16-bit pixels and colour or alpha, which Pillow would cut to
    8 bits (IHDR: bit depth 16, colour type 2 RGB, 4 gray + alpha or 6 RGBA); None for
    any other file."""
    safety.check_input(path, "an image file", ImageError)  # before open: a pipe blocks it
    try:
        with open(path, "rb") as f:
            head = f.read(26)
    except OSError:
        return None  # the normal path reports the error
    if (len(head) == 26 and head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR"
            and head[24] == 16 and head[25] in (2, 4, 6)):
        width, height = int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
        return height, width
    return None


def _read_png16(path):
    """A 16-bit PNG with colour or alpha as uint16 (H, W, planes), with pypng."""
    import png

    try:
        width, height, rows, info = png.Reader(filename=str(path)).asDirect()
        planes = info["planes"]
        image = np.vstack([np.asarray(row, np.uint16) for row in rows])
        return image.reshape(height, width, planes)
    except Exception as exc:  # pypng, zlib and numpy errors for damaged data
        raise ImageError(f"{path}: not a readable image ({error_reason(exc)})") from None


def npy_header(handle, path):
    """(shape, dtype, data offset) of the .npy file open in ``handle``, checked: C order,
    a plain dtype, and as many bytes of data as the shape needs, so that a hostile
    header never makes csw allocate what it declares.  ImageError otherwise."""
    try:
        version = np.lib.format.read_magic(handle)
        read = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                else np.lib.format.read_array_header_2_0)
        shape, fortran, dtype = read(handle)
        offset = handle.tell()
        size = os.fstat(handle.fileno()).st_size
    except Exception as exc:  # numpy parses the header as Python literals: any error
        raise ImageError(f"{path}: not a readable .npy array ({error_reason(exc)})") from None
    if fortran or dtype.hasobject or dtype.names or dtype.subdtype:
        raise ImageError(f"{path}: expected a plain array in C order, got {dtype} "
                         f"{'(Fortran order)' if fortran else ''}".rstrip())
    needed = int(np.prod(shape, dtype=object)) * dtype.itemsize
    if size - offset < needed:
        raise ImageError(f"{path}: the .npy file is truncated (its header says {shape}, "
                         f"{needed} bytes; it holds {size - offset})")
    return shape, dtype, offset


def _missing_tiff_data(page, file_size):
    """Why a TIFF page's pixel data is not all in the file, or None: a strip or tile
    that runs past the file's end, or uncompressed strips too short for the image.
    tifffile reads the pixels that are there and fills the rest with zeros, so a header
    of a few bytes would allocate a whole image of them.  (Compressed data may be far
    smaller than its pixels: the pixel limit bounds it.)"""
    segments = [(int(o), int(c)) for o, c in zip(page.dataoffsets, page.databytecounts,
                                                  strict=False) if c]
    if any(offset + count > file_size for offset, count in segments):
        return f"its pixel data runs past the file's end ({file_size} bytes)"
    if page.compression == 1:  # none: each row's bits, padded to whole bytes
        samples = page.samplesperpixel
        row_bytes = -(-page.imagewidth * samples * page.bitspersample // 8)
        needed = row_bytes * page.imagelength * page.imagedepth
        held = sum(count for _, count in segments)
        if held < needed:
            return f"its pixel data holds {held} bytes of the {needed} its header declares"
    return None


class _WhileCswReads(logging.Filter):
    """Drops tifffile's and Pillow's log records (their modules' loggers too) while csw
    reads a file with them (see :func:`quiet_decoders`)."""

    def filter(self, record):
        return not (_QUIET["readers"] and record.name.split(".")[0] in ("tifffile", "PIL"))


_DECODER_FILTER = _WhileCswReads()
# Reads under way, in any thread (zarr decodes a TIFF's chunks in a thread of its own),
# and those that hide Pillow's warnings, with the warnings.catch_warnings the first of
# them entered: the process's warnings filters are one list, so they are changed once
# for all the reads that overlap and put back when the last one ends.
_QUIET = {"readers": 0, "pillow": 0, "caught": None}
_QUIET_LOCK = threading.Lock()


@contextlib.contextmanager
def quiet_decoders(pillow_warnings=True):
    """tifffile and Pillow hidden while csw reads a file with them.  They log what they
    find wrong in it (an offset past the end, a tag of an unknown type, more samples
    than they decode), which logging's last resort prints on stderr where nothing is
    configured (a filter there drops them; a program that configured logging still gets
    them), and Pillow warns of damage it reads past (a directory cut short, corrupt EXIF
    data).  csw reads the file or refuses it with its own one-line error (the pixel
    limit is its own: check_pixels), so those lines would be a second message.  While a
    read is under way, other code's records and warnings of the two are hidden too.
    pillow_warnings=False leaves the warnings filters alone (a TIFF's rows, read by
    tifffile)."""
    import warnings

    from PIL import Image

    Image.MAX_IMAGE_PIXELS = None  # the limit is csw's own (check_pixels)
    with _QUIET_LOCK:
        if logging.lastResort is not None:
            logging.lastResort.addFilter(_DECODER_FILTER)  # once: a set of filters
        _QUIET["readers"] += 1
        if pillow_warnings:
            if _QUIET["pillow"] == 0:
                _QUIET["caught"] = warnings.catch_warnings()
                _QUIET["caught"].__enter__()
                warnings.filterwarnings("ignore", category=UserWarning, module=r"PIL\.")
            _QUIET["pillow"] += 1
    try:
        yield
    finally:
        with _QUIET_LOCK:
            _QUIET["readers"] -= 1
            if pillow_warnings:
                _QUIET["pillow"] -= 1
                if _QUIET["pillow"] == 0:
                    _QUIET["caught"].__exit__(None, None, None)
                    _QUIET["caught"] = None


class Tiff:
    """A TIFF or BigTIFF's first page, read through tifffile's zarr view, so that rows
    are decoded only as they are asked for.  shape: (H, W); colour: it has channels."""

    def __init__(self, path):
        with quiet_decoders(pillow_warnings=False):
            self._open(path)

    def _open(self, path):
        import tifffile
        import zarr

        self.path = Path(path)
        try:
            with tifffile.TiffFile(self.path) as tif:
                page = tif.pages.first
                self._separate = page.planarconfig == tifffile.PLANARCONFIG.SEPARATE
                # Refused when rows are asked for, after the header's size has met
                # the pixel limit, whose message says what to do.
                self._missing = _missing_tiff_data(page, tif.filehandle.size)
            self._store = tifffile.imread(self.path, aszarr=True, key=0)
            self._array = zarr.open(self._store, mode="r")
        except (KeyError, IndexError):  # tifffile found no page where the header points
            raise ImageError(f"{self.path}: not a readable TIFF (no image where its header "
                             "points)") from None
        except Exception as exc:  # a damaged header raises many types (struct.error,
            # TypeError from a tag of the wrong count ...)
            raise ImageError(f"{self.path}: not a readable TIFF ({error_reason(exc)})") \
                from None
        shape = self._array.shape
        if self._separate and len(shape) == 3:
            shape = (shape[1], shape[2], shape[0])
        if len(shape) not in (2, 3):
            raise ImageError(f"{self.path}: expected one 2-D image, got shape {shape}")
        self.shape = tuple(int(n) for n in shape[:2])
        self.colour = len(shape) == 3

    def rows(self, r0, r1):
        """Rows r0..r1-1 as stored: (n, W) or (n, W, C)."""
        if self._missing:
            raise ImageError(f"{self.path}: the TIFF is truncated or damaged: "
                             f"{self._missing}")
        with quiet_decoders(pillow_warnings=False):
            if self._separate and len(self._array.shape) == 3:
                return np.asarray(np.moveaxis(self._array[:, r0:r1], 0, -1))
            return np.asarray(self._array[r0:r1])

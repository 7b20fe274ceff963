"""Stereo images read by rows, so that a pair bigger than memory is read a stripe at a time.

A source has ``shape`` (H, W), ``dtype`` (uint8 or uint16, as gray) and ``rows(r0, r1)``,
which returns the gray rows r0..r1-1 as uint8/uint16 (r1 - r0, W), colour converted as
:func:`csw.io.to_gray` does for a whole image.  What is read by window:

  .tif/.tiff  tiled or striped TIFF and BigTIFF: only the tiles or strips the rows cross
              (tifffile, through its zarr view); the first page of a multi-page file
  .npy        memory-mapped
  .zarr       a 2-D (or H x W x channels) zarr array
  arrays      anything sliceable with a shape and dtype (numpy, memmap, zarr)

Other formats (PNG, PPM, JPEG ...) can't be read by rows: the whole image is decoded, on
first use, and kept for the stripes that follow.

Sources opened from paths pickle as their path, so Dask ships them to workers, which
open the file themselves.
"""

import functools
import os
from pathlib import Path

import numpy as np

from . import safety
from .formats import FORMATS
from .images import (
    ImageError,
    Tiff,
    check_pixels,
    image_header,
    npy_header,
    png16_header,
    read_image,
    to_gray,
)


def open_source(image, name="image", probe=True, striped=False, can_stripe=False):
    """A row source for a path or an array; ImageError, one line, when unusable.  The
    file is checked now (header, the pixel limit, pixel type, and with ``probe`` one row
    decoded) so that a bad input fails before any work.  striped: the caller matches in
    stripes under a memory limit the user gave; can_stripe: it could (see
    csw.io.images.check_pixels)."""
    if isinstance(image, (str, Path)):
        path = Path(image)
        safety.protect(path)
        safety.check_input(path, "an image file", ImageError)
        try:
            os.stat(path)
        except FileNotFoundError:
            raise ImageError(f"{path}: no such file") from None
        except OSError as exc:  # a name too long, a loop of links ...
            raise ImageError(f"{path}: can't read it ({exc.strerror or exc})") from None
        kind = getattr(FORMATS.get(path.suffix.lower()), "image", None)
        source = {"tiff": TiffSource, "npy": NpySource, "zarr": ZarrSource}.get(
            kind, WholeSource)(path)
        if min(source.shape) < 1:
            raise ImageError(f"{path}: the image is empty ({source.shape[1]}x"
                             f"{source.shape[0]})")
        check_pixels(source.shape, path, striped, can_stripe)
    else:
        source = ArraySource(image, name)
    if probe:
        source.rows(0, 1)  # the pixel type, compression and colour are usable
    return source


def _gray(block, name):
    """Decoded rows (n, W) or (n, W, C) -> uint8/uint16 gray (n, W)."""
    return to_gray(block, name) if block.shape[0] else block.reshape(block.shape[:2])


class _Source:
    """Shared: pickle as the path (the open handle stays behind), check rows.
    ``colour``: rows are converted from colour; ``resident_bytes``: memory held for the
    whole run (a decoded whole image), beside the stripes'."""

    resident_bytes = 0

    def __getstate__(self):
        return {"path": self.path}

    def __setstate__(self, state):
        self.__init__(state["path"])

    def rows(self, r0, r1):
        return _gray(self.raw_rows(r0, r1), str(self.path))

    def raw_rows(self, r0, r1):
        """Rows r0..r1-1 as stored: (n, W) or (n, W, C)."""
        if not 0 <= r0 <= r1 <= self.shape[0]:
            raise IndexError(f"rows {r0}..{r1} outside 0..{self.shape[0]}")
        try:
            return np.asarray(self._read(r0, r1))
        except ImageError:
            raise
        except Exception as exc:  # decoders raise many types for damaged data
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise ImageError(f"{self.path}: can't read rows {r0}..{r1} ({reason[:160]})") \
                from None

    @functools.cached_property
    def dtype(self):
        """The gray rows' dtype (one row decoded, once)."""
        return self.rows(0, 1).dtype


class TiffSource(_Source):
    """A TIFF or BigTIFF, its rows decoded as they are asked for (csw.io.images.Tiff)."""

    def __init__(self, path):
        self.path = Path(path)
        self._tiff = Tiff(self.path)
        self.shape, self.colour = self._tiff.shape, self._tiff.colour

    def _read(self, r0, r1):
        return self._tiff.rows(r0, r1)


class NpySource(_Source):
    """A .npy array (C order), its rows read from the file: a memory map would keep every
    page it touched in the process's memory."""

    def __init__(self, path):
        self.path = Path(path)
        try:
            with open(self.path, "rb") as f:
                shape, dtype, self._offset = npy_header(f, self.path)
        except OSError as exc:
            raise ImageError(f"{self.path}: can't read it ({exc.strerror or exc})") from None
        if len(shape) not in (2, 3):
            raise ImageError(f"{self.path}: expected a 2-D image, got shape {shape}")
        self._dtype, self._shape = dtype, shape
        self._row_bytes = int(np.prod(shape[1:])) * dtype.itemsize
        self.shape = tuple(int(n) for n in shape[:2])
        self.colour = len(shape) == 3

    def _read(self, r0, r1):
        with open(self.path, "rb") as f:
            f.seek(self._offset + r0 * self._row_bytes)
            block = np.fromfile(f, self._dtype, (r1 - r0) * self._row_bytes
                                // self._dtype.itemsize)
        return block.reshape((r1 - r0, *self._shape[1:]))


class ZarrSource(_Source):
    """A zarr array (a .zarr folder)."""

    def __init__(self, path):
        import zarr

        self.path = Path(path)
        try:
            self._array = zarr.open_array(self.path, mode="r")
        except Exception as exc:  # zarr raises several types for a folder it can't read
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise ImageError(f"{self.path}: not a readable zarr array ({reason[:120]})") \
                from None
        if self._array.ndim not in (2, 3):
            raise ImageError(f"{self.path}: expected a 2-D image, got shape "
                             f"{self._array.shape}")
        self.shape = tuple(int(n) for n in self._array.shape[:2])
        self.colour = self._array.ndim == 3

    def _read(self, r0, r1):
        return self._array[r0:r1]


class WholeSource(_Source):
    """A format that can't be read by rows: decoded whole on first use, then sliced.  The
    decoded image is kept per process (the last two files), so the stripe tasks that a
    worker runs for the same pair decode it once."""

    def __init__(self, path):
        self.path = Path(path)
        self.shape = _header_shape(self.path)
        self.colour = False  # converted once, with the whole image
        self.resident_bytes = self.shape[0] * self.shape[1] * 2

    def _read(self, r0, r1):
        return _decoded(self.path)[r0:r1]


_DECODED = {}  # (path, mtime, size) -> gray image, the last two


def _decoded(path):
    stat = path.stat()
    key = (str(path.resolve()), stat.st_mtime_ns, stat.st_size)
    if key not in _DECODED:
        while len(_DECODED) >= 2:
            _DECODED.pop(next(iter(_DECODED)))
        _DECODED[key] = read_image(path)
    return _DECODED[key]


def _header_shape(path):
    """(H, W) from the file's header, without decoding the pixels (ImageError saying why
    it can't be read)."""
    return png16_header(path) or image_header(path)[2]


class ArraySource(_Source):
    """An in-memory (or memory-mapped) array, (H, W) or (H, W, C), uint8/uint16; it
    pickles whole, as any array does."""

    def __init__(self, array, name="image"):
        self.path = name
        self._array = array
        shape = getattr(array, "shape", None)
        if shape is None or len(shape) not in (2, 3):
            raise ImageError(f"{name}: expected a 2-D image array, got shape {shape}")
        self.shape = tuple(int(n) for n in shape[:2])
        self.colour = len(shape) == 3

    def __getstate__(self):
        return self.__dict__

    def __setstate__(self, state):
        self.__dict__.update(state)

    def _read(self, r0, r1):
        return self._array[r0:r1]

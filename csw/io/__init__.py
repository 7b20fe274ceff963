"""Files in and out: images read as gray uint8/uint16 (whole, or by rows for pairs bigger
than memory), disparity maps read and written in the formats of one table, every write
atomic.

  images    reading stereo images (colour by luma, 16-bit kept)
  sources   images read by rows (TIFF tiles, .npy, .zarr) for striped matching
  formats   the table of formats: suffix -> reader, whole writer, stripe writer, limits
  outputs   a pair's outputs, checked before any work and written together (PairOutputs)
  atomic    writes through a temporary file renamed into place
"""

from .atomic import atomic_write, atomic_write_all
from .formats import (
    FORMATS,
    PNG_MAX_DISPARITY,
    as_float_disparity,
    check_map_range,
    colorize,
    disparity_writer,
    pfm_writer,
    png_writer,
    read_disparity,
    read_pfm,
    suffixes,
    write_disparity,
    write_float_pfm,
    write_png,
)
from .images import ImageError, luma, read_image, to_gray

__all__ = ["FORMATS", "PNG_MAX_DISPARITY", "ImageError", "as_float_disparity",
           "atomic_write", "atomic_write_all", "check_map_range", "colorize", "disparity_writer",
           "luma", "pfm_writer", "png_writer", "read_disparity", "read_image", "read_pfm",
           "suffixes", "to_gray", "write_disparity", "write_float_pfm", "write_png"]

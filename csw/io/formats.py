"""File formats, in one table: for each suffix, how an input image is read and how a
disparity map is read and written.  Every suffix list in csw derives from ``FORMATS``, so
a new format is one row here (plus its reader or writers).

Disparity maps in memory are float with NaN for invalid (or int with -1); on disk:

  .pfm        float32, Middlebury v3 (rows bottom to top, scale -1), inf invalid
  .npy        float32, inf invalid
  .png        uint16, d x 256 (KITTI), 0 invalid; holds d <= 255.99
  .tif/.tiff  tiled float32, NaN invalid (GDAL's nodata tag); written a stripe at a time
  .zarr       float32 zarr array, NaN invalid; written a stripe at a time

Stripe writers take ``blocks(rows, bottom_up=False)``, an iterator factory over (start row,
float32 rows) of the map, so that a map bigger than memory is written a band at a time.
"""

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import safety
from .atomic import atomic_write
from .images import ImageError, Tiff, check_pixels, error_reason, npy_header, read_image

PNG_MAX_DISPARITY = 65535 / 256  # KITTI: uint16 value = d * 256
TIFF_TILE = 256


# ---------------------------------------------------------------------------- conventions


def as_float_disparity(disp, dtype=np.float64):
    """A disparity map in any of csw's conventions -> float (H, W) with NaN invalid.
    Integer maps (the kernels'): -1, or int32's minimum for a range reaching below 0, is
    invalid; float maps: NaN or inf is (a negative float is a disparity)."""
    disp = np.asarray(disp)
    out = disp.astype(dtype)
    if np.issubdtype(disp.dtype, np.integer):
        out[(disp == -1) | (disp == np.iinfo(np.int32).min)] = np.nan
    else:
        out[~np.isfinite(out)] = np.nan
    return out


def disparity_to_file_float(disp):
    """float32 (H, W) with inf invalid: what PFM and NPY outputs hold."""
    out = as_float_disparity(disp, np.float32)
    out[np.isnan(out)] = np.inf
    return out


def kitti_png_values(disp):
    """A disparity map (any of csw's conventions) as KITTI's uint16 round(d * 256), 0
    where invalid; ValueError when a disparity is too large for 16 bits."""
    values = as_float_disparity(disp)
    if np.nanmax(values, initial=0) > PNG_MAX_DISPARITY:
        raise ValueError(too_large_message(".png", float(np.nanmax(values))))
    if np.nanmin(values, initial=0) < 0:
        raise ValueError(negative_message(".png"))
    # KITTI stores 0 for invalid, so d = 0 is indistinguishable from invalid there.
    return np.where(np.isfinite(values), np.round(values * 256), 0).astype(np.uint16)


def colorize(disp, dmax, dmin=0):
    """uint8 (H, W, 3) of a disparity map (any of csw's conventions): Turbo over
    dmin..dmax, invalid black (csw.io.pictures; its ``disparity_picture`` adds the colour
    bar)."""
    from .pictures import colour

    return colour(as_float_disparity(disp), dmin, dmax)


# ---------------------------------------------------------------------------- PFM


def pfm_header(width, height):
    """Middlebury v3 PFM's header: 'Pf', width height, -1 (little-endian); the rows
    follow bottom to top."""
    return f"Pf\n{width} {height}\n-1\n".encode("ascii")


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
            line = f.readline(64)
            while line and not line.split():  # tolerate blank lines, not the file's end
                line = f.readline(64)
            dims = line.split()
            if not dims:
                raise ImageError(f"{path}: the PFM header ends before its size")
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
    except ImageError:
        raise
    except (OSError, ValueError, IndexError) as exc:
        raise ImageError(f"{path}: not a readable PFM ({exc})") from None
    if data.size != width * height * channels:
        raise ImageError(f"{path}: PFM is truncated")
    data = data.reshape(height, width, channels)[..., 0] if channels == 3 else \
        data.reshape(height, width)
    return np.flipud(data).astype(np.float32)


def pfm_writer(values):
    """A ``write_to(tmp)`` for a float32 (H, W) map as PFM (inf where not finite)."""
    # One copy, its rows bottom to top, written after the header without another (a
    # video run writes a map a frame: the four copies this took cost 2-4 ms at 640x480).
    rows = np.array(np.flipud(values), "<f4", order="C")  # always a copy: changed below
    rows[~np.isfinite(rows)] = np.inf
    header = pfm_header(rows.shape[1], rows.shape[0])
    return lambda tmp: write_parts(tmp, header, rows.data)


def _pfm_values(disp):
    """A disparity map as pfm_writer takes it: a float map as it is, since pfm_writer's
    one copy already makes every non-finite value inf (disparity_to_file_float's three
    more passes over it cost 1.5 ms of a video's 640x480 frame); an integer map (the
    kernels' -1 invalid) through disparity_to_file_float."""
    disp = np.asarray(disp)
    return disp if np.issubdtype(disp.dtype, np.floating) else disparity_to_file_float(disp)


def write_parts(path, *parts):
    """Write the bytes-like ``parts`` one after another into the file ``path``."""
    with open(path, "wb") as file:
        for part in parts:
            file.write(part)


def png_writer(image):
    """A ``write_to(tmp)`` for a uint8/uint16 image (gray or RGB) as PNG."""
    import imageio.v3 as iio

    def write(tmp):
        # Encoded in memory, then written: a plugin writing to a full disk fails again
        # when it is collected, and that second error would reach the user's terminal.
        if image.dtype == np.uint16 and image.ndim == 3:  # Pillow can't write 16-bit colour
            import io

            import png

            height, width, planes = image.shape
            buffer = io.BytesIO()
            png.Writer(width, height, greyscale=planes < 3, alpha=planes in (2, 4),
                       bitdepth=16).write_array(buffer, image.reshape(-1))
            Path(tmp).write_bytes(buffer.getvalue())
        else:
            Path(tmp).write_bytes(iio.imwrite("<bytes>", image, extension=".png"))
    return write


def _npy_writer(values):
    def save(tmp):
        with open(tmp, "wb") as f:
            np.save(f, values)

    return save


# ---------------------------------------------------------------------------- readers


def load_npy(path):
    """A .npy file's array, its header checked first (see npy_header)."""
    with open(path, "rb") as handle:
        shape, dtype, offset = npy_header(handle, path)
        count = int(np.prod(shape, dtype=object))
        return np.fromfile(handle, dtype, count).reshape(shape)


def _read_float_map(path, scale):
    """PFM or NPY: as stored, non-finite unknown."""
    if path.suffix.lower() == ".pfm":
        disp = read_pfm(path)
        disp = np.where(np.isfinite(disp), disp, np.nan).astype(np.float32)
    else:
        try:
            disp = load_npy(path)
        except OSError as exc:
            raise ImageError(f"{path}: can't read it ({exc.strerror or exc})") from None
        if disp.dtype.kind not in "biuf":
            raise ImageError(f"{path}: expected a map of numbers, got {disp.dtype}")
        disp = disp.astype(np.float32)
        if disp.ndim != 2:
            raise ImageError(f"{path}: expected a 2-D array, got shape {disp.shape}")
        disp[~np.isfinite(disp)] = np.nan
    return disp / scale if scale else disp


def _read_image_map(path, scale):
    """An integer image (ground truth, KITTI PNG): value / scale, 0 unknown; the scale is
    256 for 16-bit images (KITTI) and 1 for 8-bit ones unless given."""
    raw = read_image(path)
    if scale is None:
        scale = 256.0 if raw.dtype == np.uint16 else 1.0
    disp = raw.astype(np.float32) / float(scale)
    disp[raw == 0] = np.nan
    return disp


def _read_array_map(path, scale):
    """A TIFF or a zarr store: a float map (csw's: NaN invalid) as stored, non-finite
    unknown; an integer one as an image map (value / scale, 0 unknown)."""
    if path.suffix.lower() == ".zarr":
        import zarr

        try:
            values = np.asarray(zarr.open_array(path, mode="r"))
        except Exception as exc:  # zarr raises several types for a folder it can't read
            raise ImageError(f"{path}: not a readable zarr array ({error_reason(exc)})") from None
    else:
        tiff = Tiff(path)
        check_pixels(tiff.shape, path)
        try:
            values = tiff.rows(0, tiff.shape[0])
        except Exception as exc:  # decoders raise many types for damaged data
            raise ImageError(f"{path}: not a readable TIFF ({error_reason(exc)})") from None
    if values.dtype.kind != "f":
        return _read_image_map(path, scale)
    if values.ndim != 2:
        raise ImageError(f"{path}: expected a 2-D map, got shape {values.shape}")
    disp = values.astype(np.float32)
    disp[~np.isfinite(disp)] = np.nan
    return disp / scale if scale else disp


def read_disparity(path, scale=None):
    """Read a disparity map (or ground truth) as float32 (H, W), NaN unknown.

    PFM and NPY, and float TIFF and zarr maps (as csw writes them), as stored
    (non-finite unknown); images (PNG, PGM, integer TIFF ...): value / scale, 0 unknown,
    the scale 256 for 16-bit (KITTI) and 1 for 8-bit images unless given (Middlebury
    ground truth: see the dataset's scale).
    """
    path = Path(path)
    if scale is not None and not (math.isfinite(scale) and 1e-30 < scale < 1e30):
        raise ValueError(f"the scale of {path}'s values must be a number between 1e-30 "
                         f"and 1e30, got {scale!r}")
    safety.protect(path)
    safety.check_input(path, "a disparity map file", ImageError)
    return format_of(path, "read").read(path, scale)


# ---------------------------------------------------------------------------- stripe writers


def _tiff_stripes(path, shape, blocks):
    import tifffile

    height, width = shape

    def write(tmp):
        tiles = tiff_tiles((b for _, b in blocks(TIFF_TILE)), width, np.float32, np.nan,
                           TIFF_TILE)
        tifffile.imwrite(tmp, tiles, shape=shape, dtype=np.float32,
                         tile=(TIFF_TILE, TIFF_TILE), bigtiff=height * width * 4 > 2**31,
                         photometric="minisblack",
                         extratags=[(42113, "s", 0, "nan", True)])  # GDAL_NODATA
    return write


def _pfm_stripes(path, shape, blocks):
    height, width = shape

    def write(tmp):
        with open(tmp, "wb") as f:
            f.write(pfm_header(width, height))
            for _, block in blocks(TIFF_TILE, bottom_up=True):
                f.write(np.flipud(disparity_to_file_float(block)).astype("<f4").tobytes())
    return write


def _npy_stripes(path, shape, blocks):
    def write(tmp):
        out = np.lib.format.open_memmap(tmp, mode="w+", dtype="<f4", shape=shape)
        for start, block in blocks(TIFF_TILE):
            out[start:start + block.shape[0]] = disparity_to_file_float(block)
        out.flush()
        del out
    return write


def _png_stripes(path, shape, blocks):
    import png

    height, width = shape

    def write(tmp):
        rows = (row for _, block in blocks(TIFF_TILE) for row in kitti_png_values(block))
        with open(tmp, "wb") as f:
            png.Writer(width, height, greyscale=True, bitdepth=16).write(f, rows)
    return write


def preview_stripes(shape, blocks, dmax, dmin=0):
    """A ``write_to(tmp)`` for the 8-bit colour PNG of a map with its colour bar
    (csw.io.pictures.disparity_picture), the map a band at a time."""
    import itertools

    import png

    from .pictures import bar

    height, width = shape
    under = bar(width, dmin, dmax, "disparity (pixels)")

    def write(tmp):
        rows = itertools.chain((row.reshape(-1) for _, block in blocks(TIFF_TILE)
                                for row in colorize(block, dmax, dmin)),
                               (row.reshape(-1) for row in under))
        with open(tmp, "wb") as f:
            png.Writer(width, height + len(under), greyscale=False, bitdepth=8).write(f, rows)
    return write


def tiff_tiles(blocks, width, dtype, fill=0, tile=TIFF_TILE):
    """(tile, tile) tiles in a TIFF's order from row blocks of ``tile`` rows each (the
    last may be shorter), padded with ``fill`` past the image's edges: what tifffile
    writes a tiled image from, a band at a time."""
    for block in blocks:
        padded = np.full((tile, -(-width // tile) * tile), fill, dtype)
        padded[:block.shape[0], :width] = block
        for x in range(0, width, tile):
            yield padded[:, x:x + tile]


# ---------------------------------------------------------------------------- the table


@dataclass(frozen=True)
class Format:
    """One file format.

    image: how an input image in this format is read: "pillow" (decoded whole), or by
        rows with "tiff", "npy" or "zarr" (csw.io.sources); None: not an image format.
    read: reads a disparity map (path, scale) -> float32 NaN unknown, or None.
    whole: writes a whole map, values -> write_to(tmp), or None.
    stripes: writes a map a stripe at a time, (path, shape, blocks) -> write_to(tmp);
        "store" for a zarr store written in place; None when it can't.
    floats: holds any float (a confidence map too); largest: the largest disparity held.
    invalid: how invalid pixels are stored.
    roles: the other outputs it may be: "depth" (a float depth map), "picture" (a colour
        preview or plot), "costs" (the minimum-cost map), "cloud" (a point cloud).
    stored: how a disparity map is stored in it, for help texts.
    """

    image: str | None = None
    read: object = None
    whole: object = None
    stripes: object = None
    floats: bool = True
    largest: float = float("inf")
    invalid: str = ""
    roles: frozenset = frozenset()
    stored: str = ""


FORMATS = {
    ".pfm": Format(read=_read_float_map,
                   whole=lambda disp: pfm_writer(_pfm_values(disp)),
                   stripes=_pfm_stripes, invalid="inf",
                   roles=frozenset({"depth", "costs"}), stored="float32, inf invalid"),
    ".npy": Format(image="npy", read=_read_float_map,
                   whole=lambda disp: _npy_writer(disparity_to_file_float(disp)),
                   stripes=_npy_stripes, invalid="inf", roles=frozenset({"depth"}),
                   stored="float32, inf invalid"),
    ".png": Format(image="pillow", read=_read_image_map,
                   whole=lambda disp: png_writer(kitti_png_values(disp)),
                   stripes=_png_stripes, floats=False, largest=PNG_MAX_DISPARITY,
                   invalid="0", roles=frozenset({"picture"}),
                   stored="uint16 d*256, 0 invalid, KITTI"),
    ".tif": Format(image="tiff", read=_read_array_map, stripes=_tiff_stripes,
                   invalid="NaN", roles=frozenset({"depth"}),
                   stored="tiled float32, NaN invalid"),
    ".tiff": Format(image="tiff", read=_read_array_map, stripes=_tiff_stripes,
                    invalid="NaN", roles=frozenset({"depth"}),
                    stored="tiled float32, NaN invalid"),
    ".zarr": Format(image="zarr", read=_read_array_map, stripes="store", invalid="NaN",
                    stored="a zarr store, NaN invalid"),
    ".ply": Format(roles=frozenset({"cloud"})),
    ".ppm": Format(image="pillow", read=_read_image_map),
    ".pgm": Format(image="pillow", read=_read_image_map),
    ".pnm": Format(image="pillow", read=_read_image_map),
    ".bmp": Format(image="pillow", read=_read_image_map),
    ".jpg": Format(image="pillow"),
    ".jpeg": Format(image="pillow"),
}


def suffixes(role):
    """The suffixes that can play a role, in the table's order:
      "image"      an input image of csw match (any reader)
      "decoded"    an input image csw.io.read_image decodes whole (what folders of pairs
                   are scanned for)
      "read"       a disparity map or ground truth csw reads
      "whole"      a disparity map written whole (csw.match's maps, batch maps)
      "map"        a disparity map csw match writes (whole or in stripes)
      "stripes"    a disparity map written a stripe at a time
      "confidence" a confidence map (floats) csw match writes
      and the other outputs' roles (Format.roles): "depth", "picture", "costs", "cloud"
    """
    tests = {
        "image": lambda f: f.image is not None,
        "decoded": lambda f: f.image in ("pillow", "tiff"),
        "read": lambda f: f.read is not None,
        "whole": lambda f: f.whole is not None,
        "map": lambda f: f.whole is not None or f.stripes is not None,
        "stripes": lambda f: f.stripes is not None,
        "confidence": lambda f: f.floats and (f.whole is not None or f.stripes is not None),
    }
    test = tests.get(role, lambda f: role in f.roles)
    return tuple(s for s, f in FORMATS.items() if test(f))


def map_formats_text():
    """The map formats and how each stores a map, for help texts: ".pfm (float32, inf
    invalid), .png (...), ..." in the table's order."""
    return ", ".join(f"{s} ({FORMATS[s].stored})" for s in suffixes("map"))


def format_of(path, role):
    """The Format of ``path`` for a role (see :func:`suffixes`); ValueError naming the
    suffixes that would do."""
    suffix = Path(path).suffix.lower()
    if suffix not in suffixes(role):
        raise ValueError(f"unknown extension {suffix or '(none)'!r} for {path}; use "
                         f"{', '.join(suffixes(role))}")
    return FORMATS[suffix]


def too_large_message(suffix, dmax):
    return (f"dmax {dmax:g} is too large for a 16-bit PNG (d*256 must fit in 16 bits); "
            f"write {', '.join(s for s in suffixes('map') if FORMATS[s].largest > dmax)}")


def negative_message(suffix):
    return (f"a {suffix} disparity map can't hold negative disparities; write "
            f"{', '.join(s for s in suffixes('map') if FORMATS[s].floats)}")


def check_map_range(path, dmax, dmin=0):
    """ValueError when the format of ``path`` can't hold disparities dmin..dmax (a bound
    "auto" is checked when the map is written)."""
    suffix = Path(path).suffix.lower()
    dmax = 0 if dmax == "auto" else dmax
    dmin = 0 if dmin == "auto" else dmin
    if suffix in FORMATS and dmax > FORMATS[suffix].largest:
        raise ValueError(too_large_message(suffix, dmax))
    if suffix in FORMATS and dmin < 0 and not FORMATS[suffix].floats:
        raise ValueError(negative_message(suffix))


def disparity_writer(path, disp):
    """A ``write_to(tmp)`` that writes a whole disparity map (int with -1 invalid, or
    float with NaN/inf invalid) in the format of path's suffix (see the module's table).
    ValueError for a suffix that can't be written whole or a map the format can't hold."""
    return format_of(path, "whole").whole(disp)


def stripe_writer(path, shape, blocks):
    """A ``write_to(tmp)`` that writes a map of ``shape`` from ``blocks`` (see the
    module's docstring) in the format of path's suffix."""
    return format_of(path, "stripes").stripes(path, shape, blocks)


def float_map_writer(path, values):
    """A ``write_to(tmp)`` for a whole float32 (H, W) map (depth, confidence) in a float
    format of the table: written whole where the format can, else a band at a time from
    the array; invalid (NaN) as the format stores it."""
    fmt = format_of(path, "confidence")
    if not one_file(Path(path).suffix.lower()):
        raise ValueError(f"{path}: a {Path(path).suffix} store is a folder, written in "
                         "stripes; give a file format here "
                         f"({', '.join(x for x in suffixes('confidence') if one_file(x))})")
    values = np.asarray(values, np.float32)
    if fmt.whole is not None:
        return fmt.whole(values)
    return fmt.stripes(path, values.shape, array_blocks(values))


def one_file(suffix):
    """Whether an output of this format is one file (a zarr store is a folder)."""
    return FORMATS[suffix].stripes != "store"


def array_blocks(values):
    """The ``blocks(rows, bottom_up=False)`` of a stripe writer (the module's docstring)
    over a map in memory, so that a whole map is written as a striped one is."""
    def blocks(rows, bottom_up=False):
        starts = range(0, values.shape[0], rows)
        for start in reversed(starts) if bottom_up else starts:
            yield start, values[start:start + rows]
    return blocks


def write_disparity(path, disp):
    """Write a disparity map atomically; formats as for :func:`disparity_writer`."""
    atomic_write(path, disparity_writer(path, disp))


def write_float_pfm(path, values):
    """Write a float32 (H, W) map to PFM atomically (inf where not finite)."""
    atomic_write(path, pfm_writer(values))


def write_png(path, image):
    """Write a uint8/uint16 image as PNG atomically."""
    atomic_write(path, png_writer(image))

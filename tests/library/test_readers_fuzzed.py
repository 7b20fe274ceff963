"""Every reader, fed random bytes and valid headers with hostile contents (huge declared
sizes, odd bit depths, channel counts and colour spaces): a clean error (a ValueError,
csw.ImageError among them) or a correct read, never another exception, and never an
allocation the header alone asked for."""

import numpy as np
import pytest
from hostile_files import npy, png, tiff
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import csw
from csw.io.sources import open_source
from csw.scale.jobs import jobs_from_manifest

READERS = {
    "read_image": csw.read_image,
    "read_colour": lambda p: __import__("csw.io.images", fromlist=["x"]).read_colour(p),
    "read_disparity": csw.read_disparity,
    "read_calibration": csw.read_calibration,
    "open_source": lambda p: open_source(p).rows(0, 1),
    "manifest": jobs_from_manifest,
}
SUFFIXES = [".png", ".tif", ".npy", ".pfm", ".jpg", ".bmp", ".ppm", ".txt", ".yml"]


def read_cleanly(reader, path):
    """The reader's result, or None for a clean error; anything else fails the test."""
    try:
        return READERS[reader](path)
    except ValueError:
        return None


sizes = st.sampled_from([0, 1, 3, 2**16, 60000, 2**31 - 1])
hostile = st.one_of(
    st.builds(png, sizes, sizes, st.sampled_from([1, 2, 4, 8, 16, 3, 32]),
              st.sampled_from([0, 2, 3, 4, 6, 5]), st.binary(max_size=64),
              st.sampled_from([0, 1])),
    st.builds(tiff, sizes, sizes, st.sampled_from([1, 2, 3, 4, 5]),
              st.sampled_from([1, 8, 12, 16, 32]), st.binary(max_size=64)),
    st.builds(npy, st.tuples(sizes, sizes) | st.tuples(sizes, sizes, sizes),
              st.sampled_from(["|u1", "<u2", ">u2", "<f4", "<c8", "|b1", "<i8"]),
              st.binary(max_size=64)),
    st.builds(lambda w, h, s: f"Pf\n{w} {h}\n{s}\n".encode(), sizes, sizes,
              st.sampled_from(["-1", "1", "0", "nan", "1e400"])),
    st.binary(max_size=256),
)


# Found by the test below: a TIFF without strip byte counts, whose one strip tifffile
# took to run past the file's end, read as a 65536 x 256 image of zeros from 94 bytes.
NO_BYTE_COUNTS = bytes.fromhex(
    "49492a0008000000070000010300010000000001000001010400010000000000010002010300010000"
    "0008000000000000000000000000000000060103000100000002000000110101000100000000000000"
    "150103000100000003000000")


@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=hostile, suffix=st.sampled_from(SUFFIXES), reader=st.sampled_from(list(READERS)))
@example(data=NO_BYTE_COUNTS, suffix=".png", reader="read_image")
@example(data=tiff(2**16, 9, 1, 8, b"x" * 10), suffix=".tif", reader="read_image")
def test_every_reader_ends_cleanly_on_hostile_files(tmp_path_factory, data, suffix, reader):
    path = tmp_path_factory.mktemp("hostile") / f"f{suffix}"
    path.write_bytes(data)
    result = read_cleanly(reader, path)
    if isinstance(result, np.ndarray):  # a read must be a real image or map
        assert result.ndim in (2, 3) and result.size <= 64 * 1024 * 8


@pytest.mark.parametrize("depth, colour, channels", [(8, 0, 1), (16, 0, 1), (8, 2, 3),
                                                     (16, 2, 3), (8, 4, 2), (16, 4, 2),
                                                     (8, 6, 4), (16, 6, 4)])
def test_valid_pngs_of_every_depth_and_colour_read_correctly(tmp_path, depth, colour, channels):
    """The control: a well-formed small PNG of each kind reads as its pixels (gray, or
    the luma of the colour), with its bit depth kept."""
    import png as pypng

    rng = np.random.default_rng(depth + colour)
    top = 2**depth - 1
    pixels = rng.integers(0, top + 1, (5, 7, channels)).astype(
        np.uint8 if depth == 8 else np.uint16)  # pypng writes 8 bits only from bytes
    with open(tmp_path / "p.png", "wb") as f:
        pypng.Writer(7, 5, greyscale=colour in (0, 4), alpha=colour in (4, 6),
                     bitdepth=depth).write(f, pixels.reshape(5, 7 * channels))
    gray = csw.read_image(tmp_path / "p.png")
    assert gray.dtype == (np.uint8 if depth == 8 else np.uint16)
    expected = pixels[..., 0] if channels <= 2 else csw.io.luma(pixels[..., :3])
    np.testing.assert_array_equal(gray, expected.astype(gray.dtype))

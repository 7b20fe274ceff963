"""Ranges reaching below 0 (convergent rigs, satellite pairs): the same map as the pair
shifted by hand and matched from 0, on random and real pairs."""

import numpy as np
import pytest

import csw


def shifted_by_hand(left, right, dmin, dmax, **options):
    """The pair widened by s = -dmin columns (the left image to the left, the right one to
    the right, each repeating its edge as the contract's windows do), matched over
    0..dmax + s, cut back to the image and offset by -s."""
    s = -dmin
    wide_left = np.pad(left, ((0, 0), (s, 0)), mode="edge")
    wide_right = np.pad(right, ((0, 0), (0, s)), mode="edge")
    disp = csw.match(wide_left, wide_right, dmin=0, dmax=dmax + s, **options).disparity
    return disp[:, s:] - s


def compare(left, right, dmin, dmax, **options):
    """Equal on every column whose candidates all have their right pixel in the image
    (x <= W - 1 + dmin): further right, the widened pair also offers the padding's
    columns, which a negative range leaves out."""
    got = csw.match(left, right, dmin=dmin, dmax=dmax, **options).disparity
    want = shifted_by_hand(left, right, dmin, dmax, **options)
    inside = left.shape[1] + dmin
    if options.get("subpixel", "none") == "none":
        np.testing.assert_array_equal(got[:, :inside], want[:, :inside])
    else:  # by hand, subtracting s after the float32 fit rounds once more
        np.testing.assert_allclose(got[:, :inside], want[:, :inside], rtol=0, atol=1e-6)
    assert np.nanmin(got) < 0  # negative disparities were found, not only a shifted range
    return got


@pytest.mark.parametrize("options", [dict(preset="raw"), dict(preset="raw", cost="census"),
                                     dict(preset="raw", engine="window", cost="ssd"),
                                     dict(preset="raw", subpixel="parabola")])
def test_random_pairs(options):
    rng = np.random.default_rng(11)
    left = rng.integers(0, 255, (30, 70)).astype(np.uint8)
    right = np.roll(left, 4, axis=1)  # true disparity -4
    right[rng.random(right.shape) < 0.1] = 7
    got = compare(left, right, -9, 5, **options)
    assert np.mean(np.abs(got[:, 10:60] + 4) < 0.5) > 0.8


@pytest.mark.data
def test_tsukuba_with_its_right_image_moved_by_hand(data_dir):
    """Tsukuba's right image moved 10 columns right makes its disparities 10 smaller, some
    negative: matched over -10..5, the map is the original's minus 10."""
    pair = csw.load_dataset("tsukuba", data_dir)
    moved = np.pad(pair.right, ((0, 0), (10, 0)), mode="edge")[:, :-10]
    got = compare(pair.left, moved, -10, 5, preset="raw")
    original = csw.match(pair.left, pair.right, dmin=0, dmax=15, preset="raw").disparity
    inner = (slice(None), slice(30, -30))  # away from where the moved image was padded
    assert np.mean(got[inner] == original[inner] - 10) > 0.97

"""Previews a person can read (csw.io.pictures): Turbo, invalid in a colour Turbo does
not use, and a colour bar whose type grows with the picture."""

import matplotlib
import numpy as np
import pytest

import csw
from csw.io import pictures


def test_turbo_is_matplotlib_s_to_three_levels():
    reference = np.round(matplotlib.colormaps["turbo"](np.linspace(0, 1, 256))[:, :3] * 255)
    assert np.abs(pictures.TURBO.astype(int) - reference).max() <= 3


def test_invalid_is_black_and_no_valid_pixel_is():
    disparity = np.linspace(0, 40, 60 * 80, dtype=np.float32).reshape(60, 80)
    disparity[10:20, 30:50] = np.nan
    picture = pictures.disparity_picture(disparity, 0, 40)
    top = picture[:60]
    black = (top == 0).all(axis=2)
    np.testing.assert_array_equal(black, np.isnan(disparity))
    assert not (pictures.TURBO == 0).all(axis=1).any()
    # low red-free blue at d = dmin, dark red at d = dmax
    assert tuple(top[0, 0]) == tuple(pictures.TURBO[0])
    assert tuple(top[-1, -1]) == tuple(pictures.TURBO[-1])


@pytest.mark.parametrize("width", [64, 450, 1920, 4000])
def test_the_bar_s_type_grows_with_the_picture(width):
    bar = pictures.bar(width, 0, 100, "disparity (pixels)")
    size = pictures.font_size(width)
    assert size >= 12 and size >= min(width / 40, 60)
    assert bar.shape[1] == width and bar.shape[0] > 3 * size
    text = (bar == pictures.TEXT).all(axis=2)
    assert text[:, : width // 2].any() and text[:, width // 2:].any()  # labels both halves


def test_depth_previews_put_near_at_the_red_end():
    depth = np.array([[1.0, 2.0, 3.0, 4.0]] * 4, np.float32)
    picture = pictures.depth_picture(depth, "m")
    near, far = picture[0, 0].astype(int), picture[0, 3].astype(int)
    assert near[0] > near[2] and far[2] > far[0]


def test_values_on_the_bar_have_no_exponent():
    assert [pictures.number(v) for v in (11444.2, 0.5, 12.25, 64.0, -3.0)] == \
        ["11444", "0.5", "12.2", "64", "-3"]


def test_a_match_preview_is_the_picture_of_its_map(tmp_path):
    import imageio.v3 as iio

    from csw.io import write_png

    left, right, _, _ = csw.synthetic_pair(120, 80, dmax=16, seed=3)
    write_png(tmp_path / "l.png", left)
    write_png(tmp_path / "r.png", right)
    result = csw.match_files(tmp_path / "l.png", tmp_path / "r.png", tmp_path / "d.pfm",
                             preview=tmp_path / "p.png", dmax=20)
    np.testing.assert_array_equal(iio.imread(tmp_path / "p.png"),
                                  pictures.disparity_picture(result.disparity, 0, 20))


def test_a_clipped_depth_bar_says_so():
    ramp = np.linspace(1, 50, 200 * 60, dtype=np.float32).reshape(60, 200)
    near, far = pictures.depth_range(ramp)
    picture = pictures.depth_picture(ramp, "m")
    clipped = pictures.bar(200, near, far, "depth (m)", reverse=True,
                           note="1st-99th percentile, clipped")
    np.testing.assert_array_equal(picture[60:], clipped)
    flat = np.full((60, 200), 7, np.float32)  # nothing beyond the range: no note
    np.testing.assert_array_equal(pictures.depth_picture(flat, "m")[60:],
                                  pictures.bar(200, *pictures.depth_range(flat), "depth (m)",
                                               reverse=True))
    assert not np.array_equal(clipped, pictures.bar(200, near, far, "depth (m)", reverse=True))

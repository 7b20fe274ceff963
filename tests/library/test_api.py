"""csw.match: the library entry, with the CLI's defaults."""

import numpy as np
import pytest

import csw
from csw import kernels
from csw.config import params
from csw.config.params import DEFAULTS as MATCH
from csw.config.params import PRESETS
from csw.io import luma
from csw.matching import pipeline


def test_defaults_are_the_table_and_its_preset(small_scene):
    left, right, _, _ = small_scene
    result = csw.match(left, right)
    chosen = {**MATCH, **PRESETS[MATCH["preset"]]}
    resolved = {"sgm_p1", "sgm_p2"}  # reported as the kernels take them (test_sgm.py)
    for key in ("preset", "engine", "cost", "window", "dmin", "csw", "csw_rule",
                *(set(params.OFF) - resolved)):
        assert result.settings[key] == chosen[key], key
    # No range given: it is found from the pair (tests/library/test_autorange.py).
    assert chosen["dmax"] == "auto" and result.settings["range_source"] == "auto"
    config = params.resolve(dmax=result.settings["dmax"])
    disp, _, raw = pipeline.run(left, right, dict(config.kernel_args(), csw=False, tau=-1),
                                config.stages)
    np.testing.assert_array_equal(result.disparity, disp)
    np.testing.assert_array_equal(result.min_cost, raw.min_cost)
    assert result.valid.dtype == bool and result.disparity.dtype == np.float32


def test_raw_preset_is_the_kernels_map(small_scene):
    left, right, _, _ = small_scene
    result = csw.match(left, right, preset="raw", dmax=40)
    raw = kernels.match(left, right, engine="window", window=MATCH["window"],
                        dmin=MATCH["dmin"], dmax=40, cost=MATCH["cost"])
    np.testing.assert_array_equal(np.nan_to_num(result.disparity, nan=-1), raw.disparity)
    np.testing.assert_array_equal(result.min_cost, raw.min_cost)


def test_unique_rule_defaults_to_no_tau(small_scene):
    """The old kernels.match default (tau -1) silently turned CSW off; csw.match resolves
    the rule's own default instead."""
    left, right, _, _ = small_scene
    result = csw.match(left, right, dmax=16, csw=True, csw_rule="unique", preset="raw")
    assert result.settings["tau"] == float("inf") and result.settings["tau_source"] == "none"
    assert result.work_saved > 0.2
    raw = kernels.match(left, right, engine="fast", window=9, dmin=0, dmax=16, cost="sad",
                        csw=True, tau=float("inf"), rule="unique", csw_margin=12)
    np.testing.assert_array_equal(np.nan_to_num(result.disparity, nan=-1), raw.disparity)


def test_tau_auto_comes_from_sampled_rows(small_scene):
    left, right, _, _ = small_scene
    result = csw.match(left, right, dmax=16, csw=True, preset="raw")
    rows = csw.config.tau.sample_rows(left.shape[0])
    sample = kernels.match(left, right, engine="fast", window=9, dmin=0, dmax=16, cost="sad",
                           rows=rows)
    assert result.settings["tau"] == csw.config.tau.paper_tau(sample.min_cost)
    assert result.settings["tau_source"] == "auto"


def test_colour_and_paths_are_converted_like_the_cli(small_scene, pair_files, tmp_path):
    left, right, _, _ = small_scene
    rgb = np.stack([left, np.roll(left, 1, 0), left[::-1]], axis=2)
    got = csw.match(rgb, np.stack([right] * 3, axis=2), dmax=16)
    want = csw.match(luma(rgb), right, dmax=16)
    np.testing.assert_array_equal(got.disparity, want.disparity)
    from_files = csw.match(*pair_files, dmax=16)
    np.testing.assert_array_equal(from_files.disparity, csw.match(left, right, dmax=16).disparity)


@pytest.mark.parametrize("kwargs, message", [
    (dict(tau=100), "only with CSW"),
    (dict(csw_rule="unique"), "only with CSW"),
    (dict(preset="raw", census_window=7), "census_window applies only with cost='census'"),
    (dict(preset="accurate", speckle_size=0, speckle_range=3), "speckle_range applies only"),
    (dict(preset="raw", prefilter_cap=20), "prefilter_cap applies only"),
    (dict(preset="accurate", sgm_paths=8), "sgm_paths applies only"),
    (dict(csw=True, tau=-5), ">= 0"),
    (dict(csw=True, tau="sometimes"), "not a number"),
    (dict(engine="gpu"), "engine must be one of"),
    (dict(window=4), "odd"),
    (dict(dmax=500), "less than the image width"),
])
def test_bad_options_raise_value_error(small_scene, kwargs, message):
    with pytest.raises(ValueError, match=message):
        csw.match(small_scene[0], small_scene[1], **kwargs)


def test_an_option_given_its_default_passes_where_it_would_do_nothing(small_scene):
    """Refused only when it would change the match the user asked for: a default given
    (a script passing every option) changes nothing either way."""
    plain = csw.match(small_scene[0], small_scene[1], dmax=16, preset="raw")
    for name in ("census_window", "census_pattern", "speckle_range", "prefilter_cap",
                 "sgm_paths", "csw_rule"):
        default = params.OPTIONS[name].default
        got = csw.match(small_scene[0], small_scene[1], dmax=16, preset="raw",
                        **{name: default})
        np.testing.assert_array_equal(got.disparity, plain.disparity, err_msg=name)


def test_unknown_option_is_a_type_error(small_scene):
    with pytest.raises(TypeError, match="unknown option"):
        csw.match(small_scene[0], small_scene[1], rule="unique")


@pytest.mark.parametrize("cost, dtype, options", [
    ("ssd", np.uint8, {}), ("sad", np.uint16, {}), ("shd", np.uint16, {}),
    ("census", np.uint8, dict(preset="accurate", csw=True, csw_rule="unique")),
    ("sad", np.uint8, dict(csw=True, subpixel="linear", median=3, fill="background")),
])
def test_loading_the_kernels_loads_what_the_match_runs(cost, dtype, options):
    """The match itself must not compile: the kernels a run needs are loaded (or compiled)
    before it, for its window, dtype, census codes and stages (a 1x1 warm-up once left
    SSD 9x9 and 16-bit input compiling inside the timed match)."""
    from csw.kernels import native

    rng = np.random.default_rng(0)
    left = rng.integers(0, 200, (40, 60)).astype(dtype)
    opts = csw.config.params.resolve(**{"preset": "raw", **options, "cost": cost,
                                        "window": 9, "dmax": 8})
    csw.matching.setup.load_kernels(opts, np.dtype(dtype))
    loaded = dict(native._LOADED)
    csw.match(left, np.roll(left, 2, 1), **{"preset": "raw", **options, "cost": cost,
                                             "window": 9, "dmax": 8})
    assert native._LOADED == loaded


def _formula(rgb):
    r, g, b = (rgb[..., i].astype(np.int64) for i in range(3))
    return (r * 19595 + g * 38470 + b * 7471 + 0x8000) >> 16


def test_luma_of_8_bit_colour_is_the_integer_formula():
    """8-bit colour: the kernel's result is Pillow's formula, for every value."""
    rgb = np.random.default_rng(7).integers(0, 256, (64, 300, 3)).astype(np.uint8)
    rgb[0, :256] = np.arange(256)[:, None]  # every value in every channel
    np.testing.assert_array_equal(luma(rgb), _formula(rgb))
    np.testing.assert_array_equal(luma(rgb[:, ::2]), _formula(rgb)[:, ::2])  # a strided view
    from PIL import Image

    np.testing.assert_array_equal(luma(rgb), np.asarray(Image.fromarray(rgb).convert("L")))


def test_luma_of_16_bit_colour_and_of_rgba_is_the_same_formula():
    """16-bit colour, up to its largest value (the sum stays in 32 bits), and RGBA, whose
    alpha is dropped without a copy of the colour pixels, give the formula too."""
    rgb = np.random.default_rng(9).integers(0, 65536, (37, 91, 3)).astype(np.uint16)
    rgb[0, 0] = 65535
    out = luma(rgb)
    assert out.dtype == np.uint16 and out[0, 0] == 65535
    np.testing.assert_array_equal(out, _formula(rgb))
    rgba = np.concatenate([rgb, np.full((37, 91, 1), 7, np.uint16)], axis=2)
    np.testing.assert_array_equal(luma(rgba), _formula(rgb))


def test_luma_in_stripes_equals_one_piece(monkeypatch):
    """An image large enough for stripes on every thread gives the same values, stripe
    edges included."""
    from csw.kernels import runtime

    big = np.random.default_rng(8).integers(0, 256, (1111, 1282, 3)).astype(np.uint8)
    whole = luma(big)
    monkeypatch.setattr(runtime, "DIRECT_WORK", 1)  # every image in stripes
    np.testing.assert_array_equal(luma(big), whole)
    np.testing.assert_array_equal(whole, _formula(big))


def test_match_on_files_takes_the_calib_txt_beside_them_as_csw_match_does(tmp_path):
    """One range rule: a calib.txt beside the left image gives its ndisp to csw.match on
    paths, as to csw match (csw.match_files); a dmax given wins over it in both."""
    from csw.data.synth import render
    from csw.io import write_png

    left, right, _, _ = render(96, 64, dmax=12, seed=2)
    write_png(tmp_path / "im0.png", left)
    write_png(tmp_path / "im1.png", right)
    (tmp_path / "calib.txt").write_text(
        "cam0=[100 0 48; 0 100 32; 0 0 1]\ncam1=[100 0 48; 0 100 32; 0 0 1]\ndoffs=0\n"
        "baseline=100\nwidth=96\nheight=64\nndisp=21\n")
    paths = tmp_path / "im0.png", tmp_path / "im1.png"
    from_python = csw.match(*paths).settings
    from_cli = csw.match_files(*paths, tmp_path / "d.pfm").settings
    assert (from_python["dmin"], from_python["dmax"]) == (0, 20)
    assert (from_cli["dmin"], from_cli["dmax"]) == (0, 20)
    assert from_python["range_source"] == from_cli["range_source"]
    assert csw.match(*paths, dmax=15).settings["dmax"] == 15
    assert csw.match(left, right).settings["range_source"].startswith("auto")  # arrays


@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.int32])
def test_a_map_s_pfm_has_every_invalid_pixel_inf_whatever_its_type(tmp_path, dtype):
    """The .pfm writer takes a float map as it is (one copy makes NaN and +-inf inf), an
    integer one through disparity_to_file_float (-1 invalid): both give the bytes of
    disparity_to_file_float's float32 map, inf invalid, rows bottom up."""
    from csw.io.formats import disparity_to_file_float, disparity_writer, pfm_writer

    if dtype == np.int32:
        disp = np.array([[-1, 3, 7], [0, -1, 12]], dtype)
    else:
        disp = np.array([[np.nan, 3.25, -np.inf], [np.inf, -0.5, 1e30]]).astype(dtype)
    disparity_writer(tmp_path / "d.pfm", disp)(tmp_path / "d.pfm")
    pfm_writer(disparity_to_file_float(disp))(tmp_path / "e.pfm")
    assert (tmp_path / "d.pfm").read_bytes() == (tmp_path / "e.pfm").read_bytes()
    back = csw.read_disparity(tmp_path / "d.pfm")
    assert np.isnan(back).sum() == (2 if dtype == np.int32 else 3)

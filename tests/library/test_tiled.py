"""csw.match_tiled: a pair matched in row stripes equals the whole-image match bit for bit,
for every preset and stage; inputs are read by rows and outputs written by stripes."""

import subprocess
import sys
import textwrap

import imageio.v3 as iio
import numpy as np
import pytest
import tifffile
import zarr

import csw
import csw.scale.tiled as tiled
from csw.data.synth import render, write_tiff_scene
from csw.io import ImageError, read_disparity, read_image, read_pfm, write_png
from csw.io.pictures import disparity_picture
from csw.io.sources import open_source
from csw.scale.tiled import plan as tiled_plan
from csw.scale.tiled import tasks as tiled_tasks

WIDTH, HEIGHT, DMAX = 160, 101, 24  # an odd height: the last stripe is short

CASES = {
    "paper": dict(preset="paper"),
    "raw CSW literal, tau auto": dict(preset="raw", csw=True, tau="auto"),
    "raw CSW unique": dict(preset="raw", csw=True, csw_rule="unique"),
    "accurate (census, LR, speckle)": dict(preset="accurate"),
    "every stage": dict(preset="accurate", prefilter="xsobel", texture_threshold=30,
                        uniqueness_ratio=10, subpixel="parabola", median=3,
                        fill="background"),
    "window engine, SSD, subpixel": dict(preset="raw", engine="window", cost="ssd",
                                         subpixel="linear", lr_check=1),
    "accurate, a range from -6": dict(preset="accurate", dmin=-6),
}


@pytest.fixture(scope="module")
def scene():
    return render(WIDTH, HEIGHT, dmax=DMAX, seed=5)


def occluded_row(nonocc):
    """A row with many occluded pixels, for a stripe boundary inside an occlusion."""
    return int(np.argmax((~nonocc).sum(axis=1)[20:-20])) + 20


def as_stored(disp):
    """What .npy holds for a float map with NaN invalid: inf."""
    return np.where(np.isfinite(disp), disp, np.inf).astype(np.float32)


def tiled_maps(tmp_path, left, right, rows, **options):
    out, conf = tmp_path / "d.npy", tmp_path / "c.npy"
    result = tiled.match_tiled(left, right, out, confidence=conf, stripe_rows=rows,
                               dmax=DMAX, **options)
    return result, np.load(out), np.load(conf)


@pytest.mark.parametrize("case", list(CASES))
def test_stripes_equal_the_whole_image(tmp_path, scene, case):
    left, right, _, nonocc = scene
    options = CASES[case]
    whole = csw.match(left, right, dmax=DMAX, want_confidence=True, **options)
    boundary = occluded_row(nonocc)
    assert (~nonocc[boundary]).sum() >= 5  # the boundary really is in an occlusion
    for rows in (9, boundary, 40):
        result, disp, conf = tiled_maps(tmp_path, left, right, rows, **options)
        assert len(result.plan.stripes) > 1 and result.plan.stripes[0][1] == rows
        np.testing.assert_array_equal(disp, as_stored(whole.disparity), err_msg=f"{rows}")
        np.testing.assert_array_equal(conf, whole.confidence)
        assert result.evaluated == whole.evaluated
        assert result.settings["tau"] == whole.settings["tau"]
    assert list(tmp_path.iterdir()) and not [p for p in tmp_path.iterdir()
                                             if p.name.startswith(".csw-tmp")]


@pytest.mark.parametrize("options", [dict(preset="paper"), dict()])
def test_one_row_less_of_input_overlap_would_differ(tmp_path, scene, monkeypatch, options):
    """The overlap is what makes stripes exact: one row less and some pixel's disparity
    or confidence changes (the default's sparse census reads the farthest row for only 5
    of its 32 bits, which moved no disparity of this scene, but its costs)."""
    left, right, _, nonocc = scene
    whole = csw.match(left, right, dmax=DMAX, want_confidence=True, **options)
    original = tiled_plan.row_overlap
    monkeypatch.setattr(tiled_plan, "row_overlap", lambda *a: original(*a) - 1)
    _, disp, conf = tiled_maps(tmp_path, left, right, occluded_row(nonocc), **options)
    assert not (np.array_equal(disp, as_stored(whole.disparity)) and
                np.array_equal(conf, whole.confidence))


def test_sgm_stripes_pair_the_rows_its_half_size_pass_averages(tmp_path):
    """The narrowed search's half-size pass averages rows 2k and 2k + 1: a stripe read
    from an odd row (here 150 less the overlap, odd at 69) would average other pairs and
    differ far below its edge; read from an even row, the rows beyond the overlap equal
    the whole image's."""
    left, right, _, _ = render(256, 300, dmax=100, seed=3)
    whole = csw.match(left, right, dmin=0, dmax=127).disparity
    result = tiled.match_tiled(left, right, tmp_path / "d.npy", stripe_rows=150, dmin=0,
                               dmax=127)
    layout = result.plan
    assert layout.paired_rows and layout.row_overlap % 2 == 1
    for stripe in layout.stripes:
        first, end = tiled_plan.input_band(stripe, layout)
        assert first % 2 == 0 and (end - first) % 2 == 0
    beyond = 150 + layout.row_overlap
    np.testing.assert_array_equal(np.load(tmp_path / "d.npy")[beyond:],
                                  as_stored(whole[beyond:]))


def filter_in_stripes(tmp_path, disp, stages, rows, overlap):
    """The second pass alone: ``disp`` in a stage store, filtered stripe by stripe."""
    shape = disp.shape
    stage = tiled_tasks.create_store(tmp_path / "stage.zarr", shape, rows, False)
    final = tiled_tasks.create_store(tmp_path / "final.zarr", shape, rows, False)
    zarr.open_array(stage, mode="r+")[:] = disp
    layout = tiled.Plan(shape[0], shape[1], rows, 0, overlap, 0)
    for stripe in layout.stripes:
        tiled_tasks.filter_stripe({"stripe": stripe, "band": tiled_plan.map_band(stripe, layout),
                             "stages": stages, "stage": stage, "stage_confidence": None,
                             "disparity": final, "confidence_store": None})
    return zarr.open_array(final, mode="r")[:]


@pytest.mark.parametrize("stages, tight", [(dict(speckle_size=6), True),
                                           (dict(median=5), True),
                                           (dict(speckle_size=6, median=3), False)])
def test_the_filter_overlap_is_exactly_enough(tmp_path, stages, tight):
    """Vertical segments of S and S - 1 pixels across a stripe boundary: the speckle
    filter keeps the first and removes the second only with S - 1 rows of overlap; a
    random map does the same for the median.  (On the segments the 3 x 3 median changes
    nothing, so together they are only checked for exactness.)"""
    from csw.config.params import OFF, Stages
    from csw.matching.pipeline import filter_map, filter_overlap

    stages = Stages(**dict(OFF, **stages))
    rng = np.random.default_rng(0)
    disp = np.where(rng.random((40, 30)) < 0.7, rng.integers(0, 9, (40, 30)), np.nan)\
        .astype(np.float32)
    size = stages.speckle_size
    if size:
        disp[:] = np.nan
        for column, length in ((5, size), (12, size - 1), (20, size), (26, size - 1)):
            top = 20 - length + 1 if column < 15 else 20  # ending, or starting, at row 20
            disp[top:top + length, column] = 3.0
    whole, _ = filter_map(disp.copy(), np.zeros_like(disp), stages)
    overlap = filter_overlap(stages)
    exact = filter_in_stripes(tmp_path / "a", disp, stages, 20, overlap)
    np.testing.assert_array_equal(exact, whole)
    if tight:
        short = filter_in_stripes(tmp_path / "b", disp, stages, 20, overlap - 1)
        assert not np.array_equal(short, whole, equal_nan=True)


def test_stripe_cores_run_as_one_stripe_in_the_fast_engine():
    from csw.kernels.fast import stripe_bounds

    band = np.arange(10, 90, dtype=np.int64)
    np.testing.assert_array_equal(stripe_bounds(100, 9, 1, band), [[10, 90]])
    sample = np.array([3, 50, 51, 52, 80], np.int64)
    np.testing.assert_array_equal(stripe_bounds(100, 9, 1, sample),
                                  [[3, 4], [50, 53], [80, 81]])
    assert stripe_bounds(100, 9, 2, np.arange(100)).shape == (2, 2)


@pytest.mark.parametrize("suffix", [".tif", ".zarr", ".pfm", ".npy", ".png"])
def test_every_output_format_holds_the_whole_image_map(tmp_path, scene, suffix):
    left, right, _, _ = scene
    whole = map_ = csw.match(left, right, dmax=DMAX, preset="accurate").disparity
    out = tmp_path / f"d{suffix}"
    tiled.match_tiled(left, right, out, preview=tmp_path / "p.png", stripe_rows=16,
                      dmax=DMAX, preset="accurate")
    if suffix == ".tif":
        got = tifffile.imread(out)
        with tifffile.TiffFile(out) as tif:
            assert tif.pages.first.is_tiled
    elif suffix == ".zarr":
        got = zarr.open_array(out, mode="r")[:]
    else:  # as the whole-image writer writes it (KITTI's PNG has d = 0 as invalid)
        csw.write_disparity(tmp_path / f"whole{suffix}", whole)
        whole = read_disparity(tmp_path / f"whole{suffix}")
        got = read_disparity(out)
        if suffix != ".png":
            assert out.read_bytes() == (tmp_path / f"whole{suffix}").read_bytes()
    np.testing.assert_array_equal(got, whole)  # NaN where invalid in every reading
    # The striped preview is the whole one, its colour bar included.
    np.testing.assert_array_equal(iio.imread(tmp_path / "p.png"),
                                  disparity_picture(map_, 0, DMAX))


def test_a_zarr_output_is_replaced_whole(tmp_path, scene):
    left, right, _, _ = scene
    out = tmp_path / "d.zarr"
    tiled.match_tiled(left, right, out, stripe_rows=16, dmax=DMAX, preset="raw")
    tiled.match_tiled(left, right, out, stripe_rows=16, dmax=DMAX, preset="accurate")
    np.testing.assert_array_equal(zarr.open_array(out, mode="r")[:],
                                  csw.match(left, right, dmax=DMAX,
                                            preset="accurate").disparity)
    (tmp_path / "folder.zarr").mkdir()
    (tmp_path / "folder.zarr" / "mine.txt").write_text("keep")
    with pytest.raises(ValueError, match="not a zarr store"):
        tiled.match_tiled(left, right, tmp_path / "folder.zarr", stripe_rows=16, dmax=DMAX)
    assert (tmp_path / "folder.zarr" / "mine.txt").read_text() == "keep"


def rgb(gray):
    return np.stack([gray, gray // 2, 255 - gray], axis=-1).astype(np.uint8)


@pytest.mark.parametrize("layout", ["tiled", "striped", "bigtiff", "rgb", "planar", "npy",
                                    "zarr", "png"])
def test_inputs_read_by_rows_equal_the_decoded_image(tmp_path, scene, layout):
    left, right, _, _ = scene
    paths = []
    for name, image in (("l", left), ("r", right)):
        colour = rgb(image)
        if layout in ("tiled", "bigtiff"):
            path = tmp_path / f"{name}.tif"
            tifffile.imwrite(path, image, tile=(32, 32), bigtiff=layout == "bigtiff",
                             compression="zlib")
        elif layout == "striped":
            path = tmp_path / f"{name}.tiff"
            tifffile.imwrite(path, image, rowsperstrip=7)
        elif layout == "rgb":
            path = tmp_path / f"{name}.tif"
            tifffile.imwrite(path, colour, photometric="rgb", tile=(16, 16))
        elif layout == "planar":
            path = tmp_path / f"{name}.tif"
            tifffile.imwrite(path, np.moveaxis(colour, -1, 0), photometric="rgb",
                             planarconfig="separate")
        elif layout == "npy":
            path = tmp_path / f"{name}.npy"
            np.save(path, colour)
        elif layout == "zarr":
            path = tmp_path / f"{name}.zarr"
            zarr.create_array(str(path), data=image, chunks=(10, 64))
        else:
            path = tmp_path / f"{name}.png"
            write_png(path, colour)
        paths.append(path)
    if layout in ("rgb", "planar", "npy", "png"):  # colour: the CLI's luma of the file
        want_left, want_right = read_image_png(tmp_path, rgb(left), rgb(right))
    else:
        want_left, want_right = left, right
    source = open_source(paths[0])
    np.testing.assert_array_equal(source.rows(0, HEIGHT), want_left)
    np.testing.assert_array_equal(source.rows(37, 52), want_left[37:52])
    # accurate: its stripes equal the whole image exactly (sgm's differ near their edges)
    tiled.match_tiled(*paths, tmp_path / "d.npy", stripe_rows=20, dmax=DMAX,
                      preset="accurate")
    np.testing.assert_array_equal(
        np.load(tmp_path / "d.npy"),
        as_stored(csw.match(want_left, want_right, dmax=DMAX, preset="accurate").disparity))


def read_image_png(folder, *colour):
    """The gray csw reads from these colour images written as PNG."""
    out = []
    for i, image in enumerate(colour):
        path = folder / f"ref{i}.png"
        write_png(path, image)
        out.append(read_image(path))
    return out


@pytest.mark.parametrize("content, message", [
    (b"hello, not a TIFF at all", "not a readable TIFF"),
    (b"II*\x00\x08\x00\x00\x00\xff\xff", "not a readable TIFF"),
])
def test_a_tiff_that_is_not_one(tmp_path, scene, content, message):
    (tmp_path / "l.tif").write_bytes(content)
    tifffile.imwrite(tmp_path / "r.tif", scene[1])
    with pytest.raises(ImageError, match=message) as info:
        tiled.match_tiled(tmp_path / "l.tif", tmp_path / "r.tif", tmp_path / "d.tif",
                          dmax=DMAX)
    assert "\n" not in str(info.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["l.tif", "r.tif"]


def test_a_damaged_tile_mid_image_fails_cleanly(tmp_path, scene):
    left, right, _, _ = scene
    tifffile.imwrite(tmp_path / "l.tif", left, tile=(32, 32), compression="zlib")
    tifffile.imwrite(tmp_path / "r.tif", right, tile=(32, 32), compression="zlib")
    with tifffile.TiffFile(tmp_path / "l.tif") as tif:
        page = tif.pages.first
        offset, count = page.dataoffsets[-3], page.databytecounts[-3]  # a bottom tile
    data = bytearray((tmp_path / "l.tif").read_bytes())
    data[offset:offset + count] = b"\x00" * count
    (tmp_path / "l.tif").write_bytes(bytes(data))
    with pytest.raises(ImageError, match="can't read rows") as info:
        tiled.match_tiled(tmp_path / "l.tif", tmp_path / "r.tif", tmp_path / "d.tif",
                          stripe_rows=16, dmax=DMAX)
    assert "\n" not in str(info.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["l.tif", "r.tif"]


def test_a_memory_limit_below_one_stripe_is_refused(tmp_path, scene):
    left, right, _, _ = scene
    with pytest.raises(tiled.MemoryLimitError, match=r"raise the memory limit to at least"):
        tiled.match_tiled(left, right, tmp_path / "d.tif", memory_limit="100kB", dmax=DMAX)
    assert list(tmp_path.iterdir()) == []


# sgm's stripes hold 64 rows more each side and bands of 32 rows at least: about 0.8 GiB
# at 20000 pixels wide, d 0..64
@pytest.mark.parametrize("preset, limits", [
    ("accurate", ("256MiB", "512MiB", "1GiB", "2GiB")),
    ("sgm", ("1GiB", "2GiB", "4GiB", "8GiB"))])
def test_stripes_grow_with_the_memory_limit(preset, limits):
    options = csw.config.params.resolve(dmax=64, preset=preset)
    heights = [tiled_plan.plan(20000, 20000, options, tiled.parse_size(limit), threads=2)
               .stripe_rows for limit in limits]
    assert heights == sorted(heights) and heights[0] < heights[-1] < 20000
    whole = tiled_plan.plan(500, 400, options, tiled.parse_size("512MiB"), threads=2)
    assert whole.stripes == [(0, 500)]


@pytest.mark.parametrize("text, size", [("512MB", 512 * 10**6), ("2GiB", 2 * 2**30),
                                        ("1.5G", 1_500_000_000), ("4096", 4096),
                                        ("64 MiB", 64 * 2**20)])
def test_sizes(text, size):
    assert tiled.parse_size(text) == size


@pytest.mark.slow
def test_memory_follows_the_stripe_not_the_image(tmp_path):
    """Pairs whose whole-image match needs several times the limit are matched within it:
    peak RSS during the run, above the process's RSS before it, stays under the limit
    (plus the libraries' own buffers, which vary from run to run by some tens of MiB and
    belong to the process's base), and does not grow with the image's height."""
    for height in (1000, 2000):
        write_tiff_scene(tmp_path / f"h{height}", 4000, height, dmax=32, seed=2, processes=1)
    write_tiff_scene(tmp_path / "small", 200, 60, dmax=32, seed=2, processes=1)
    limit, libraries = 64 * 2**20, 32 * 2**20
    # accurate: the sgm preset's stripes hold 64 rows more each side and bands of 32 rows
    # at least, more than this limit at 4000 pixels wide
    options = csw.config.params.resolve(dmax=32, preset="accurate")
    assert tiled_plan.plan(1000, 4000, options, stripe_rows=1000).bytes_per_stripe > 3 * limit
    script = textwrap.dedent(f"""
        import sys, csw.scale.tiled as t
        def run(scene):
            return t.match_tiled(f"{tmp_path}/{{scene}}/left.tif",
                                 f"{tmp_path}/{{scene}}/right.tif",
                                 f"{tmp_path}/{{scene}}/d.tif", memory_limit={limit}, dmax=32,
                                 preset="accurate")
        def status(key):
            for line in open("/proc/self/status"):
                if line.startswith(key + ":"):
                    return int(line.split()[1]) * 1024
        run("small")  # compiles (or loads the cache), and the libraries' first allocations
        # Linux: reset the peak to the current RSS, so that a compile's peak is not counted.
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        before = status("VmRSS")
        result = run(sys.argv[1])
        print(len(result.plan.stripes), status("VmHWM") - before)
    """)
    growth = {}
    for height in (1000, 2000):
        done = subprocess.run([sys.executable, "-c", script, f"h{height}"],
                              capture_output=True, text=True, check=True)
        stripes, growth[height] = (int(v) for v in done.stdout.split())
        assert stripes >= 4 * height // 1000
        assert growth[height] < limit + libraries, \
            f"peak grew {growth[height] / 2**20:.0f} MiB with a {limit / 2**20:.0f} MiB limit"
    assert growth[2000] < growth[1000] + libraries  # twice the image, not twice the memory


def test_tau_auto_sees_the_same_rows(tmp_path, scene):
    left, right, _, _ = scene
    whole = csw.match(left, right, dmax=DMAX, preset="raw", csw=True, tau="auto")
    result = tiled.match_tiled(left, right, tmp_path / "d.pfm", stripe_rows=12, dmax=DMAX,
                               preset="raw", csw=True, tau="auto")
    assert result.settings["tau"] == whole.settings["tau"] > 0
    np.testing.assert_array_equal(read_pfm(tmp_path / "d.pfm"), as_stored(whole.disparity))

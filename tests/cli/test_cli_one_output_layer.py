"""One way from a pair to files (issue 40): the same pair through a single csw match, a
batch, a striped run and a stream of frames from a folder (a KITTI raw drive) writes the
same bytes; every file written for a pair goes through csw.io.outputs.PairOutputs; the
range is decided once per pair; a batch reuses one Matcher."""

import numpy as np
import pytest
from click.testing import CliRunner
from rig_fixtures import kitti_text, random_rig

import csw
from csw.camera.rectify import stereo_rectify
from csw.io import outputs as outputs_module
from csw.io.formats import write_png
from csw.matching import disparity_range
from csw_cli.main import cli

# The accurate preset is stripe-exact by design (the default, sgm, is not).
OPTIONS = ["--preset", "accurate", "--dmax", "16"]
FRAMES = 3


def run(*args):
    result = CliRunner().invoke(cli, ["match", *map(str, args)])
    assert result.exit_code == 0, result.output
    return result.output


@pytest.fixture
def pairs(tmp_path):
    """Three small pairs of one size (wide enough to be cut in stripes under a memory
    limit of 1200 KB): [(left, right)]."""
    found = []
    for k in range(FRAMES):
        left, right, _, _ = csw.synthetic_pair(160, 120, dmax=16, seed=20 + k)
        found.append((left, right))
    return found


def single(tmp_path, pair, *extra):
    """One pair through csw match: its map, preview and confidence."""
    folder = tmp_path / "single"
    folder.mkdir(exist_ok=True)
    write_png(folder / "l.png", pair[0])
    write_png(folder / "r.png", pair[1])
    out = [folder / "d.pfm", folder / "d.png", folder / "c.pfm"]
    run(folder / "l.png", folder / "r.png", "-o", out[0], "--preview", out[1],
        "--confidence", out[2], *OPTIONS, *extra)
    return out


def batch_folders(tmp_path, pairs):
    lefts, rights = tmp_path / "L", tmp_path / "R"
    lefts.mkdir()
    rights.mkdir()
    for k, (left, right) in enumerate(pairs):
        write_png(lefts / f"{k:06d}.png", left)
        write_png(rights / f"{k:06d}.png", right)
    return lefts, rights


def kitti_drive(tmp_path, pairs):
    """A KITTI raw *_sync drive (a folder of rectified frames) of ``pairs``."""
    rig = random_rig(np.random.default_rng(5), size=(160, 120))
    r1, r2, p1, p2, _ = stereo_rectify(rig.k1, rig.d1, rig.k2, rig.d2, rig.size, rig.r,
                                       rig.t, alpha=0.0)
    date = tmp_path / "2011_09_26"
    drive = date / "2011_09_26_drive_0001_sync"
    date.mkdir()
    (date / "calib_cam_to_cam.txt").write_text(kitti_text(rig, rect=(r1, r2, p1, p2)))
    stamps = [f"2011-09-26 13:02:25.{k:09d}" for k in range(0, len(pairs) * 10**8, 10**8)]
    for camera, which in (("image_02", 0), ("image_03", 1)):
        (drive / camera / "data").mkdir(parents=True)
        for k, pair in enumerate(pairs):
            write_png(drive / camera / "data" / f"{k:010d}.png", pair[which])
        (drive / camera / "timestamps.txt").write_text("\n".join(stamps) + "\n")
    return drive


def same_bytes(got, want):
    for a, b in zip(got, want, strict=True):
        assert a.read_bytes() == b.read_bytes(), (a, b)


def test_a_batch_pair_writes_the_single_pairs_bytes(tmp_path, pairs):
    want = single(tmp_path, pairs[1])
    lefts, rights = batch_folders(tmp_path, pairs)
    run(lefts, rights, "-O", tmp_path / "out", "--preview", ".png", "--confidence", ".pfm",
        *OPTIONS)
    out = tmp_path / "out"
    same_bytes([out / "000001.pfm", out / "000001.preview.png",
                out / "000001.confidence.pfm"], want)


def test_a_striped_pair_writes_the_single_pairs_bytes(tmp_path, pairs):
    want = single(tmp_path, pairs[0])
    folder = tmp_path / "single"
    out = [tmp_path / "s.pfm", tmp_path / "s.png", tmp_path / "s.conf.pfm"]
    said = run(folder / "l.png", folder / "r.png", "-o", out[0], "--preview", out[1],
               "--confidence", out[2], "--memory-limit", "1200KB", *OPTIONS)
    stripes = int(said.split(" stripe(s)")[0].rsplit(", ", 1)[1])
    assert stripes > 1, said
    same_bytes(out, want)


def test_a_tif_map_is_striped_to_the_same_values(tmp_path, pairs):
    want = single(tmp_path, pairs[0])
    folder = tmp_path / "single"
    said = run(folder / "l.png", folder / "r.png", "-o", tmp_path / "s.tif", *OPTIONS)
    assert "stripe(s)" in said
    np.testing.assert_array_equal(csw.read_disparity(tmp_path / "s.tif"),
                                  csw.read_disparity(want[0]))


def test_a_stream_of_frames_from_a_folder_writes_the_single_pairs_bytes(tmp_path, pairs):
    drive = kitti_drive(tmp_path, pairs)
    run(drive, "-O", tmp_path / "frames", "--preview", ".png", "--confidence", ".pfm",
        *OPTIONS)
    out = tmp_path / "frames"
    for k in (0, FRAMES - 1):
        want = single(tmp_path, pairs[k])
        same_bytes([out / f"{k:06d}.pfm", out / f"{k:06d}.preview.png",
                    out / f"{k:06d}.confidence.pfm"], want)


@pytest.fixture
def spies(monkeypatch):
    """(written, decided): every path PairOutputs wrote, and every range decision."""
    written, decided = [], []
    real_write, real_decide = outputs_module.PairOutputs.write, disparity_range.decide

    def write(self):
        written.extend(path for path, _ in self._staged)
        return real_write(self)

    def decide(*args, **kwargs):
        decided.append(args[1])
        return real_decide(*args, **kwargs)

    monkeypatch.setattr(outputs_module.PairOutputs, "write", write)
    monkeypatch.setattr(disparity_range, "decide", decide)
    return written, decided


def made(folder, *besides):
    """Every file under ``folder`` but the run's ``besides`` (a summary)."""
    return {p.resolve() for p in folder.rglob("*") if p.is_file()} - \
        {p.resolve() for p in besides}


# A range "auto": found from each pair's own pixels, so that every pair decides.
AUTO = ["--preset", "accurate", "--dmax", "auto"]


@pytest.mark.parametrize("extra", [[], ["--memory-limit", "1200KB"]], ids=["whole", "stripes"])
def test_every_file_of_one_pair_goes_through_the_output_layer(tmp_path, pairs, spies, extra):
    written, decided = spies
    folder = tmp_path / "one"
    folder.mkdir()
    write_png(tmp_path / "l.png", pairs[0][0])
    write_png(tmp_path / "r.png", pairs[0][1])
    run(tmp_path / "l.png", tmp_path / "r.png", "-o", folder / "d.pfm", "--preview",
        folder / "d.png", "--confidence", folder / "c.pfm", *AUTO, *extra)
    assert made(folder) == {p.resolve() for p in written}
    assert len(made(folder)) == 3
    assert len(decided) == 1


def test_every_file_of_a_batch_goes_through_the_output_layer(tmp_path, pairs, spies):
    written, decided = spies
    lefts, rights = batch_folders(tmp_path, pairs)
    out = tmp_path / "out"
    run(lefts, rights, "-O", out, "--preview", ".png", "--confidence", ".pfm", *AUTO)
    assert made(out, out / "summary.json") == {p.resolve() for p in written}
    assert len(written) == 3 * FRAMES
    assert len(decided) == FRAMES


def test_every_file_of_a_stream_goes_through_the_output_layer(tmp_path, pairs, spies):
    written, decided = spies
    drive = kitti_drive(tmp_path, pairs)
    out = tmp_path / "frames"
    run(drive, "-O", out, "--preview", ".png", "--confidence", ".pfm", *AUTO,
        "--range-each-frame")
    assert made(out, out / "summary.json") == {p.resolve() for p in written}
    assert len(written) == 3 * FRAMES
    assert len(decided) == FRAMES


def test_a_batch_makes_one_matcher_and_reuses_its_set_up(tmp_path, pairs, monkeypatch):
    from csw.matching import matcher as matcher_module

    made_matchers, set_ups = [], []
    real_init, real_set_up = matcher_module.Matcher.__init__, matcher_module.set_up

    def init(self, *args, **kwargs):
        made_matchers.append(self)
        real_init(self, *args, **kwargs)

    def set_up(*args, **kwargs):
        set_ups.append(args[1])
        return real_set_up(*args, **kwargs)

    monkeypatch.setattr(matcher_module.Matcher, "__init__", init)
    monkeypatch.setattr(matcher_module, "set_up", set_up)
    lefts, rights = batch_folders(tmp_path, pairs)
    run(lefts, rights, "-O", tmp_path / "out", "--threads", "1", *OPTIONS)
    assert len(made_matchers) == 1
    assert len(set_ups) == 1  # three pairs of one size and range: one set-up


@pytest.mark.parametrize("suffix", [".png", ".zarr"])  # not floats; a folder, not a file
def test_a_frames_output_in_a_format_its_role_cannot_take_fails_before_any_frame(tmp_path,
                                                                                  pairs,
                                                                                  suffix):
    drive = kitti_drive(tmp_path, pairs)
    result = CliRunner().invoke(cli, ["match", str(drive), "-O", str(tmp_path / "frames"),
                                      "--confidence", suffix, *OPTIONS])
    assert result.exit_code == 2, result.output
    assert "--confidence" in result.output and ".pfm" in result.output
    assert len(result.output.strip().splitlines()) == 1
    assert not (tmp_path / "frames").exists()

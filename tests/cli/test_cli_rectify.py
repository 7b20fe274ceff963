"""csw rectify and csw match --rig: a raw pair from a calibrated rig, rectified, matched,
turned into depth and a cloud in one run; bad rigs are one line, exit 2, nothing
written."""

import numpy as np
import pytest
from click.testing import CliRunner
from rig_fixtures import random_rig, raw_from_rectified, write_opencv

import csw
from csw.camera.rectify import Rectifier, stereo_rectify
from csw.io import write_png
from csw_cli.main import cli

SIZE = (240, 180)


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture
def raw_pair(tmp_path):
    rig = random_rig(np.random.default_rng(21), size=SIZE)
    r1, r2, p1, p2, _ = stereo_rectify(rig.k1, rig.d1, rig.k2, rig.d2, rig.size, rig.r,
                                       rig.t, 0.0)
    left, right, _, _ = csw.synthetic_pair(*SIZE, dmax=20, seed=6)
    write_png(tmp_path / "raw_l.png", raw_from_rectified(left, rig.k1, rig.d1, r1, p1))
    write_png(tmp_path / "raw_r.png", raw_from_rectified(right, rig.k2, rig.d2, r2, p2))
    write_opencv(tmp_path / "stereo.yml", rig)
    return tmp_path, rig


def test_rectify_then_match_uses_the_rectified_calibration(raw_pair):
    folder, rig = raw_pair
    done = run("rectify", folder / "raw_l.png", folder / "raw_r.png", "--rig",
               folder / "stereo.yml", "-O", folder / "rect")
    assert done.exit_code == 0, done.output
    assert sorted(p.name for p in (folder / "rect").iterdir()) == \
        ["calib.txt", "left.png", "right.png"]
    matched = run("match", folder / "rect/left.png", folder / "rect/right.png", "-o",
                  folder / "d.pfm", "--depth", folder / "z.pfm")
    assert matched.exit_code == 0, matched.output
    assert "calibration" in matched.output and "rect/calib.txt" in matched.output


def test_match_rig_writes_the_cloud_in_either_frame(raw_pair):
    from plyfile import PlyData

    folder, rig = raw_pair
    clouds = {}
    for frame in ("rectified", "camera"):
        done = run("match", folder / "raw_l.png", folder / "raw_r.png", "--rig",
                   folder / "stereo.yml", "-o", folder / f"{frame}.pfm", "--cloud",
                   folder / f"{frame}.ply", "--frame", frame, "--rectified-left",
                   folder / f"{frame}-left.png")
        assert done.exit_code == 0, done.output
        vertex = PlyData.read(folder / f"{frame}.ply")["vertex"]
        clouds[frame] = np.stack([vertex["x"], vertex["y"], vertex["z"]], axis=1)
    r1 = Rectifier(rig).r1
    assert len(clouds["camera"]) > 1000
    np.testing.assert_allclose(clouds["camera"], clouds["rectified"] @ r1, atol=1e-3)
    rectified_left = csw.read_image(folder / "rectified-left.png")
    assert rectified_left.shape == SIZE[::-1]


@pytest.mark.parametrize("change, message", [
    (lambda text: text.replace("M1", "Q1"), "no M1"),
    (None, "is for 240x180 images"),
])
def test_a_bad_rig_is_one_line_exit_2_and_nothing_written(raw_pair, change, message):
    folder, _ = raw_pair
    rig_file = folder / "stereo.yml"
    if change is not None:
        rig_file.write_text(change(rig_file.read_text()))
        left = folder / "raw_l.png"
    else:
        left = folder / "small.png"
        write_png(left, np.zeros((50, 60), np.uint8))
    before = sorted(p.name for p in folder.iterdir())
    done = run("match", left, folder / "raw_r.png", "--rig", rig_file, "-o",
               folder / "d.pfm")
    assert done.exit_code == 2 and message in done.output
    assert len(done.output.strip().splitlines()) == 1
    assert sorted(p.name for p in folder.iterdir()) == before


def test_rig_options_without_a_rig_are_refused(raw_pair):
    folder, _ = raw_pair
    done = run("match", folder / "raw_l.png", folder / "raw_r.png", "-o", folder / "d.pfm",
               "--alpha", "0.5")
    assert done.exit_code == 2 and "need --rig" in done.output


def test_a_folder_of_raw_pairs_rectifies_with_one_rig_and_a_bad_pair_is_reported(raw_pair):
    import shutil

    folder, _ = raw_pair
    for side, raw in (("lefts", "raw_l.png"), ("rights", "raw_r.png")):
        (folder / side).mkdir()
        for name in ("a", "b"):
            shutil.copy(folder / raw, folder / side / f"{name}.png")
    write_png(folder / "lefts" / "c.png", np.zeros((50, 60), np.uint8))  # wrong size
    write_png(folder / "rights" / "c.png", np.zeros((50, 60), np.uint8))
    done = run("rectify", folder / "lefts", folder / "rights", "--rig", folder / "stereo.yml",
               "-O", folder / "rect")
    assert done.exit_code == 1 and "2 pair(s) rectified" in done.output
    assert "failed: c:" in done.output
    assert sorted(p.name for p in (folder / "rect/left").iterdir()) == \
        ["a.png", "b.png", "calib.txt"]
    matched = run("match", folder / "rect/left", folder / "rect/right", "-O",
                  folder / "maps", "--depth", ".pfm")
    assert matched.exit_code == 0, matched.output
    assert (folder / "maps" / "a.depth.pfm").is_file()


def test_a_batch_of_raw_pairs_matches_with_the_rig_s_maps_built_once(raw_pair, monkeypatch):
    import shutil

    from csw.camera import rectify

    folder, _ = raw_pair
    for side, raw in (("lefts", "raw_l.png"), ("rights", "raw_r.png")):
        (folder / side).mkdir()
        for name in ("a", "b", "c"):
            shutil.copy(folder / raw, folder / side / f"{name}.png")
    built = []
    original = rectify.rectify_maps
    monkeypatch.setattr(rectify, "rectify_maps",
                        lambda *a, **k: built.append(1) or original(*a, **k))
    done = run("match", folder / "lefts", folder / "rights", "--rig", folder / "stereo.yml",
               "-O", folder / "maps", "--depth", ".pfm")
    assert done.exit_code == 0, done.output
    assert len(built) == 2  # one map pair for the left camera, one for the right
    single = run("match", folder / "raw_l.png", folder / "raw_r.png", "--rig",
                 folder / "stereo.yml", "-o", folder / "one.pfm")
    assert single.exit_code == 0
    np.testing.assert_array_equal(csw.read_disparity(folder / "maps" / "b.pfm"),
                                  csw.read_disparity(folder / "one.pfm"))


def test_no_output_may_replace_the_rig_file(raw_pair):
    folder, _ = raw_pair
    rect = folder / "rect"
    rect.mkdir()
    rig_as_calib = rect / "calib.txt"  # a rig that happens to sit where calib.txt goes
    rig_as_calib.write_text((folder / "stereo.yml").read_text())
    before = rig_as_calib.read_bytes()
    done = run("rectify", folder / "raw_l.png", folder / "raw_r.png", "--rig", rig_as_calib,
               "-O", rect)
    assert done.exit_code == 2 and "calib.txt" in done.output
    assert rig_as_calib.read_bytes() == before
    assert sorted(p.name for p in rect.iterdir()) == ["calib.txt"]
    oddly_named = folder / "rig.png"  # a rig file with a picture's suffix
    oddly_named.write_text((folder / "stereo.yml").read_text())
    done = run("match", folder / "raw_l.png", folder / "raw_r.png", "--rig", oddly_named,
               "-o", folder / "d.pfm", "--rectified-left", oddly_named)
    assert done.exit_code == 2 and "rig.png" in done.output
    assert oddly_named.read_text().startswith("%YAML") and not (folder / "d.pfm").exists()


def _words(text):
    import re

    return set(re.findall(r"[a-z]+", text))


@pytest.mark.parametrize("units, expected", [(None, None), ("m", "mm")])
def test_units_are_carried_through_rectify_never_invented(raw_pair, monkeypatch, units,
                                                          expected):
    """A rig without units gives no "mm" or "m" anywhere downstream: rectify's summary
    and calib.txt, match --depth, depth, cloud, and the preview legends; a rig in m
    says m, and its calib.txt mm (the baseline in mm, as Middlebury's) all the way on."""
    from dataclasses import replace

    from csw.camera.calibration import read_calibration
    from csw.io import pictures

    folder, rig = raw_pair
    if units:
        write_opencv(folder / "stereo.yml", replace(rig, units=units))
        text = (folder / "stereo.yml").read_text() + f"units: {units}\n"
        (folder / "stereo.yml").write_text(text)
    legends = []
    original = pictures.depth_picture
    monkeypatch.setattr(pictures, "depth_picture",
                        lambda z, u=None: legends.append(u) or original(z, u))
    rect = folder / "rect"
    outputs = [run("rectify", folder / "raw_l.png", folder / "raw_r.png", "--rig",
                   folder / "stereo.yml", "-O", rect)]
    assert read_calibration(rect / "calib.txt").units == expected
    outputs.append(run("match", rect / "left.png", rect / "right.png", "-o", folder / "d.pfm",
                       "--depth", folder / "z.pfm", "--depth-preview", folder / "z.png"))
    outputs.append(run("depth", folder / "d.pfm", "--calib", rect / "calib.txt", "-o",
                       folder / "z2.pfm", "--preview", folder / "z2.png"))
    outputs.append(run("cloud", folder / "d.pfm", "--calib", rect / "calib.txt", "-o",
                       folder / "c.ply"))
    for done, unit in zip(outputs, [units, expected, expected, expected], strict=True):
        assert done.exit_code == 0, done.output
        said = _words(done.output) & {"mm", "m"}
        assert said == ({unit} if unit else set()), done.output
    assert legends == [expected, expected]
    assert ("units=none" if expected is None else "units=mm") in \
        (rect / "calib.txt").read_text()


def test_calib_reads_an_opencv_rig_that_gives_its_rectification(raw_pair):
    """An OpenCV rig with R1, R2, P1, P2 (stereoRectify's) and no Q: its "P2:" line was
    taken for a KITTI calib's, which was then refused for lacking P3."""
    from rig_fixtures import write_opencv

    from csw.camera.calibration import read_calibration

    folder, rig = raw_pair
    rect = Rectifier(rig)
    path = folder / "rectified.yml"
    write_opencv(path, rig, given={"R1": rect.r1, "R2": rect.r2, "P1": rect.p1,
                                   "P2": rect.p2},
                 keys=("M1", "D1", "M2", "D2", "R", "T", "R1", "R2", "P1", "P2"))
    assert read_calibration(path).matrix().tolist() == rect.calibration.matrix().tolist()


def test_calib_takes_a_rig_file_or_names_rig(raw_pair):
    """One door: --calib reads every rig file (its rectified pair's geometry gives Q, as
    csw rectify's calib.txt), or its one-line error names --rig."""
    from rig_fixtures import ros_camera_info

    from csw.camera.calibration import read_calibration

    folder, rig = raw_pair
    rect = Rectifier(rig)
    assert read_calibration(folder / "stereo.yml").matrix().tolist() == \
        rect.calibration.matrix().tolist()
    csw.write_disparity(folder / "d.pfm", np.full(SIZE[::-1], 10, np.float32))
    done = run("cloud", folder / "d.pfm", "--calib", folder / "stereo.yml", "-o",
               folder / "c.ply")
    assert done.exit_code == 0 and f"{SIZE[0] * SIZE[1]} points" in done.output, done.output
    (folder / "left.yaml").write_text(ros_camera_info(rig.k1, rig.d1, rect.r1, rect.p1, SIZE))
    done = run("cloud", folder / "d.pfm", "--calib", folder / "left.yaml", "-o",
               folder / "c2.ply")
    assert done.exit_code == 2 and "give it to --rig" in done.output
    assert len(done.output.strip().splitlines()) == 1 and not (folder / "c2.ply").exists()

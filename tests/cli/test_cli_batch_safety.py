"""Batches that cannot hurt: a manifest's names are names, no output is an input, nothing
is written outside the output folder, and a full disk fails one pair cleanly."""

import errno
import hashlib
import json
import os
import string

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import csw
from csw.data.synth import render
from csw.io import write_png
from csw_cli.main import cli


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def digest(path):
    return hashlib.md5(path.read_bytes()).hexdigest()


def snapshot(root, skip=None):
    """Every file under root (but ``skip``'s) with its digest."""
    return {str(p.relative_to(root)): digest(p) for p in sorted(root.rglob("*"))
            if p.is_file() and (skip is None or skip not in p.parents)}


@pytest.fixture
def pair(lr_pngs):
    return lr_pngs


def test_the_reproduction_writes_nothing_and_exits_2(pair):
    """The issue's case: a name ../l with --suffix .png once overwrote the input l.png."""
    (pair / "pairs.csv").write_text("l.png,r.png,../l\n")
    before = snapshot(pair)
    result = invoke("match", "--manifest", pair / "pairs.csv", "-O", pair / "out",
                    "--suffix", ".png", "--overwrite", "--dmax", 10)
    assert result.exit_code == 2 and "line 1" in result.output
    assert len(result.output.strip().splitlines()[-1]) < 300
    assert snapshot(pair) == before and not (pair / "out").exists()


@pytest.mark.parametrize("name, problem", [
    ("../evil", "path separator"), ("/srv/x/abs", "path separator"), ("a/b", "separator"),
    ("a\\b", "separator"), ("..", "'..'"), ("x..y", "'..'"), ('"x\x00y"', "control"),
    ('"tab\there"', "control"), ('"new\nline"', "control"), ("C:evil", "drive"),
])
def test_a_name_that_is_not_a_plain_name_is_refused(pair, name, problem):
    (pair / "m.csv").write_text(f"# pairs\nl.png,r.png,ok\nl.png,r.png,{name}\n")
    before = snapshot(pair)
    result = invoke("match", "--manifest", pair / "m.csv", "-O", pair / "out", "--dmax", 10)
    assert result.exit_code == 2, result.output
    assert "line 3" in result.output and problem in result.output
    assert snapshot(pair) == before and not (pair / "out").exists()


def test_an_empty_name_and_names_that_differ_in_case_are_refused(pair):
    (pair / "m.csv").write_text("l.png,r.png,\n")
    assert "is empty" in invoke("match", "--manifest", pair / "m.csv", "-O",
                                pair / "out").output
    (pair / "m.csv").write_text("l.png,r.png,Scene\nl.png,r.png,scene\n")
    result = invoke("match", "--manifest", pair / "m.csv", "-O", pair / "out")
    assert result.exit_code == 2 and "differ only in case" in result.output
    assert not (pair / "out").exists()


def test_an_output_that_is_an_input_is_refused(pair):
    (pair / "out").mkdir()
    write_png(pair / "out" / "x.png", render(80, 48, dmax=10, seed=5)[0])
    (pair / "m.csv").write_text("out/x.png,r.png,x\n")
    before = snapshot(pair)
    result = invoke("match", "--manifest", pair / "m.csv", "-O", pair / "out",
                    "--suffix", ".png", "--overwrite", "--dmax", 10)
    assert result.exit_code == 2 and "is an input" in result.output
    assert snapshot(pair) == before
    result = invoke("match", "--manifest", pair / "m.csv", "-O", pair / "out",
                    "--summary", pair / "r.png", "--dmax", 10)
    assert result.exit_code == 2 and "summary" in result.output
    assert snapshot(pair) == before


def test_an_output_linked_outside_the_folder_is_refused(pair):
    (pair / "out").mkdir()
    (pair / "out" / "p.pfm").symlink_to(pair / "elsewhere.pfm")
    (pair / "m.csv").write_text("l.png,r.png,p\n")
    result = invoke("match", "--manifest", pair / "m.csv", "-O", pair / "out", "--overwrite",
                    "--dmax", 10)
    assert result.exit_code == 2 and "outside the output folder" in result.output
    assert not (pair / "elsewhere.pfm").exists()


def test_the_output_folder_is_created_and_a_file_there_is_an_error(pair):
    (pair / "m.csv").write_text("l.png,r.png,p\n")
    deep = pair / "a" / "b" / "out"
    result = invoke("match", "--manifest", pair / "m.csv", "-O", deep, "--dmax", 10)
    assert result.exit_code == 0, result.output
    assert (deep / "p.pfm").is_file() and (deep / "summary.json").is_file()
    (pair / "file").write_text("x")
    result = invoke("match", "--manifest", pair / "m.csv", "-O", pair / "file")
    assert result.exit_code == 2 and "is a file" in result.output
    with pytest.raises(ValueError, match="not a folder"):
        csw.match_many(csw.jobs_from_manifest(pair / "m.csv"), pair / "file", progress=False)


def test_the_manifest_is_read_as_csv(pair):
    """A byte-order mark, a header, comments, blank lines, quoted fields with commas."""
    (pair / "a, b.png").write_bytes((pair / "l.png").read_bytes())
    (pair / "m.csv").write_bytes(b"\xef\xbb\xbfleft,right,name\r\n# a comment\r\n\r\n"
                                 b'"a, b.png",r.png,"first"\r\nl.png,r.png\r\n')
    jobs = csw.jobs_from_manifest(pair / "m.csv")
    assert [(j.name, j.left.name) for j in jobs] == [("first", "a, b.png"), ("l", "l.png")]
    assert jobs[0].where.endswith("line 4")
    (pair / "m.csv").write_text('l.png,r.png\n"unclosed,r.png\n')
    with pytest.raises(ValueError, match="line"):
        csw.jobs_from_manifest(pair / "m.csv")


def test_overwrite_redoes_outputs_that_exist(pair):
    (pair / "m.csv").write_text("l.png,r.png,p\n")
    out = pair / "out"
    assert invoke("match", "--manifest", pair / "m.csv", "-O", out, "--dmax", 10).exit_code == 0
    want = (out / "p.pfm").read_bytes()
    (out / "p.pfm").write_bytes(b"stale")
    assert invoke("match", "--manifest", pair / "m.csv", "-O", out, "--dmax", 10).exit_code == 0
    assert (out / "p.pfm").read_bytes() == b"stale"  # skipped: a rerun resumes
    assert invoke("match", "--manifest", pair / "m.csv", "-O", out, "--dmax", 10,
                  "--overwrite").exit_code == 0
    assert (out / "p.pfm").read_bytes() == want


def test_a_full_disk_fails_one_pair_and_leaves_no_partial_file(pair, monkeypatch):
    import csw.io.formats as formats

    lines = "".join(f"l.png,r.png,p{i}\n" for i in range(4))
    (pair / "m.csv").write_text(lines)
    real = formats.pfm_writer

    def third_fails(values):
        # The third pair's map (pairs may run side by side: by its name, not by order).
        def half_then_full(tmp):
            if ".p2.pfm." not in os.path.basename(tmp):
                return real(values)(tmp)
            with open(tmp, "wb") as f:
                f.write(b"Pf\n80 48\n-1\n" + b"\0" * 100)
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(tmp))
        return half_then_full

    monkeypatch.setattr(formats, "pfm_writer", third_fails)
    out = pair / "out"
    result = invoke("match", "--manifest", pair / "m.csv", "-O", out, "--dmax", 10)
    assert result.exit_code == 1 and "No space left on device" in result.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["counts"] == {"ok": 3, "skipped": 0, "failed": 1}
    failed = [e for e in summary["pairs"] if e["status"] == "failed"]
    assert failed[0]["name"] == "p2" and "No space left" in failed[0]["error"]
    assert sorted(p.name for p in out.iterdir()) == ["p0.pfm", "p1.pfm", "p3.pfm",
                                                     "summary.json"]


NAMES = st.one_of(
    st.text(alphabet=string.ascii_letters + string.digits + "._-", min_size=1, max_size=8),
    st.sampled_from(["..", "../x", "../../y", "/tmp/abs", "a/b", "a\\b", "C:z", "x..", "",
                     ".", "...", "l", "r", "summary", "L", "m"]),
    st.text(min_size=0, max_size=6))
PATHS = st.sampled_from(["l.png", "r.png", "out/l.png", "../l.png", "missing.png", "m.csv",
                         "out/summary.json"])


@pytest.mark.slow
@settings(deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture,
                                 HealthCheck.too_slow])
@given(st.lists(st.tuples(PATHS, PATHS, st.one_of(st.none(), NAMES)), min_size=1,
                max_size=4),
       st.sampled_from([".pfm", ".png", ".npy"]), st.booleans())
def test_no_manifest_writes_outside_the_folder_or_changes_an_input(pair, records, suffix,
                                                                   overwrite):
    """Whatever a manifest holds, every file outside out/ is unchanged afterwards, and so
    is out/l.png where the manifest uses it as an input."""
    import csv
    import io
    import shutil

    shutil.rmtree(pair / "out", ignore_errors=True)
    (pair / "out").mkdir()
    write_png(pair / "out" / "l.png", render(80, 48, dmax=10, seed=6)[0])
    buffer = io.StringIO()
    writer = csv.writer(buffer)
    for left, right, name in records:
        writer.writerow([left, right] if name is None else [left, right, name])
    (pair / "m.csv").write_text(buffer.getvalue())
    before = snapshot(pair.parent, skip=pair / "out")
    inside_before = {"l.png": digest(pair / "out" / "l.png")}
    result = invoke("match", "--manifest", pair / "m.csv", "-O", pair / "out", "--suffix",
                    suffix, "--dmax", 10, "--preset", "raw", *(["--overwrite"] if overwrite
                                                              else []))
    assert result.exit_code in (0, 1, 2), result.output
    assert snapshot(pair.parent, skip=pair / "out") == before
    if any("out/l.png" in (left, right) for left, right, _ in records):
        assert digest(pair / "out" / "l.png") == inside_before["l.png"]


def test_an_atomic_write_that_fails_half_way_leaves_nothing(tmp_path):
    """The single-file writer (every map, PNG, summary and plot goes through it)."""
    from csw.io import atomic_write

    def broken(tmp):
        with open(tmp, "wb") as f:
            f.write(b"half")
        raise OSError(errno.ENOSPC, "No space left on device")

    target = tmp_path / "new.pfm"
    with pytest.raises(OSError):
        atomic_write(target, broken)
    assert list(tmp_path.iterdir()) == []
    target.write_bytes(b"the old map")
    with pytest.raises(OSError):
        atomic_write(target, broken)
    assert target.read_bytes() == b"the old map" and list(tmp_path.iterdir()) == [target]


def test_density_counts_known_ground_truth_only():
    """density = valid and known / known: by hand, 2 of the 4 known pixels are valid."""
    gt = np.array([[1, np.nan, 3], [4, 5, np.nan]], np.float32)
    disp = np.array([[1, 2, np.nan], [4, np.nan, 6]], np.float32)
    metrics = csw.score(disp, gt, {"all": np.ones(gt.shape, bool)})["all"]
    assert metrics["pixels"] == 4 and metrics["density"] == 50.0
    assert metrics["bad_valid"][1.0] == 0.0 and metrics["invalid"] == 50.0

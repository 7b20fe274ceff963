"""csw.match_many: many pairs, progress, a summary, and bad pairs reported, not fatal."""

import json
import os

import numpy as np
import pytest

import csw
import csw.scale.batch
from csw.data.synth import render
from csw.io import read_disparity, write_png


@pytest.fixture
def folders(tmp_path):
    for name in ("left", "right", "out"):
        (tmp_path / name).mkdir()
    scenes = {}
    for i in range(3):
        left, right, _, _ = render(64, 40, dmax=12, seed=i)
        write_png(tmp_path / "left" / f"p{i}.png", left)
        write_png(tmp_path / "right" / f"p{i}.png", right)
        scenes[f"p{i}"] = (left, right)
    return tmp_path, scenes


def test_folders_equal_one_by_one_and_bad_pairs_are_reported(folders):
    root, scenes = folders
    (root / "left" / "bad.png").write_bytes(b"not a png")
    (root / "right" / "bad.png").write_bytes(b"not a png")
    write_png(root / "left" / "lonely.png", np.zeros((40, 64), np.uint8))
    jobs = csw.jobs_from_folders(root / "left", root / "right")
    report = csw.match_many(jobs, root / "out", dmax=12, progress=False)
    assert report["counts"] == {"ok": 3, "skipped": 0, "failed": 2}
    failed = {e["name"]: e["error"] for e in report["pairs"] if e["status"] == "failed"}
    assert "not a readable image" in failed["bad"] and "no lonely.png" in failed["lonely"]
    for name, (left, right) in scenes.items():
        want = csw.match(left, right, dmax=12).disparity
        np.testing.assert_array_equal(read_disparity(root / "out" / f"{name}.pfm"), want)
    assert json.loads((root / "out" / "summary.json").read_text())["counts"]["failed"] == 2
    assert not (root / "out" / "bad.pfm").exists()


def test_rerun_skips_finished_outputs_unless_overwrite(folders):
    root, _ = folders
    jobs = csw.jobs_from_folders(root / "left", root / "right")
    csw.match_many(jobs, root / "out", dmax=12, progress=False)
    again = csw.match_many(jobs, root / "out", dmax=12, progress=False)
    assert again["counts"] == {"ok": 0, "skipped": 3, "failed": 0}
    redo = csw.match_many(jobs, root / "out", dmax=12, progress=False, overwrite=True,
                          suffix=".npy")
    assert redo["counts"]["ok"] == 3 and (root / "out" / "p0.npy").is_file()


def test_a_killed_writer_s_temporary_file_goes_when_the_batch_ends(folders):
    """A worker killed mid-write leaves p1.pfm's temporary file, too fresh for the
    day-old rule; once every task has finished, the batch removes it."""
    from csw.io.atomic import HOST

    root, _ = folders
    (root / "out").mkdir(exist_ok=True)
    alive = os.getppid()  # a worker that is still running, as far as the sweep can tell
    left_behind = root / "out" / f".csw-tmp.p1.pfm.{HOST}-{alive}-abc123.tmp"
    left_behind.write_bytes(b"half a map")
    unrelated = root / "out" / f".csw-tmp.other.pfm.{HOST}-{alive}-abc123.tmp"
    unrelated.write_bytes(b"someone else's")
    jobs = csw.jobs_from_folders(root / "left", root / "right")
    assert csw.match_many(jobs, root / "out", dmax=12, progress=False)["counts"]["ok"] == 3
    assert not left_behind.exists() and unrelated.exists()


def test_manifest_names_and_relative_paths(folders):
    root, scenes = folders
    (root / "pairs.csv").write_text("# left,right,name\nleft/p0.png,right/p0.png,first\n\n"
                                    "left/p1.png,right/p1.png\n")
    jobs = csw.jobs_from_manifest(root / "pairs.csv")
    assert [j.name for j in jobs] == ["first", "p1"]
    report = csw.match_many(jobs, root / "out", dmax=12, progress=False, suffix=".png")
    assert report["counts"]["ok"] == 2 and (root / "out" / "first.png").is_file()


@pytest.mark.parametrize("text, message", [("a.png\n", "line 1"), ("", "lists no pairs"),
                                           ("a,b\nc,d,e,f\n", "line 2")])
def test_bad_manifest(tmp_path, text, message):
    (tmp_path / "m.csv").write_text(text)
    with pytest.raises(ValueError, match=message):
        csw.jobs_from_manifest(tmp_path / "m.csv")


def test_two_pairs_writing_one_output_are_refused(folders):
    root, _ = folders
    (root / "m.csv").write_text("left/p0.png,right/p0.png,x\nleft/p1.png,right/p1.png,x\n")
    with pytest.raises(ValueError, match="both write"):
        csw.match_many(csw.jobs_from_manifest(root / "m.csv"), root / "out", progress=False)


def test_an_interrupted_batch_says_what_finished(folders, monkeypatch):
    root, _ = folders
    calls = []
    real = csw.scale.batch.run_job

    def run_then_stop(task, **options):
        calls.append(task[0].name)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(task, **options)

    monkeypatch.setattr(csw.scale.batch, "run_job", run_then_stop)
    jobs = csw.jobs_from_folders(root / "left", root / "right")
    with pytest.raises(KeyboardInterrupt):  # one thread: one pair at a time
        csw.match_many(jobs, root / "out", dmax=12, progress=False, threads=1)
    summary = json.loads((root / "out" / "summary.json").read_text())
    assert summary["interrupted"] and summary["counts"]["ok"] == 1
    assert sorted(p.name for p in (root / "out").iterdir()) == ["p0.pfm", "summary.json"]


@pytest.mark.two_cores
def test_small_pairs_run_side_by_side_and_give_the_same_maps(folders, monkeypatch):
    import threading

    root, _ = folders
    seen = set()
    real = csw.scale.batch.run_job

    def noting_thread(task, **options):
        seen.add(threading.current_thread().name)
        assert options["config"].threads == 1  # one thread each, side by side
        return real(task, **options)

    monkeypatch.setattr(csw.scale.batch, "run_job", noting_thread)
    jobs = csw.jobs_from_folders(root / "left", root / "right")
    report = csw.match_many(jobs, root / "two", dmax=12, progress=False, threads=2)
    assert report["counts"]["ok"] == len(jobs)
    assert [p["name"] for p in report["pairs"]] == [job.name for job in jobs]  # in order
    assert all(name.startswith("csw-pair") for name in seen)
    alone = csw.match_many(jobs, root / "one", dmax=12, progress=False, threads=1)
    assert alone["counts"]["ok"] == len(jobs)
    for job in jobs:
        np.testing.assert_array_equal(csw.read_disparity(root / "two" / f"{job.name}.pfm"),
                                      csw.read_disparity(root / "one" / f"{job.name}.pfm"))


def test_a_batch_pair_is_a_single_pair_and_can_be_striped(folders, monkeypatch):
    """One path from a pair to files: a batch pair's map has the bytes of the same pair
    matched alone, and a pair too big for memory is matched in stripes (forced here),
    to the same bytes."""
    import csw.scale.files

    root, _ = folders
    jobs = csw.jobs_from_folders(root / "left", root / "right")
    csw.match_many(jobs, root / "out", dmax=12, progress=False)
    csw.match_files(jobs[0].left, jobs[0].right, root / "one.pfm", dmax=12)
    whole = (root / "out" / f"{jobs[0].name}.pfm").read_bytes()
    assert whole == (root / "one.pfm").read_bytes()
    monkeypatch.setattr(csw.scale.files, "too_big_for_whole", lambda *a, **k: True)
    report = csw.match_many(jobs[:1], root / "striped", dmax=12, progress=False)
    assert report["pairs"][0]["stripes"] >= 1
    assert (root / "striped" / f"{jobs[0].name}.pfm").read_bytes() == whole

"""Many pairs on a Dask LocalCluster bound to 127.0.0.1 with 2 worker processes: the
same maps as one by one, a bad pair reported, a worker killed mid-batch survived."""

import json
import os
import signal
import time

import numpy as np
import pytest
from click.testing import CliRunner

import csw
from csw.data.synth import render
from csw.io import read_disparity, write_png

distributed = pytest.importorskip("dask.distributed")
pytestmark = pytest.mark.slow  # a cluster starts in seconds


@pytest.fixture(scope="module")
def client():
    from csw.scale.distributed import close, local_client

    client = local_client(2)
    yield client
    close(client)


def write_pairs(root, count, size=(96, 64)):
    for name in ("l", "r", "out"):
        (root / name).mkdir()
    scenes = {}
    for i in range(count):
        left, right, _, _ = render(*size, dmax=12, seed=i)
        write_png(root / "l" / f"p{i:02d}.png", left)
        write_png(root / "r" / f"p{i:02d}.png", right)
        scenes[f"p{i:02d}"] = (left, right)
    return scenes


def test_cluster_batch_equals_one_by_one_and_reports_a_bad_pair(tmp_path, client):
    scenes = write_pairs(tmp_path, 4)
    (tmp_path / "l" / "bad.png").write_bytes(b"not an image")
    (tmp_path / "r" / "bad.png").write_bytes(b"not an image")
    jobs = csw.jobs_from_folders(tmp_path / "l", tmp_path / "r")
    report = csw.match_many(jobs, tmp_path / "out", dmax=12, progress=False, client=client)
    assert report["counts"] == {"ok": 4, "skipped": 0, "failed": 1}
    assert [e["name"] for e in report["pairs"]] == ["bad", *sorted(scenes)]  # jobs' order
    assert "not a readable image" in report["pairs"][0]["error"]
    for name, (left, right) in scenes.items():
        want = csw.match(left, right, dmax=12).disparity
        np.testing.assert_array_equal(read_disparity(tmp_path / "out" / f"{name}.pfm"), want)


def test_a_worker_killed_mid_batch_loses_nothing(tmp_path, client):
    scenes = write_pairs(tmp_path, 12, size=(320, 240))
    jobs = csw.jobs_from_folders(tmp_path / "l", tmp_path / "r")
    pids = list(client.run(os.getpid).values())
    killed = []

    def kill_one():
        # Once the first map is on disk the batch is under way: kill one worker process.
        while not any((tmp_path / "out").glob("*.pfm")):
            time.sleep(0.02)
        os.kill(pids[0], signal.SIGKILL)
        killed.append(pids[0])

    import threading

    killer = threading.Thread(target=kill_one, daemon=True)
    killer.start()
    report = csw.match_many(jobs, tmp_path / "out", dmax=12, progress=False, client=client)
    killer.join(timeout=60)
    assert killed, "the batch finished before a worker could be killed"
    assert report["counts"] == {"ok": 12, "skipped": 0, "failed": 0}
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert names == sorted(f"{n}.pfm" for n in scenes) + ["summary.json"]  # no temp files
    for name, (left, right) in scenes.items():
        want = csw.match(left, right, dmax=12).disparity
        np.testing.assert_array_equal(read_disparity(tmp_path / "out" / f"{name}.pfm"), want)


def test_cli_workers_and_an_unreachable_scheduler(tmp_path):
    from csw_cli.main import cli

    write_pairs(tmp_path, 2)
    args = ["match", str(tmp_path / "l"), str(tmp_path / "r"), "-O", str(tmp_path / "out"),
            "--dmax", "12"]
    ok = CliRunner().invoke(cli, [*args, "--workers", "2"])
    assert ok.exit_code == 0, ok.output
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["counts"]["ok"] == 2
    bad = CliRunner().invoke(cli, [*args, "--overwrite", "--scheduler", "tcp://127.0.0.1:9"])
    assert bad.exit_code == 2 and "can't reach the Dask scheduler" in bad.output
    both = CliRunner().invoke(cli, [*args, "--workers", "2", "--scheduler", "tcp://x:1"])
    assert both.exit_code == 2 and "not both" in both.output


def test_the_stripes_of_one_pair_as_cluster_tasks(tmp_path, client):
    import tifffile

    from csw.scale.tiled import match_tiled

    left, right, _, _ = render(300, 157, dmax=20, seed=3)
    tifffile.imwrite(tmp_path / "l.tif", left, tile=(32, 32))
    tifffile.imwrite(tmp_path / "r.tif", right, tile=(32, 32))
    result = match_tiled(tmp_path / "l.tif", tmp_path / "r.tif", tmp_path / "d.tif",
                         stripe_rows=20, client=client, dmax=20, preset="accurate",
                         subpixel="parabola", median=3)
    assert len(result.plan.stripes) == 8
    want = csw.match(left, right, dmax=20, preset="accurate", subpixel="parabola",
                     median=3).disparity
    np.testing.assert_array_equal(tifffile.imread(tmp_path / "d.tif"), want)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.tif", "l.tif", "r.tif"]


def test_a_tls_scheduler_with_dasks_own_security_settings(tmp_path):
    """--scheduler tls://... uses Dask's TLS configuration (here its environment variables):
    the batch runs over an encrypted connection to a scheduler that requires one."""
    import subprocess
    import sys

    from distributed import LocalCluster
    from distributed.security import Security

    cert, key = tmp_path / "cert.pem", tmp_path / "key.pem"
    made = subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes",
                           "-keyout", str(key), "-out", str(cert), "-days", "1", "-subj",
                           "/CN=localhost", "-addext",
                           "subjectAltName=IP:127.0.0.1,DNS:localhost"],
                          capture_output=True, text=True)
    if made.returncode != 0:
        pytest.skip(f"openssl can't make a certificate here: {made.stderr[-200:]}")
    files = {f"tls_{role}_{part}": str(path) for role in ("scheduler", "worker", "client")
             for part, path in (("cert", cert), ("key", key))}
    security = Security(tls_ca_file=str(cert), require_encryption=True, **files)
    write_pairs(tmp_path, 2)
    with LocalCluster(n_workers=1, processes=False, protocol="tls://", host="127.0.0.1",
                      security=security, dashboard_address=None) as cluster:
        address = cluster.scheduler_address
        assert address.startswith("tls://")
        env = dict(os.environ, DASK_DISTRIBUTED__COMM__TLS__CA_FILE=str(cert),
                   DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT=str(cert),
                   DASK_DISTRIBUTED__COMM__TLS__CLIENT__KEY=str(key),
                   DASK_DISTRIBUTED__COMM__REQUIRE_ENCRYPTION="True")
        args = [sys.executable, "-m", "csw_cli", "match", str(tmp_path / "l"),
                str(tmp_path / "r"), "-O", str(tmp_path / "out"), "--dmax", "12",
                "--scheduler", address]
        done = subprocess.run(args, env=env, capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        assert json.loads((tmp_path / "out" / "summary.json").read_text())["counts"]["ok"] == 2
        plain = subprocess.run([*args[:-1], address.replace("tls://", "tcp://"),
                                "--overwrite"], capture_output=True, text=True, timeout=600)
        assert plain.returncode == 2 and "can't reach the Dask scheduler" in plain.stderr

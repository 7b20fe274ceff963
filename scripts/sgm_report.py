"""Write reports/sgm.md: semi-global matching's speed, memory and stripes (make bench-sgm).

  1. Speed: csw's sgm preset (the whole csw.match call) and its kernel alone against
     OpenCV SGBM (MODE_SGBM, OpenCV's sample settings) and StereoBM, in one process,
     interleaved, after a warm-up, median of rounds (min / median / max of the ratios
     to each peer's one-thread time):
     KITTI 2015's first frame (1242 x 375, d 0..191) and the 1080p synthetic pair
     (d 0..255), csw with 1 and 2 threads, the peers with 1; and million disparity
     evaluations a second (W * H * D / s) per core.
  2. Streams: Matcher.stream with the sgm preset against SGBM's frames a second, both
     with 2 threads, at 640 x 480 d 0..63; and both with 1.
  3. Memory: peak RSS of `csw match --preset sgm` on the 1080p pair, d 0..255.
  4. Stripes: the share of pixels of csw.match_tiled's map that differ from the whole
     image's, at several stripe heights, on a 2000 x 2000 synthetic pair (d 0..127).

Usage: python scripts/sgm_report.py --output reports/sgm.md [--rounds N]
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from functools import partial
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

import csw  # noqa: E402
import peers  # noqa: E402
from csw.config.params import PRESETS  # noqa: E402
from csw.data import layouts  # noqa: E402
from csw.data.synth import render, write_tiff_scene  # noqa: E402
from csw.io import read_disparity  # noqa: E402
from csw.kernels import target_cpu  # noqa: E402
from csw.scale.tiled import match_tiled  # noqa: E402
from report_common import (  # noqa: E402
    PEAK_PROBE,
    cpu_name,
    fill_template,
    now_utc,
    peak_memory_mb,
    spread,
)

PRESET = "sgm"


def kitti_pair(data_dir):
    pair = layouts.find_scene(Path(data_dir) / "kitti2015", "000000_10").load()
    return pair.left, pair.right  # read as gray


def timed(call):
    start = time.perf_counter()
    call()
    return time.perf_counter() - start


def speed(name, left, right, dmax, rounds):
    """Rows of the speed table for one pair: each method's median seconds, its ratios to
    SGBM's and StereoBM's one-thread times (min / median / max over rounds), and M
    evaluations/s/core."""
    ndisp = peers.ndisp16(dmax)
    sgbm, bm = peers.sgbm_sample(ndisp), peers.stereo_bm(ndisp)

    def peer(matcher, threads):
        peers.cv2.setNumThreads(threads)
        return lambda: matcher.compute(left, right)

    methods = {
        "csw sgm, 1 thread": lambda: csw.match(left, right, preset=PRESET, dmin=0, dmax=dmax,
                                               threads=1),
        "csw sgm, 2 threads": lambda: csw.match(left, right, preset=PRESET, dmin=0,
                                                dmax=dmax, threads=2),
        "csw sgm whole range, 1 thread": lambda: csw.match(
            left, right, preset=PRESET, sgm_narrow=0, dmin=0, dmax=dmax, threads=1),
        "csw sgm whole range, 2 threads": lambda: csw.match(
            left, right, preset=PRESET, sgm_narrow=0, dmin=0, dmax=dmax, threads=2),
        "csw sgm 5 paths, 1 thread": lambda: csw.match(
            left, right, preset=PRESET, sgm_paths=5, dmin=0, dmax=dmax, threads=1),
        "csw sgm 5 paths, 2 threads": lambda: csw.match(
            left, right, preset=PRESET, sgm_paths=5, dmin=0, dmax=dmax, threads=2),
        "csw accurate, 1 thread": lambda: csw.match(left, right, preset="accurate", dmin=0,
                                                    dmax=dmax, threads=1),
        "SGBM, 1 thread": peer(sgbm, 1),
        "StereoBM, 1 thread": peer(bm, 1),
    }
    threads = {k: (2 if "2 threads" in k else 1) for k in methods}
    for call in methods.values():  # warm-up: kernels loaded, caches filled
        call()
    times = {k: [] for k in methods}
    for _ in range(rounds):
        for key, call in methods.items():
            times[key].append(timed(call))
    peers.cv2.setNumThreads(-1)
    evaluations = left.size * (dmax + 1) / 1e6
    rows = []
    for key, values in times.items():
        ratios = [spread([t / s for t, s in zip(values, times[peer], strict=True)])
                  for peer in ("SGBM, 1 thread", "StereoBM, 1 thread")]
        median = statistics.median(values)
        rows.append(f"| {name} | {key} | {median * 1000:.0f} | {' | '.join(ratios)} | "
                    f"{evaluations / median / threads[key]:.0f} |")
    return rows


def stream(rounds, frames=24):
    """Frames a second at 640 x 480, d 0..63: {"csw" | "SGBM": {threads: [per round]}}
    for 2 threads each (the target's) and 1, the rounds interleaved."""
    pairs = [render(640, 480, 63, 3, phase=i / frames)[:2] for i in range(frames)]
    matchers = {threads: csw.Matcher(preset=PRESET, dmin=0, dmax=63, threads=threads)
                for threads in (2, 1)}
    sgbm = peers.sgbm_sample(64)
    for matcher in matchers.values():
        list(matcher.stream(pairs[:4]))

    def run_csw(threads):
        for _ in matchers[threads].stream(pairs):
            pass

    def run_sgbm(threads):
        peers.cv2.setNumThreads(threads)
        for left, right in pairs:
            sgbm.compute(left, right)

    rates = {"csw": {2: [], 1: []}, "SGBM": {2: [], 1: []}}
    for _ in range(rounds):
        for threads in (2, 1):
            rates["csw"][threads].append(frames / timed(partial(run_csw, threads)))
            rates["SGBM"][threads].append(frames / timed(partial(run_sgbm, threads)))
    peers.cv2.setNumThreads(-1)
    return rates


def stripes(work):
    """Rows: stripe rows, stripes, share of pixels differing from the whole image's."""
    left, right, _, _ = render(2000, 2000, dmax=120, seed=7)
    whole = csw.match(left, right, preset=PRESET, dmin=0, dmax=127).disparity
    rows = []
    for stripe_rows in (250, 500, 1000):
        out = Path(work) / f"s{stripe_rows}.pfm"
        match_tiled(left, right, out, stripe_rows=stripe_rows, preset=PRESET, dmin=0,
                    dmax=127)
        striped = read_disparity(out)
        same = (striped == whole) | (np.isnan(striped) & np.isnan(whole))
        rows.append(f"| {stripe_rows} | {-(-2000 // stripe_rows)} | "
                    f"{100 * (1 - same.mean()):.3f} |")
    return rows


BIG_SIDE, BIG_DMAX = 8000, 64


def big_striped(work):
    """(peak RSS in MB, seconds) of `csw match` on an 8000 x 8000 synthetic TIFF pair,
    d 0..64, the sgm preset and the default memory limit, in a process of its own: row
    stripes (a TIFF map is written in stripes), all threads."""
    folder = Path(work) / "big"
    write_tiff_scene(folder, BIG_SIDE, BIG_SIDE, BIG_DMAX, seed=0)
    cmd = ["csw", "match", str(folder / "left.tif"), str(folder / "right.tif"), "-o",
           str(folder / "d.tif"), "--preset", PRESET, "--dmax", str(BIG_DMAX)]
    start = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", PEAK_PROBE, *cmd], check=True,
                         capture_output=True, text=True)
    return int(out.stdout.strip()) / 1024, time.perf_counter() - start


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default="reports/sgm.md")
    parser.add_argument("--data-dir", default=os.environ.get("CSW_DATA_DIR",
                                                             "../shared/datasets"))
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()

    rows = speed("KITTI 2015 000000, 1242 x 375, d 0..191", *kitti_pair(args.data_dir), 191,
                 args.rounds)
    left, right, _, _ = render(1920, 1080, dmax=255, seed=0)
    rows += speed("synthetic 1920 x 1080, d 0..255", left, right, 255, args.rounds)
    rates = stream(args.rounds)
    ours, theirs = rates["csw"][2], rates["SGBM"][2]
    ratios = [a / b for a, b in zip(ours, theirs, strict=True)]
    scaling = {name: [a / b for a, b in zip(r[2], r[1], strict=True)]
               for name, r in rates.items()}
    peak = peak_memory_mb(["--preset", PRESET, "--dmin", "0"])
    with tempfile.TemporaryDirectory() as work:
        stripe_rows = stripes(work)
        big_peak, big_seconds = big_striped(work)
    text = fill_template("sgm", [("report", dict(
        date=now_utc(), cpu=cpu_name(), llvm_cpu=target_cpu(), rounds=args.rounds,
        window=PRESETS[PRESET]["window"],
        speed_rows="\n".join(rows), ours=spread(ours), theirs=spread(theirs),
        ratios=spread(ratios), ours_1=spread(rates["csw"][1]),
        theirs_1=spread(rates["SGBM"][1]), csw_scaling=spread(scaling["csw"]),
        sgbm_scaling=spread(scaling["SGBM"]), peak=peak,
        stripe_rows="\n".join(stripe_rows), side=BIG_SIDE, big_dmax=BIG_DMAX,
        big_peak=big_peak, big_seconds=big_seconds))])
    Path(args.output).write_text(text)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()

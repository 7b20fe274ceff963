"""Write reports/sgm.md: semi-global matching's speed, memory and stripes (make bench-sgm).

  1. Speed: csw's sgm preset (the whole csw.match call) and its kernel alone against
     OpenCV SGBM (MODE_SGBM, OpenCV's sample settings) and StereoBM, in one process,
     interleaved, after a warm-up, median of rounds (min / median / max of the ratios):
     KITTI 2015's first frame (1242 x 375, d 0..191) and the 1080p synthetic pair
     (d 0..255), csw with 1 and 2 threads, the peers with 1; and million disparity
     evaluations a second (W * H * D / s) per core.
  2. Streams: Matcher.stream with the sgm preset against SGBM's frames a second, both
     with 2 threads, at 640 x 480 d 0..63.
  3. Memory: peak RSS of `csw match --preset sgm` on the 1080p pair, d 0..255.
  4. Stripes: the share of pixels of csw.match_tiled's map that differ from the whole
     image's, at several stripe heights, on a 2000 x 2000 synthetic pair (d 0..127).

Usage: python scripts/sgm_report.py --output reports/sgm.md [--rounds N]
"""

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

import csw  # noqa: E402
import peers  # noqa: E402
from csw.data import layouts  # noqa: E402
from csw.data.synth import render  # noqa: E402
from csw.io import read_disparity  # noqa: E402
from csw.kernels.store import target_cpu  # noqa: E402
from csw.scale.tiled import match_tiled  # noqa: E402
from report_common import cpu_name, now_utc, peak_memory_mb  # noqa: E402

PRESET = "sgm"


def kitti_pair(data_dir):
    pair = layouts.find_scene(Path(data_dir) / "kitti2015", "000000_10").load()
    return pair.left, pair.right  # read as gray


def spread(values):
    return f"{min(values):.2f} / {statistics.median(values):.2f} / {max(values):.2f}"


def timed(call):
    start = time.perf_counter()
    call()
    return time.perf_counter() - start


def speed(name, left, right, dmax, rounds):
    """Rows of the speed table for one pair: each method's median seconds, its ratio to
    SGBM's one-thread time (min / median / max over rounds), and M evaluations/s/core."""
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
        "csw sgm narrowed to 32, 1 thread": lambda: csw.match(
            left, right, preset=PRESET, sgm_narrow=32, dmin=0, dmax=dmax, threads=1),
        "csw sgm narrowed to 32, 2 threads": lambda: csw.match(
            left, right, preset=PRESET, sgm_narrow=32, dmin=0, dmax=dmax, threads=2),
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
    sgbm_times = times["SGBM, 1 thread"]
    evaluations = left.size * (dmax + 1) / 1e6
    rows = []
    for key, values in times.items():
        ratios = [t / s for t, s in zip(values, sgbm_times, strict=True)]
        median = statistics.median(values)
        rows.append(f"| {name} | {key} | {median * 1000:.0f} | {spread(ratios)} | "
                    f"{evaluations / median / threads[key]:.0f} |")
    return rows


def stream(rounds, frames=24):
    """(csw frames/s, SGBM frames/s, ratios) at 640 x 480, d 0..63, 2 threads each."""
    pairs = [render(640, 480, 63, 3, phase=i / frames)[:2] for i in range(frames)]
    matcher = csw.Matcher(preset=PRESET, dmin=0, dmax=63, threads=2)
    sgbm = peers.sgbm_sample(64)
    list(matcher.stream(pairs[:4]))

    def run_csw():
        for _ in matcher.stream(pairs):
            pass

    def run_sgbm():
        peers.cv2.setNumThreads(2)
        for left, right in pairs:
            sgbm.compute(left, right)

    ours, theirs = [], []
    for _ in range(rounds):
        ours.append(frames / timed(run_csw))
        theirs.append(frames / timed(run_sgbm))
    peers.cv2.setNumThreads(-1)
    return ours, theirs, [a / b for a, b in zip(ours, theirs, strict=True)]


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


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default="reports/sgm.md")
    parser.add_argument("--data-dir", default=os.environ.get("CSW_DATA_DIR",
                                                             "../shared/datasets"))
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()

    rows = speed("KITTI 2015 000000, 1242 x 375, d 0..191", *kitti_pair(args.data_dir), 191,
                 args.rounds)
    left, right, _, _ = render(1920, 1080, dmax=255, seed=0)
    rows += speed("synthetic 1920 x 1080, d 0..255", left, right, 255, args.rounds)
    ours, theirs, ratios = stream(args.rounds)
    peak = peak_memory_mb(["--preset", PRESET, "--dmin", "0"])
    with tempfile.TemporaryDirectory() as work:
        stripe_rows = stripes(work)
    text = f"""# Semi-global matching: speed, memory and stripes

Made by `make bench-sgm` ({now_utc()}) on {cpu_name()} (LLVM's `{target_cpu()}`), 2 cores.
csw's `sgm` preset is census 9x9 sparse codes over a 5x5 window, 4 paths, left-right
check, subpixel, speckle and median filters (docs/pipeline.md); its accuracy against
SGBM and StereoBM is in [quality.md](quality.md).  SGBM is MODE_SGBM with OpenCV's
sample settings (block 5, P1 8·25, P2 32·25); StereoBM 9x9.

## 1. Speed

The whole csw.match call (costs, aggregation, every stage) against each peer's
compute(), in one process, interleaved, {args.rounds} rounds after a warm-up.  Ratio:
each round's time over SGBM's one-thread time in that round (min / median / max).  M/s
per core: million disparity evaluations (W x H x D) a second, per thread used.  "narrowed
to 32" is `--sgm-narrow 32` (docs/engines.md): a half-size pass, then 32 disparities a
pixel at full size (off by default: it raises Middlebury 2014's filled bad, quality.md).
"5 paths" is `--sgm-paths 5`, OpenCV SGBM's own paths: one sweep down, no second pass
(off by default: it raises KITTI's filled D1 from 5.07% to 7.58%, docs/engines.md).

| pair | method | median ms | ratio to SGBM (1 thread) | M/s per core |
|---|---|---|---|---|
{chr(10).join(rows)}

## 2. Streams, 640 x 480, d 0..63, 2 threads each

Matcher.stream with the sgm preset against SGBM over the same 24 frames,
{args.rounds} rounds: csw {spread(ours)} frames/s, SGBM {spread(theirs)} frames/s,
ratio {spread(ratios)}.

## 3. Memory

Peak RSS of the whole `csw match --preset sgm` process on the 1080p pair, d 0..255, all
threads: {peak:.0f} MB (target: at most 500).  The volume (1920 x 1080 x 256 sums) would
be 1 GB in 16 bits; the bands hold about 100 MB of it (docs/engines.md).

## 4. Stripes

csw.match_tiled in row stripes, each with 64 rows more each side, against one whole-image
match of a 2000 x 2000 synthetic pair, d 0..127: the share of pixels whose disparity
differs (semi-global paths cross every row, so a stripe's edge rows see less of them).

| stripe rows | stripes | pixels that differ (%) |
|---|---|---|
{chr(10).join(stripe_rows)}
"""
    Path(args.output).write_text(text)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()

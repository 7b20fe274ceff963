"""csw's fast engine against OpenCV's StereoBM, in one run (make bench-peers).

Both use a 9x9 window and the same number of disparities (a multiple of 16). Each pair is
warmed up, then the variants are interleaved `--repeat` times and the medians reported;
ratios compare medians from this same run. Prints a Markdown report to stdout and, with
--output, writes it there too.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from csw import datasets as D
from csw import kernels
from csw.io import write_png
from csw.scoring import score
from csw.synth import render
from report_common import cpu_name, now_utc

try:
    import cv2
except ImportError:
    sys.exit("bench_peers needs OpenCV: pip install 'csw[bench]'")

THREADS = os.cpu_count() or 1
PAIRS = [("tsukuba", 16), ("cones", 64), ("bowling1-half", 128), ("synthetic-1080p", 256)]


def load_pair(name):
    """(left, right, gt or None, regions or None) for a benchmark pair."""
    if name == "synthetic-1080p":
        left, right, gt, nonocc = render(1920, 1080, dmax=255, seed=0)
        return left, right, gt, {"all": np.isfinite(gt)}
    pair = D.load(name)
    return pair.left, pair.right, pair.gt, {"all": pair.masks["all"]}


def stereobm(ndisp, filters):
    bm = cv2.StereoBM_create(numDisparities=ndisp, blockSize=9)
    if not filters:
        bm.setTextureThreshold(0)
        bm.setUniquenessRatio(0)
    return bm


def bm_disparity(raw):
    """StereoBM's int16 output (d * 16, negative = invalid) as int32 with -1 invalid."""
    disp = raw.astype(np.int32)
    return np.where(disp >= 0, (disp + 8) // 16, -1)  # nearest whole disparity


def timed(fn):
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def bench_pair(name, ndisp, repeat):
    left, right, gt, regions = load_pair(name)
    variants = {}
    for threads in sorted({1, THREADS}):
        variants[f"csw {threads}t"] = (threads, lambda t=threads: kernels.match(
            left, right, engine="fast", window=9, dmin=0, dmax=ndisp - 1, cost="sad",
            threads=t))
        for filters in (True, False):
            bm = stereobm(ndisp, filters)
            label = f"bm{'' if filters else '-nofilter'} {threads}t"
            variants[label] = (threads, lambda b=bm: b.compute(left, right))
    outputs = {}
    for label, (threads, fn) in variants.items():  # warm-up, and the maps to score
        cv2.setNumThreads(threads)
        outputs[label] = fn()
    times = {label: [] for label in variants}
    for _ in range(repeat):
        for label, (threads, fn) in variants.items():
            cv2.setNumThreads(threads)
            times[label].append(timed(fn))
    medians = {label: statistics.median(t) for label, t in times.items()}
    row = {"pair": name, "size": f"{left.shape[1]}x{left.shape[0]}", "ndisp": ndisp,
           "medians": medians,
           "mpd": left.size * ndisp / 1e6}
    if gt is not None:
        row["bad1_csw"] = score(outputs["csw 1t"].disparity, gt, regions)["all"]["bad"][1.0]
        row["bad1_bm"] = score(bm_disparity(outputs["bm 1t"]), gt, regions)["all"]["bad"][1.0]
        row["bad1_bm_nofilter"] = score(bm_disparity(outputs["bm-nofilter 1t"]), gt,
                                        regions)["all"]["bad"][1.0]
    return row


def window_vs_fast(repeat):
    """Median time of the window engine over the fast one, tsukuba SAD 9x9 d 0..15, 1 thread."""
    pair = D.load("tsukuba")
    runs = {}
    for engine in ("window", "fast"):
        fn = lambda e=engine: kernels.match(pair.left, pair.right, engine=e, window=9,  # noqa: E731
                                            dmin=0, dmax=15, cost="sad", threads=1)
        fn()
        runs[engine] = fn
    times = {e: [] for e in runs}
    for _ in range(repeat):
        for engine, fn in runs.items():
            times[engine].append(timed(fn))
    return {e: statistics.median(t) for e, t in times.items()}


PEAK_PROBE = """
import resource, subprocess, sys
subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
"""


def peak_memory_mb():
    """Peak resident memory (MB) of `csw match` on the 1080p pair, d 0..255, all threads."""
    left, right, _, _ = render(1920, 1080, dmax=255, seed=0)
    with tempfile.TemporaryDirectory() as tmp:
        write_png(f"{tmp}/l.png", left)
        write_png(f"{tmp}/r.png", right)
        cmd = ["csw", "match", f"{tmp}/l.png", f"{tmp}/r.png", "-o", f"{tmp}/d.pfm",
               "--dmax", "255"]
        out = subprocess.run([sys.executable, "-c", PEAK_PROBE, *cmd], check=True,
                             capture_output=True, text=True)
    return int(out.stdout.strip()) / 1024  # ru_maxrss is in KiB on Linux


def report(rows, engines, peak_mb, repeat):
    today = now_utc()
    cpu = cpu_name()
    t = THREADS
    out = ["# csw fast engine vs OpenCV StereoBM\n",
           f"Generated by `scripts/bench_peers.sh` (`make bench-peers`) on {today}.",
           f"Machine: {cpu}, {THREADS} logical cores; OpenCV {cv2.__version__}, "
           f"numba {__import__('numba').__version__}.",
           f"9×9 window, SAD, same disparity count for both; median of {repeat} interleaved "
           "runs after a warm-up. StereoBM 'default' keeps its pre-filter, texture threshold "
           "(10) and uniqueness ratio (15); 'no filter' sets textureThreshold = 0 and "
           "uniquenessRatio = 0 (its x-Sobel pre-filter stays: it can't be switched off). "
           "Ratios are csw time / StereoBM time at equal thread counts: below 1 means csw "
           "is faster. Throughput is million pixel·disparities per second. Absolute times "
           "move from run to run on this shared machine; ratios from the same run are "
           "what to compare.\n",
           "| pair | size | disparities | csw 1t (ms) | csw "
           f"{t}t (ms) | BM 1t (ms) | BM {t}t (ms) | BM no-filter 1t (ms) | BM no-filter {t}t (ms) "
           f"| csw/BM 1t | csw/BM {t}t | csw/BM no-filter 1t | csw {t}t speed-up | csw 1t Mpd/s "
           "| BM 1t Mpd/s | bad-1 csw (%) | bad-1 BM (%) | bad-1 BM no-filter (%) |",
           "|" + "---|" * 19]
    for r in rows:
        m = r["medians"]
        ms = {k: f"{1000 * v:.1f}" for k, v in m.items()}
        bad = {k: f"{r[k]:.2f}" if k in r else "" for k in
               ("bad1_csw", "bad1_bm", "bad1_bm_nofilter")}
        out.append(
            f"| {r['pair']} | {r['size']} | {r['ndisp']} | {ms['csw 1t']} | {ms[f'csw {t}t']} "
            f"| {ms['bm 1t']} | {ms[f'bm {t}t']} | {ms['bm-nofilter 1t']} "
            f"| {ms[f'bm-nofilter {t}t']} | {m['csw 1t'] / m['bm 1t']:.2f} "
            f"| {m[f'csw {t}t'] / m[f'bm {t}t']:.2f} | {m['csw 1t'] / m['bm-nofilter 1t']:.2f} "
            f"| {m['csw 1t'] / m[f'csw {t}t']:.2f}× | {r['mpd'] / m['csw 1t']:.0f} "
            f"| {r['mpd'] / m['bm 1t']:.0f} | {bad['bad1_csw']} | {bad['bad1_bm']} "
            f"| {bad['bad1_bm_nofilter']} |")
    out += ["",
            f"Window engine vs fast engine, tsukuba SAD 9×9 d 0..15, 1 thread: "
            f"{1000 * engines['window']:.1f} ms vs {1000 * engines['fast']:.2f} ms, "
            f"the fast engine is {engines['window'] / engines['fast']:.1f}× faster.",
            "",
            f"Peak resident memory of `csw match` (fast engine, {THREADS} threads) on the "
            f"1920×1080 pair with d 0..255: {peak_mb:.0f} MB (the whole process: Python, "
            "NumPy, Numba and LLVM included).",
            "",
            "bad-1 is over all known ground truth, invalid pixels counted as bad. StereoBM "
            "leaves its leftmost `numDisparities` columns and its filtered pixels invalid; "
            "csw fills every pixel with a candidate, so the two error rates measure "
            "different trade-offs, not only matching quality."]
    return "\n".join(out) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--output", type=Path)
    args = parser.parse_args()
    rows = []
    for name, ndisp in PAIRS:
        print(f"bench-peers: {name} ...", file=sys.stderr, flush=True)
        rows.append(bench_pair(name, ndisp, args.repeat))
    engines = window_vs_fast(max(3, args.repeat // 2))
    peak = peak_memory_mb()
    text = report(rows, engines, peak, args.repeat)
    sys.stdout.write(text)
    if args.output:
        args.output.write_text(text)


if __name__ == "__main__":
    main()

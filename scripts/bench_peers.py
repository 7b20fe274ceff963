"""csw's fast engine against OpenCV's StereoBM, in one run (make bench-peers).

Both use a 9x9 window and the same number of disparities (a multiple of 16). Each pair is
warmed up, then the variants are interleaved `--repeat` times and the medians reported;
ratios compare medians from this same run. Prints a Markdown report to stdout and, with
--output, writes it there too.
"""

import argparse
import functools
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from csw import kernels
from csw.data import datasets as D
from csw.data.synth import render
from csw.eval.scoring import score
from peers import cv2, ndisp16, stereo_bm, whole_map
from report_common import PEAK_PROBE, cpu_name, fill_template, now_utc, peak_memory_mb

THREADS = os.cpu_count() or 1
PAIRS = [("tsukuba", 16), ("cones", 64), ("bowling1-half", 128), ("synthetic-1080p", 256)]
# The whole pipeline (csw.match, each preset) against StereoBM: (pair, dmax, threads,
# {preset: target ratio}), the targets of the issue that set them.
PIPELINE_CASES = [("tsukuba", 15, 1, {"accurate": None, "raw": 1.0}),
                  ("cones", 63, 1, {"accurate": 1.5, "raw": None}),
                  ("synthetic 1920x1080 seed 7", 255, 1, {"accurate": 1.0, "raw": 0.7}),
                  ("synthetic 2880x1988 seed 7", 511, 2, {"accurate": 1.2, "raw": None})]
ROUNDS = 3  # separate rounds, each the median of --repeat interleaved pairs


def load_pair(name, dmax=None):
    """(left, right, gt or None, regions or None) for a benchmark pair; "synthetic WxH
    seed S" is the scene `csw synth --size WxH --dmax DMAX --seed S` writes."""
    if name.startswith("synthetic ") and "seed" in name:
        size, seed = name.split()[1], int(name.split()[3])
        width, height = map(int, size.split("x"))
        left, right, gt, _ = render(width, height, dmax=dmax, seed=seed)
        return left, right, gt, {"all": np.isfinite(gt)}
    if name == "synthetic-1080p":
        left, right, gt, nonocc = render(1920, 1080, dmax=255, seed=0)
        return left, right, gt, {"all": np.isfinite(gt)}
    pair = D.load(name)
    return pair.left, pair.right, pair.gt, {"all": pair.masks["all"]}


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
            bm = stereo_bm(ndisp, filters=filters)
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
        row["bad1_bm"] = score(whole_map(outputs["bm 1t"]), gt, regions)["all"]["bad"][1.0]
        row["bad1_bm_nofilter"] = score(whole_map(outputs["bm-nofilter 1t"]), gt,
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


def pipeline_vs_bm(repeat, rounds=ROUNDS):
    """The whole default pipeline and the raw one (csw.match on arrays, as a notebook
    calls it) against StereoBM's compute, per PIPELINE_CASES: warmed up, then csw and
    StereoBM alternated ``repeat`` times per round.  Returns rows of (pair, dmax,
    threads, preset, target, per-round median ratios, every pair's ratio, median ms of
    csw and of StereoBM)."""
    import csw

    rows = []
    for name, dmax, threads, presets in PIPELINE_CASES:
        print(f"bench-peers: pipeline on {name} ...", file=sys.stderr, flush=True)
        left, right, _, _ = load_pair(name, dmax)
        bm = stereo_bm(ndisp16(dmax))
        cv2.setNumThreads(threads)
        for preset, target in presets.items():
            run = functools.partial(csw.match, left, right, dmax=dmax, threads=threads,
                                    preset=preset)
            base = functools.partial(bm.compute, left, right)
            run(), base()
            medians, ratios, csw_t, bm_t = [], [], [], []
            for _ in range(rounds):
                pairs = []
                for _ in range(repeat):
                    a, b = timed(run), timed(base)
                    pairs.append(a / b)
                    csw_t.append(a)
                    bm_t.append(b)
                medians.append(statistics.median(pairs))
                ratios += pairs
            rows.append((name, dmax, threads, preset, target, medians, ratios,
                         statistics.median(csw_t), statistics.median(bm_t)))
    cv2.setNumThreads(THREADS)
    return rows


def pipeline_table(rows):
    out = ["| pair | d | threads | preset | csw (ms) | StereoBM (ms) | rounds: min / median "
           "/ max | every pair: min / max | target | met in every round |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for name, dmax, threads, preset, target, medians, ratios, c, b in rows:
        met = "" if target is None else ("yes" if max(medians) <= target else
                                         "**no**" + (" (median yes)" if
                                                     statistics.median(medians) <= target
                                                     else ""))
        out.append(f"| {name} | 0..{dmax} | {threads} | {preset} | {1000 * c:.1f} | "
                   f"{1000 * b:.1f} | {min(medians):.2f} / {statistics.median(medians):.2f} / "
                   f"{max(medians):.2f} | {min(ratios):.2f} / {max(ratios):.2f} | "
                   f"{'' if target is None else f'≤ {target}'} | {met} |")
    return "\n".join(out)


def pipeline_memory():
    """Peak RSS (MB) of whole `csw match` processes (preset accurate, 2 threads) at
    2880x1988 and 2880x3976, d 0..511: matched whole where it fits the default memory
    limit, and in stripes under --memory-limit 160MiB.  Returns {(height, mode): MB}."""
    from csw.io import write_png

    peaks = {}
    with tempfile.TemporaryDirectory() as tmp:
        for height in (1988, 3976):
            print(f"bench-peers: peak memory at 2880x{height} ...", file=sys.stderr,
                  flush=True)
            left, right, _, _ = render(2880, height, dmax=511, seed=7)
            write_png(f"{tmp}/l.png", left)
            write_png(f"{tmp}/r.png", right)
            for mode, extra in (("default", []), ("160MiB", ["--memory-limit", "160MiB"])):
                cmd = ["csw", "match", f"{tmp}/l.png", f"{tmp}/r.png", "-o",
                       f"{tmp}/d.tif" if extra else f"{tmp}/d.pfm", "--dmax", "511",
                       "--preset", "accurate", "--threads", "2", "--overwrite", *extra]
                out = subprocess.run([sys.executable, "-c", PEAK_PROBE, *cmd], check=True,
                                     capture_output=True, text=True)
                peaks[(height, mode)] = int(out.stdout.strip()) / 1024
    return peaks


def memory_table(peaks):
    return "\n".join(["| pair | as chosen by csw (MB) | `--memory-limit 160MiB`, in stripes (MB) |",
                      "|---|---|---|"] + [
        f"| 2880x{h} | {peaks[(h, 'default')]:.0f} | {peaks[(h, '160MiB')]:.0f} |"
        for h in (1988, 3976)])


def engine_table(rows):
    t = THREADS
    out = ["| pair | size | disparities | csw 1t (ms) | csw "
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
    return "\n".join(out)


def markdown(figures):
    """The report's text (scripts/templates/peers.md) from main()'s figures: the kernels'
    rows (bench_pair), the engines' times, the peak memory, the pipeline's rows
    (pipeline_vs_bm) and the big pairs' peaks (pipeline_memory)."""
    f = figures
    engines = f["engines"]
    return fill_template("peers", [("report", dict(
        date=f["date"], cpu=f["cpu"], threads=THREADS, opencv=f["opencv"], numba=f["numba"],
        repeat=f["repeat"], engine_table=engine_table(f["rows"]),
        window_ms=1000 * engines["window"], fast_ms=1000 * engines["fast"],
        fast_speedup=engines["window"] / engines["fast"], peak=f["peak"], rounds=ROUNDS,
        pipeline_table=pipeline_table(f["pipeline"]), memory_table=memory_table(f["peaks"])))])


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
    peak = peak_memory_mb(["--preset", "raw"])  # the raw engine StereoBM is timed against
    pipeline = pipeline_vs_bm(args.repeat)
    text = markdown(dict(date=now_utc(), cpu=cpu_name(), opencv=cv2.__version__,
                         numba=__import__("numba").__version__, repeat=args.repeat,
                         rows=rows, engines=engines, peak=peak, pipeline=pipeline,
                         peaks=pipeline_memory()))
    sys.stdout.write(text)
    if args.output:
        args.output.write_text(text)


if __name__ == "__main__":
    main()

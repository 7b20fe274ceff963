"""Long batches (make bench-batch): 1000 small pairs matched here and on 2 local Dask
workers; pairs per second, what each pair costs beyond its match, and whether memory
stays flat from pair 100 to pair 1000.  Writes Markdown to --output (and stdout)."""

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import psutil

import csw
from csw.config.params import DEFAULTS
from csw.data.synth import render
from csw.io import write_png
from csw.scale.distributed import close, local_client
from report_common import cpu_name, fill_template, now_utc

SIZE, DMAX, DISTINCT = (320, 240), 32, 20


def rss_mb():
    return psutil.Process().memory_info().rss / 2**20


def worker_rss(client):
    return sorted(client.run(rss_mb).values())


def run(jobs, out, client, marks, dmax=DMAX):
    """Match ``jobs`` in one batch; RSS as the batch passes each of ``marks`` pairs."""
    memory, start = {}, time.perf_counter()

    def progress(done, total):
        if done in marks:
            memory[done] = (rss_mb(), worker_rss(client) if client else [])
    report = csw.match_many(jobs, out, client=client, progress=progress, dmax=dmax,
                            overwrite=True)
    wall = time.perf_counter() - start
    assert report["counts"]["ok"] == len(jobs), "a pair failed"
    return wall, list(report["pairs"]), memory


def long_batch(work, pairs, workers=2, size=(64, 48), dmax=8):
    """``pairs`` tiny pairs on ``workers`` local Dask workers: (pairs/s, RSS MB of the
    main process at pair 2000 and at the last)."""
    left, right, _, _ = render(*size, dmax=dmax, seed=1)
    write_png(work / "tl.png", left)
    write_png(work / "tr.png", right)
    (work / "tiny.csv").write_text("".join(f"tl.png,tr.png,t{i:07d}\n" for i in range(pairs)))
    jobs = csw.jobs_from_manifest(work / "tiny.csv")
    client = local_client(workers)
    try:
        csw.match_many(jobs[:4], work / "warm-tiny", client=client, progress=False,
                       dmax=dmax)
        wall, _, memory = run(jobs, work / "tiny", client, {2000, pairs}, dmax)
    finally:
        close(client)
    return pairs / wall, memory[2000][0], memory[pairs][0]


def growth(memory, a, b):
    return 100.0 * (memory[b] - memory[a]) / memory[a]


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--output", type=Path)
    parser.add_argument("--pairs", type=int, default=1000)
    parser.add_argument("--long-pairs", type=int, default=20000)
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="csw-batch-"))
    for i in range(DISTINCT):  # distinct scenes, each listed many times under its own name
        left, right, _, _ = render(*SIZE, dmax=DMAX, seed=i)
        write_png(work / f"l{i}.png", left)
        write_png(work / f"r{i}.png", right)
    lines = [f"l{i % DISTINCT}.png,r{i % DISTINCT}.png,pair{i:05d}" for i in range(args.pairs)]
    (work / "pairs.csv").write_text("\n".join(lines) + "\n")
    jobs = csw.jobs_from_manifest(work / "pairs.csv")
    marks = [100, args.pairs]
    csw.match_many(jobs[:2], work / "warm", progress=False, dmax=DMAX)  # kernels loaded
    runs = []
    for label, workers in (("here", None), ("2 local workers", 2)):
        print(f"batch: {label}", file=sys.stderr, flush=True)
        client = local_client(workers) if workers else None
        try:
            if client:  # each worker loads the kernels once, before the clock starts
                csw.match_many(jobs[:4], work / "warm", client=client, progress=False,
                               dmax=DMAX, overwrite=True)
            wall, entries, memory = run(jobs, work / label.replace(" ", "-"), client, marks)
        finally:
            if client:
                close(client)
        runs.append(dict(label=label, wall=wall, memory=memory,
                         match_s=[e["match_seconds"] for e in entries],
                         pair_s=[e["seconds"] for e in entries]))
    print(f"batch: {args.long_pairs} tiny pairs on 2 workers", file=sys.stderr, flush=True)
    long = dict(zip(("rate", "at_2000", "at_end"), long_batch(work, args.long_pairs),
                    strict=True))
    text = markdown(runs, args.pairs, args.long_pairs, long, now_utc(), cpu_name(),
                    os.cpu_count(), csw.__version__)
    print(text, end="")
    if args.output:
        args.output.write_text(text)


def markdown(runs, pairs, long_pairs, long, date, cpu, cores, version):
    """The report's text (scripts/templates/batch.md) from its figures: per run its
    label, wall seconds, each pair's match and task seconds, and RSS at pair 100 and at
    the last (main process, workers); the long batch's rate and RSS at 2000 and at the
    end."""
    marks = [100, pairs]
    rows, growths = [], []
    for r in runs:
        memory = r["memory"]
        overhead = [p - m for p, m in zip(r["pair_s"], r["match_s"], strict=True)]
        main_growth = growth({k: v[0] for k, v in memory.items()}, *marks)
        worker_growth = [100.0 * (b - a) / a for a, b in
                         zip(memory[marks[0]][1], memory[marks[1]][1], strict=True)]
        rows.append(f"| {r['label']} | {pairs / r['wall']:.1f} | "
                    f"{1000 * statistics.median(r['match_s']):.2f} | "
                    f"{1000 * statistics.median(overhead):.2f} | "
                    f"{memory[marks[0]][0]:.0f} → {memory[marks[1]][0]:.0f} "
                    f"({main_growth:+.1f}%) | "
                    + (", ".join(f"{a:.0f} → {b:.0f} ({g:+.1f}%)" for a, b, g in
                                 zip(memory[marks[0]][1], memory[marks[1]][1],
                                     worker_growth, strict=True)) or "–") + " |")
        growths.append((main_growth, worker_growth))
    flat = all(abs(g) < 10 for m, w in growths for g in [m, *w])
    table = ["| run | pairs/s | match (ms) | overhead per pair (ms) | main RSS MB, 100 → "
             f"{pairs} | worker RSS MB, 100 → {pairs} |", "|---|---|---|---|---|---|", *rows]
    long_table = ["| pairs/s | main RSS MB at pair 2000 | at the last | growth |",
                  "|---|---|---|---|",
                  f"| {long['rate']:.1f} | {long['at_2000']:.1f} | {long['at_end']:.1f} | "
                  f"{long['at_end'] - long['at_2000']:+.1f} MB |"]
    return fill_template("batch", [("report", dict(
        date=date, cpu=cpu, cores=cores, version=version, pairs=pairs, width=SIZE[0],
        height=SIZE[1], distinct=DISTINCT, dmax=DMAX, preset=DEFAULTS["preset"],
        table="\n".join(table),
        growth=("under 10% in every process (flat)." if flat else
                "10% or more in some process: see the table."),
        long_pairs=long_pairs, long_table="\n".join(long_table)))])


if __name__ == "__main__":
    main()

"""Regenerate reports/scale.md: csw on Dask, for many pairs and for one pair bigger than
memory, measured on this machine.

  1. Many pairs: pairs per second matching a batch of 1080p pairs (d 0..255, the default
     preset) here, on 1 Dask worker (all cores) and on 2 workers (a core each).
  2. Striping: one 1080p pair whole (csw.match) against csw.match_tiled at several
     stripe heights, interleaved, median of repeats.
  3. A 20000 x 20000 pair (tiled TIFFs made by `csw synth --tiff`), d 0..64, the default
     preset and memory limit: here (`csw match`, its own process) and on 2 workers; peak
     RSS of every process that does the work.
  4. A model of N machines, from what a task moves against what it computes (measured)
     and the scheduler's task rate (measured), with the network's bandwidth assumed.

Usage: python scripts/scale_report.py --output reports/scale.md [--work DIR]
"""

import argparse
import logging
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import csw  # noqa: E402
from csw.config.params import resolve  # noqa: E402
from csw.data.synth import render, write_tiff_scene  # noqa: E402
from csw.io import write_disparity, write_png  # noqa: E402
from csw.matching.pipeline import filter_overlap  # noqa: E402
from csw.scale.distributed import close, local_client  # noqa: E402
from csw.scale.tiled import DEFAULT_MEMORY_LIMIT, match_tiled  # noqa: E402
from report_common import cpu_name, fill_template, now_utc  # noqa: E402

HD = (1920, 1080)
HD_DMAX = 255
BIG_DMAX = 64


def timed(call):
    start = time.perf_counter()
    value = call()
    return time.perf_counter() - start, value


def make_pairs(folder, count):
    """count 1080p synthetic pairs as PNG in folder/l and folder/r (kept between runs)."""
    for side in ("l", "r"):
        (folder / side).mkdir(parents=True, exist_ok=True)
    for i in range(count):
        if not (folder / "r" / f"p{i:02d}.png").exists():
            left, right, _, _ = render(*HD, dmax=HD_DMAX, seed=i)
            write_png(folder / "l" / f"p{i:02d}.png", left)
            write_png(folder / "r" / f"p{i:02d}.png", right)
    return csw.jobs_from_folders(folder / "l", folder / "r")[:count]


def many_pairs(work, count, repeat):
    """Section 1: {mode: (median seconds for the batch, start-up seconds)}."""
    jobs = make_pairs(work / "pairs", count)
    out = work / "maps"
    out.mkdir(exist_ok=True)
    clients = {"here (no Dask)": (None, 0.0)}
    for workers in (1, 2):
        seconds, client = timed(lambda w=workers: local_client(w))
        clients[f"{workers} worker{'s' if workers > 1 else ''}"] = (client, seconds)
    try:
        for client, _ in clients.values():  # compile or load the cache in every worker
            csw.match_many(jobs[:2], out, dmax=HD_DMAX, overwrite=True, progress=False,
                           client=client)
        times = {mode: [] for mode in clients}
        for _ in range(repeat):
            for mode, (client, _) in clients.items():  # interleaved
                seconds, report = timed(lambda c=client: csw.match_many(
                    jobs, out, dmax=HD_DMAX, overwrite=True, progress=False, client=c))
                assert report["counts"]["ok"] == len(jobs), report["counts"]
                times[mode].append(seconds)
        noop = scheduler_rate(clients["2 workers"][0])
    finally:
        for client, _ in clients.values():
            if client is not None:
                close(client)
    bytes_per_pair = statistics.mean(
        sum(p.stat().st_size for p in (job.left, job.right)) + (out / f"{job.name}.pfm")
        .stat().st_size for job in jobs)
    return ({mode: (statistics.median(t), clients[mode][1]) for mode, t in times.items()},
            bytes_per_pair, noop)


def scheduler_rate(client, tasks=2000):
    """Tasks per second the scheduler completes for tasks that do nothing."""
    client.gather(client.map(int, range(100), pure=False))  # warm
    seconds, _ = timed(lambda: client.gather(client.map(int, range(tasks), pure=False)))
    return tasks / seconds


def striping(work, repeat):
    """Section 2: [(label, stripes, overlap share, median seconds, seconds list)]."""
    left, right, _, _ = render(*HD, dmax=HD_DMAX, seed=0)
    variants = [("whole image (csw.match)", None)]
    variants += [(f"stripes, default limit ({DEFAULT_MEMORY_LIMIT // 2**20} MiB)", "limit")]
    variants += [(f"stripes of {rows} rows", rows) for rows in (540, 270, 135)]
    rows = []
    out = work / "stripe-test.pfm"
    for preset in ("accurate", "raw"):
        times = {label: [] for label, _ in variants}
        layouts = {}
        for i in range(repeat + 1):  # the first round warms up and is not counted
            for label, stripe_rows in variants:
                if stripe_rows is None:
                    seconds, _ = timed(lambda p=preset: write_disparity(
                        out, csw.match(left, right, dmax=HD_DMAX, preset=p).disparity))
                else:
                    seconds, result = timed(lambda p=preset, r=stripe_rows: match_tiled(
                        left, right, out, dmax=HD_DMAX, preset=p,
                        stripe_rows=None if r == "limit" else r))
                    layouts[label] = result.plan
                if i:
                    times[label].append(seconds)
        base = statistics.median(times[variants[0][0]])
        for label, _ in variants:
            plan = layouts.get(label)
            median = statistics.median(times[label])
            rows.append((preset, label, len(plan.stripes) if plan else 1,
                         plan.overhead if plan else 0.0, plan.filter_overlap if plan else 0,
                         median, median / base))
    return rows


PEAK_PROBE = """
import resource, subprocess, sys, time
start = time.perf_counter()
done = subprocess.run(sys.argv[1:], capture_output=True, text=True)
seconds = time.perf_counter() - start
print(done.returncode, seconds, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
print(done.stderr.strip().splitlines()[-1] if done.stderr.strip() else "")
"""


def worker_peak():
    """This process's peak RSS (VmHWM) in bytes, on a Dask worker."""
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024
    return 0


def big_pair(work, side):
    """Section 3: the generation time and [(mode, stripes, seconds, peaks in MB)]."""
    folder = work / f"big{side}"
    gen = 0.0
    if not (folder / "right.tif").exists():
        gen, _ = timed(lambda: write_tiff_scene(folder, side, side, BIG_DMAX, seed=0))
    left, right = folder / "left.tif", folder / "right.tif"
    rows = []
    # Here: `csw match`, in a process of its own, as a user runs it.
    # Over csw's pixel limit: a memory limit (the default one) is the user's word for it.
    cmd = ["csw", "match", str(left), str(right), "-o", str(work / "big-here.tif"),
           "--dmax", str(BIG_DMAX), "--memory-limit", str(DEFAULT_MEMORY_LIMIT)]
    done = subprocess.run([sys.executable, "-c", PEAK_PROBE, *cmd], capture_output=True,
                          text=True, check=True)
    code, seconds, peak_kib = done.stdout.splitlines()[0].split()
    summary = done.stdout.splitlines()[1]
    assert code == "0", done.stdout
    stripes = summary.split(" stripe(s)")[0].rsplit(", ", 1)[-1]
    rows.append(("here: `csw match` (all cores)", stripes, float(seconds),
                 [int(peak_kib) / 1024], summary))
    # On 2 workers: the library with a LocalCluster; the workers' own peaks.
    client = local_client(2)
    try:
        warm = work / "warm"
        write_tiff_scene(warm, 256, 64, BIG_DMAX, seed=0, processes=1)
        match_tiled(warm / "left.tif", warm / "right.tif", warm / "d.tif", dmax=BIG_DMAX,
                    client=client)
        seconds, result = timed(lambda: match_tiled(left, right, work / "big-dask.tif",
                                                    dmax=BIG_DMAX, client=client,
                                                    memory_limit=DEFAULT_MEMORY_LIMIT))
        peaks = [v / 2**20 for v in client.run(worker_peak).values()]
    finally:
        close(client)
    rows.append(("2 Dask workers (a core each)", str(len(result.plan.stripes)), seconds,
                 peaks, result))
    same = subprocess.run(["cmp", work / "big-here.tif", work / "big-dask.tif"]).returncode
    return gen, rows, same == 0, result


def model_rows(rate_per_machine, bytes_per_item, scheduler_tasks_per_s, tasks_per_item):
    """Items per second on N machines: each adds rate_per_machine until the network (at
    an assumed bandwidth) or the scheduler is the limit."""
    rows = []
    for n in (1, 2, 4, 8, 16, 32, 64, 128):
        row = [n, n * rate_per_machine]
        for gbit in (1, 10):
            network = gbit * 1e9 / 8 / bytes_per_item
            scheduler = scheduler_tasks_per_s / tasks_per_item
            row.append(min(n * rate_per_machine, network, scheduler))
        rows.append(row)
    return rows


def table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def markdown(figures):
    """The report's text (scripts/templates/scale.md) from main()'s figures: the batch
    times per mode, the striping rows, the big pair's rows (the first row's last item is
    its summary line) and its tasks, and the model's inputs."""
    f = figures
    cores, pairs, big, batch, stripes = (f["cores"], f["pairs"], f["big"], f["batch"],
                                         f["stripes"])
    bytes_per_pair, noop_rate, tasks = f["bytes_per_pair"], f["noop_rate"], f["tasks"]
    here_s = batch["here (no Dask)"][0]
    one_s = batch["1 worker"][0]
    two_s = batch["2 workers"][0]
    per_machine = pairs / two_s
    seconds_per_pair = two_s / pairs
    big_bytes = (tasks["bytes_read"] + tasks["bytes_written"]) / tasks["count"]
    big_task_s = tasks["seconds"] / tasks["count"]
    gain = here_s / two_s
    big_rows = f["big_rows"]
    big_rate = (big ** 2 / 1e6) / big_rows[1][2]  # Mpx/s on this machine
    per_mpx_bytes = big_bytes * tasks["count"] / (big ** 2 / 1e6)
    network_pairs = 1e9 / 8 / bytes_per_pair
    pair_io_rate = bytes_per_pair / seconds_per_pair / 1e6  # MB per second of compute
    stripe_io_rate = big_bytes / big_task_s / 1e6
    model_header = ["1 Gbit/s shared", "10 Gbit/s shared"]
    fields = dict(
        date=f["date"], cpu=f["cpu"], cores=cores, version=f["version"], pairs=pairs,
        hd_dmax=HD_DMAX, repeat=f["repeat"],
        batch_table=table(["run", "batch (s)", "pairs/s", "vs here", "cluster start-up (s)"],
                          [(mode, f"{s:.2f}", f"{pairs / s:.2f}", f"{here_s / s:.2f}x",
                            f"{start:.1f}" if start else "") for mode, (s, start) in
                           batch.items()]),
        two_rate=pairs / two_s, here_rate=pairs / here_s, gain=gain, one_rate=pairs / one_s,
        why=("a pair per core beats splitting each pair's rows between threads, which "
             "leaves a core idle in the serial parts (reading and writing files, the "
             "speckle filter's flood fill)" if gain > 1.05 else
             "splitting each pair's rows between threads already keeps the cores busy"),
        stripe_table=table(["preset", "run", "stripes", "extra rows matched",
                            "filter overlap", "seconds", "vs whole"],
                           [(p, label, n, f"{100 * share:.1f}%", f"{fo} rows" if fo else "",
                             f"{s:.3f}", f"{r:.2f}x") for p, label, n, share, fo, s, r
                            in stripes]),
        default_accurate=next(r for p, label, *_, r in stripes
                              if p == "accurate" and label.startswith("stripes, default")),
        worst=max(r for *_, r in stripes), speckle_rows=f["speckle_rows"], big=big,
        big_dmax=BIG_DMAX, big_mpx=big * big / 1e6,
        generated=f" in {f['gen']:.0f} s" if f["gen"] else "",
        map_gib=big * big * 4 / 2**30, limit_mib=DEFAULT_MEMORY_LIMIT // 2**20,
        big_table=table(["run", "stripes", "seconds", "Mpx/s", "peak RSS per process (MB)"],
                        [(mode, n, f"{s:.1f}", f"{big ** 2 / s / 1e6:.1f}",
                          ", ".join(f"{p:.0f}" for p in peaks)) for mode, n, s, peaks, _
                         in big_rows]),
        summary=big_rows[0][4], same="identical" if f["same"] else "DIFFERENT",
        worst_peak=max(p for *_, peaks, _ in big_rows for p in peaks),
        pair_mb=bytes_per_pair / 1e6, seconds_per_pair=seconds_per_pair,
        per_machine=per_machine, task_mb=big_bytes / 1e6, big_task_s=big_task_s,
        task_count=tasks["count"], noop_rate=noop_rate,
        pairs_model=table(["machines", f"compute only ({cores} cores each)", *model_header],
                          [(n, f"{a:.1f}", f"{b:.1f}", f"{c:.1f}") for n, a, b, c in
                           model_rows(per_machine, bytes_per_pair, noop_rate, 1)]),
        big_model=table(["machines", "compute only", *model_header],
                        [(n, f"{a:.1f}", f"{b:.1f}", f"{c:.1f}") for n, a, b, c in
                         model_rows(big_rate, per_mpx_bytes, noop_rate,
                                    tasks["count"] / (big ** 2 / 1e6))]),
        network_pairs=network_pairs, network_machines=network_pairs / per_machine,
        network_machines_10=10 * network_pairs / per_machine,
        scheduler_machines=noop_rate / per_machine, stripe_io_rate=stripe_io_rate,
        pair_io_rate=pair_io_rate,
        network_verdict=("saturates a link sooner" if stripe_io_rate > pair_io_rate else
                         "is no harder on the network"))
    return fill_template("scale", [("report", fields)])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", required=True)
    parser.add_argument("--work", help="folder for the generated pairs (kept; default: a "
                                       "temporary folder)")
    parser.add_argument("--pairs", type=int, default=8)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--big", type=int, default=20000, help="side of the big pair")
    args = parser.parse_args()
    logging.getLogger("distributed").setLevel(logging.WARNING)  # the cluster's INFO lines
    work = Path(args.work) if args.work else Path(tempfile.mkdtemp(prefix="csw-scale-"))
    work.mkdir(parents=True, exist_ok=True)
    cores = os.cpu_count()

    batch, bytes_per_pair, noop_rate = many_pairs(work, args.pairs, args.repeat)
    stripes = striping(work, args.repeat)
    gen, big, same, big_result = big_pair(work, args.big)

    text = markdown(dict(
        date=now_utc(), cpu=cpu_name(), cores=cores, version=csw.__version__,
        pairs=args.pairs, repeat=args.repeat, big=args.big, batch=batch,
        bytes_per_pair=bytes_per_pair, noop_rate=noop_rate, stripes=stripes,
        speckle_rows=filter_overlap(resolve().stages), gen=gen, big_rows=big, same=same,
        tasks=big_result.tasks))
    Path(args.output).write_text(text)
    print(f"wrote {args.output}", file=sys.stderr)
    if not args.work:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()

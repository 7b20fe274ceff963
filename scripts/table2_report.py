"""Write reports/table2.md: the paper's TABLE II measured here, beside the paper's figures.

Run by scripts/reproduce_table2.sh (make bench). Every figure comes from the library
call that `csw bench` makes (csw.bench.run_bench) in this run; the statements under each
table are computed from them.
"""

import os
import platform
import sys
from pathlib import Path

import numpy as np

from csw import __version__, kernels
from csw.config.tau import paper_tau
from csw.data import datasets as D
from csw.eval.bench import run_bench
from csw.io import read_image
from report_common import command, cpu_name, fmt, now_utc

REPEAT = int(os.environ.get("CSW_BENCH_REPEAT", "5"))


def bench(datasets, **options):
    """csw.bench.run_bench on registered datasets, by default with the window engine and
    the literal rule (the paper's method); returns (rows, the equivalent csw command)."""
    options = {"engines": ["window"], "rules": ["literal"], "repeat": REPEAT, **options}
    rows, _ = run_bench((D.load(n) for n in datasets), progress=print_progress, **options)
    return rows, command("bench", datasets, options)


def print_progress(step):
    print(f"bench: {step}", file=sys.stderr, flush=True)


def table(rows, paper=True):
    head = ["Image", "Size", "d", "Algorithm", "τ", "Error rate (%)", "nonocc bad-1 (%)",
            "Time (s)", "Time reduced (%)", "Work saved (%)"]
    if paper:
        head += ["Paper error (%)", "Paper time reduced (%)"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        algo = r["algorithm"]
        nonocc = r["regions"].get("nonocc", {}).get("bad1")
        cells = [r["dataset"], r["size"], f"{r['dmin']}..{r['dmax']}", algo,
                 (fmt(r["tau"], 0) if r["tau"] is not None else "none") if r["csw"] else "",
                 fmt(r["error_rate"]), fmt(nonocc),
                 fmt(r["time_s"], 4), fmt(r["time_reduced"]), fmt(r["work_saved"])]
        if paper:
            cells += [fmt(r["paper_error_rate"]), fmt(r["paper_time_reduced"])]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def verdicts(rows):
    """One line per CSW row: does it keep the error rate (within 0.3 points), and what
    does it save? Each CSW row is compared with the plain row before it."""
    out = []
    plain = None
    for row in rows:
        if not row["csw"]:
            plain = row
            continue
        delta = row["error_rate"] - plain["error_rate"]
        kept = "keeps" if delta <= 0.3 else "raises"
        line = (f"- {row['dataset']} {row['algorithm']}: {kept} the error rate "
                f"({fmt(plain['error_rate'])}% → {fmt(row['error_rate'])}%, "
                f"{delta:+.2f} points), skips {fmt(row['work_saved'], 1)}% of the candidate "
                f"costs and saves {fmt(row['time_reduced'], 1)}% of the time.")
        if row["paper_error_rate"] is not None:
            paper_delta = row["paper_error_rate"] - plain["paper_error_rate"]
            line += (f" Paper: {paper_delta:+.2f} points, {fmt(row['paper_time_reduced'], 1)}% "
                     "time saved.")
        out.append(line)
    return "\n".join(out)


def beyond_150(name):
    """Share (%) of known ground truth beyond the paper's d <= 150 at full size. The 2006
    PNGs store disparity in full-size pixels at every size (value / size factor is the
    disparity of the reduced image), so the stored value is the full-size disparity."""
    ds = D.DATASETS[name]
    raw = read_image(D.resolve(ds.gt)).astype(float)
    known = raw > 0
    return 100.0 * np.mean(raw[known] > 150)


def tsukuba_plain_stats():
    """Per cost on Tsukuba (9x9, d 0..16): the tau of the paper's own rule (the first of
    10 histogram bins of plain m) and the smallest m."""
    pair = D.load("tsukuba")
    stats = {}
    for cost in ("sad", "ssd", "shd"):
        m = kernels.match(pair.left, pair.right, engine="fast", window=9, dmin=0, dmax=16,
                          cost=cost).min_cost
        stats[cost] = {"rule_tau": paper_tau(m), "min_m": int(m[m >= 0].min())}
    return stats


def machine():
    import numba

    return (f"{cpu_name()}, {os.cpu_count()} logical cores, {platform.system()} "
            f"{platform.release()}; Python {platform.python_version()}, numba "
            f"{numba.__version__}, numpy {np.__version__}, csw {__version__}")


def main(path):
    today = now_utc()
    tsukuba, cmd_tsukuba = bench(["tsukuba"], preset="paper", costs=["sad", "ssd", "shd"])
    cmd_tsukuba += " --paper-figures"
    scenes2006 = ["wood1", "baby1", "bowling1", "baby1-half", "bowling1-half"]
    preset2006, cmd_preset2006 = bench(scenes2006, preset="paper", costs=["sad"])
    # The registry range covers the ground truth, unlike the scaled paper range.
    full2006 = []
    cmds_full2006 = []
    for name in scenes2006:
        rows, cmd = bench([name], preset="paper", costs=["sad"], dmax=D.DATASETS[name].dmax)
        full2006 += rows
        cmds_full2006.append(cmd)
    others = ["venus", "sawtooth", "cones", "teddy", "synthetic"]
    other_rows, cmd_others = bench(others, costs=["sad", "ssd", "shd"], tau="auto")
    shares = {n: beyond_150(n) for n in ["wood1", "baby1", "bowling1"]}
    stats = tsukuba_plain_stats()
    unique_rows, cmd_unique = bench(["tsukuba"], dmax=16, costs=["sad"],
                                    rules=["literal", "unique"], tau="auto")
    for name in ("venus", "cones", "teddy"):
        rows, _ = bench([name], costs=["sad"], rules=["literal", "unique"], tau="auto")
        unique_rows += rows
    by = {(r["cost"], r["csw"]): r for r in tsukuba}

    nine = tsukuba + [r for r in preset2006 if r["dataset"] in ("wood1", "baby1", "bowling1")]
    text = f"""# TABLE II reproduced: CSW against plain window matching

Generated by `scripts/reproduce_table2.sh` (`make bench`) on {today}.
Machine: {machine()}.
Engine: the window engine (full 9×9 sum per candidate, the paper's method), one thread,
median of {REPEAT} interleaved plain/CSW runs after a warm-up run. Error rate is bad-1 over
all known ground truth (invalid pixels count as bad; Tsukuba's 18-pixel border is unknown
and left out). Work saved is the share of candidate cost evaluations CSW skipped, counted
by the kernel: it does not depend on the machine. Times are this machine's and move from
run to run; compare only the ratios.

## The paper's nine rows

Tsukuba with the paper's settings (9×9, d 0..16, τ 410/360/32), and Wood, Baby and Bowling
with SAD and the paper's τ. The paper ran the 2006 scenes at full size with d 0..150;
here they exist at third size only, so d is scaled to 0..50.

`{cmd_tsukuba}`
`{cmd_preset2006}`

{table(nine)}

{verdicts(nine)}

### What reproduces on Tsukuba, and what does not

- **Plain matching agrees.** bad-1 is {fmt(by['sad', False]['error_rate'])}% (SAD),
  {fmt(by['ssd', False]['error_rate'])}% (SSD) and {fmt(by['shd', False]['error_rate'])}% (SHD)
  here against the paper's 11.45%, 11.08% and 15.34%. The paper does not say how it
  made gray images, handled the image border or broke ties (here: ITU-R 601-2 luma as
  Pillow's `convert("L")`, the edge pixel repeated, the smallest d), and differences
  there move bad-1 by about this much.
- **The time saving reproduces.** SAD + CSW skips {fmt(by['sad', True]['work_saved'], 1)}% of
  the candidate costs and saves {fmt(by['sad', True]['time_reduced'], 1)}% of the time (paper:
  45.37%); SSD + CSW saves {fmt(by['ssd', True]['time_reduced'], 1)}% (paper: 28.98%). Time
  saved tracks work saved, as it must for the window engine.
- **The quality claim does not.** SAD + CSW raises bad-1 by
  {by['sad', True]['error_rate'] - by['sad', False]['error_rate']:+.2f} points and SSD + CSW by
  {by['ssd', True]['error_rate'] - by['ssd', False]['error_rate']:+.2f}, where the paper reports
  −0.68 and +0.69. The likely mechanism: the first confident match on a row claims its
  right pixel for good, so a left pixel scanned later whose true match was claimed by a
  wrong (or occluded) earlier pixel can't get it back, and takes another, wrong right
  pixel instead, which can displace the next one in turn. The paper's remark that a poor
  claim "only leads to one unmatched pixel" does not allow for that chain.
- **SHD at τ = 32 does almost nothing here.** The smallest SHD cost on Tsukuba is
  {stats['shd']['min_m']} bits over the 9×9 window, so τ = 32 marks few pixels and CSW skips
  {fmt(by['shd', True]['work_saved'], 2)}% of the work; the paper's 8.61% time saving with SHD
  can't be reached with this τ under the contract's SHD (popcount of the XOR of 8-bit
  gray values).
- **τ.** The paper's own rule (width of the first of 10 bins of the plain min-cost
  histogram) gives τ = {stats['sad']['rule_tau']:.0f} (SAD), {stats['ssd']['rule_tau']:.0f} (SSD) and
  {stats['shd']['rule_tau']:.1f} (SHD) here, against the paper's 410, 360 and 32. SAD and SHD are close;
  SSD's 360 is far below any SSD cost scale here (the SSD costs are squares), so the
  paper's SSD τ cannot have come from this rule on 8-bit data.

## The 2006 scenes: the scaled range does not cover the ground truth

At full size, {shares['wood1']:.1f}% of Wood1's known ground truth, {shares['bowling1']:.1f}% of
Bowling1's and {shares['baby1']:.1f}% of Baby1's lies beyond the paper's d ≤ 150 (stored
values above 150 in `disp1.png`, which holds full-size disparities at every size). Those
pixels can't be matched within the paper's range, so an error rate near 9% for Wood and
Bowling is not possible with bad-1 over all known ground truth: the paper must have
scored differently (another threshold, a mask, or a different range) than it states.

With the paper's range scaled to these sizes (same command as above, half size too):

{table(preset2006)}

With the registry's range, which covers the ground truth (`{cmds_full2006[0]}` and
likewise for each scene):

{table(full2006)}

{verdicts(full2006)}

## A CSW that keeps its accuracy: the unique rule, timed

The literal rule's loss of accuracy is examined in
[`csw-tradeoff.md`](csw-tradeoff.md), which also derives the `unique` rule
(`--csw-rule unique`: only distinct matches claim, and a claim does not bind the next
pixel). Here it is timed the same way as TABLE II, with the window engine, SAD 9×9,
literal rows at the auto τ, unique rows with no τ and margin 12%:

`{cmd_unique}` (and `-d venus`, `-d cones`, `-d teddy` with their registry ranges)

{table(unique_rows, paper=False)}

{verdicts(unique_rows)}

## Every other dataset

SAD, SSD and SHD with the paper's τ rule (`--tau auto`: the width of the first of 10 bins
of the plain min-cost histogram), 9×9, the registry's disparity range.

`{cmd_others}`

{table(other_rows, paper=False)}

{verdicts(other_rows)}
"""
    Path(path).write_text(text)
    print(f"wrote {path}", file=sys.stderr)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "reports/table2.md")

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
from report_common import command, cpu_name, fill_template, fmt, now_utc

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


def markdown(figures):
    """The report's text (scripts/templates/table2.md) from main()'s figures: the bench
    rows of each run and its command, the 2006 scenes' shares beyond d 150 and Tsukuba's
    plain statistics."""
    f = figures
    tsukuba, preset2006, full2006 = f["tsukuba"], f["preset2006"], f["full2006"]
    by = {(r["cost"], r["csw"]): r for r in tsukuba}
    nine = tsukuba + [r for r in preset2006 if r["dataset"] in ("wood1", "baby1", "bowling1")]
    stats, shares = f["stats"], f["shares"]
    return fill_template("table2", [("report", dict(
        date=f["date"], machine=f["machine"], repeat=REPEAT, cmd_tsukuba=f["cmd_tsukuba"],
        cmd_preset2006=f["cmd_preset2006"], nine_table=table(nine),
        nine_verdicts=verdicts(nine),
        sad_plain=fmt(by["sad", False]["error_rate"]),
        ssd_plain=fmt(by["ssd", False]["error_rate"]),
        shd_plain=fmt(by["shd", False]["error_rate"]),
        sad_work_saved=fmt(by["sad", True]["work_saved"], 1),
        sad_time_saved=fmt(by["sad", True]["time_reduced"], 1),
        ssd_time_saved=fmt(by["ssd", True]["time_reduced"], 1),
        sad_csw_delta=by["sad", True]["error_rate"] - by["sad", False]["error_rate"],
        ssd_csw_delta=by["ssd", True]["error_rate"] - by["ssd", False]["error_rate"],
        shd_min_m=stats["shd"]["min_m"], shd_work_saved=fmt(by["shd", True]["work_saved"], 2),
        sad_rule_tau=stats["sad"]["rule_tau"], ssd_rule_tau=stats["ssd"]["rule_tau"],
        shd_rule_tau=stats["shd"]["rule_tau"], wood1_beyond=shares["wood1"],
        bowling1_beyond=shares["bowling1"], baby1_beyond=shares["baby1"],
        preset2006_table=table(preset2006), cmd_full2006=f["cmds_full2006"][0],
        full2006_table=table(full2006), full2006_verdicts=verdicts(full2006),
        cmd_unique=f["cmd_unique"], unique_table=table(f["unique"], paper=False),
        unique_verdicts=verdicts(f["unique"]), cmd_others=f["cmd_others"],
        others_table=table(f["others"], paper=False),
        others_verdicts=verdicts(f["others"])))])


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
    text = markdown(dict(
        date=today, machine=machine(), tsukuba=tsukuba, cmd_tsukuba=cmd_tsukuba,
        preset2006=preset2006, cmd_preset2006=cmd_preset2006, full2006=full2006,
        cmds_full2006=cmds_full2006, others=other_rows, cmd_others=cmd_others, shares=shares,
        stats=stats, unique=unique_rows, cmd_unique=cmd_unique))
    Path(path).write_text(text)
    print(f"wrote {path}", file=sys.stderr)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "reports/table2.md")

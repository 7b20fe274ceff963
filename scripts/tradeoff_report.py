"""Write reports/csw-tradeoff.md: CSW's work saved against bad-1 for every dataset, the
literal rule against the unique rule, with plots in reports/img/.

Run by scripts/tradeoff.sh (make tradeoff). Every figure comes from the library call
that `csw sweep` makes (csw.sweep.sweep_rows) or from the kernels in this run.
"""

import sys
from pathlib import Path

import numpy as np

from csw import kernels
from csw.config.tau import paper_tau, parse_sweep
from csw.data import datasets as D
from csw.eval import plots
from csw.eval.scoring import bad1_all
from csw.eval.sweep import DEFAULT_TAUS, sweep_rows
from report_common import command, fill_template, fmt, now_utc

TARGETS = {"tsukuba": (40.0, 0.3), "cones": (30.0, 0.5), "teddy": (30.0, 0.5),
           "venus": (30.0, 0.5)}
DMAX = {"tsukuba": 16}  # the paper's range; the registry's elsewhere


def sweep(name, out_dir, cost="sad", taus=DEFAULT_TAUS):
    """What `csw sweep -d NAME --plot ...` does, through the library: (rows, the command,
    the plot's path relative to the report)."""
    pair = D.load(name)
    dmax = DMAX.get(name, pair.dmax)
    plot = out_dir / "img" / f"tradeoff-{name}{'' if cost == 'sad' else '-' + cost}.png"
    print(f"sweep: {name} {cost}", file=sys.stderr, flush=True)
    rows = sweep_rows(pair, cost=cost, rules=["literal", "unique"], taus=parse_sweep(taus),
                      window=9, dmax=dmax)
    plots.tradeoff(plot, rows, f"{name}: {cost.upper()} 9x9, d 0..{dmax}")
    options = dict(cost=cost, dmax=dmax, tau_range=None if taus == DEFAULT_TAUS else taus)
    return rows, command("sweep", [name], options), plot.relative_to(out_dir)


def table(rows):
    lines = ["| Algorithm | τ | τ value | Work saved (%) | bad-1 (%) | Δ bad-1 | nonocc bad-1 (%) |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        # No threshold (none) has no value: the cell stays empty, as for plain rows.
        tau = "" if r["tau"] is None or r["tau_label"] == "none" else f"{r['tau']:.0f}"
        lines.append(f"| {r['algorithm']} | {r['tau_label']} | {tau} | {fmt(r['work_saved'], 1)} "
                     f"| {fmt(r['error_rate'])} | {fmt(r['delta'], 2)} | {fmt(r['nonocc'])} |")
    return "\n".join(lines)


def pick(rows, rule, label):
    return next(r for r in rows if r["rule"] == rule and r["tau_label"] == label)


def mechanism(name, tau_factor=1.0):
    """Where the literal rule's new errors come from, from the kernels' outputs alone:
    for each pixel that plain matching got right and literal CSW got wrong, the right
    pixel of its plain answer was claimed by an earlier pixel x' (the last x' whose CSW
    match pointed at it with m <= tau). How far back is x', and was x' itself right?"""
    pair = D.load(name)
    dmax = DMAX.get(name, pair.dmax)
    settings = dict(engine="fast", window=9, dmin=0, dmax=dmax, cost="sad")
    plain = kernels.match(pair.left, pair.right, **settings)
    tau = paper_tau(plain.min_cost) * tau_factor
    csw = kernels.match(pair.left, pair.right, csw=True, tau=tau, **settings)
    gt, known = pair.gt, pair.masks["all"]

    def good(disp):
        return (disp >= 0) & (np.abs(disp - np.nan_to_num(gt)) <= 1)

    new_bad = known & good(plain.disparity) & ~good(csw.disparity)
    distances, claimant_right, shortfall = [], [], []
    for y, x in zip(*np.nonzero(new_bad), strict=True):
        r = x - plain.disparity[y, x]
        row_d, row_m = csw.disparity[y, :x], csw.min_cost[y, :x]
        xs = np.nonzero((np.arange(x) - row_d == r) & (row_d >= 0) & (row_m <= tau))[0]
        if xs.size == 0:
            continue
        claimant = xs[-1]
        distances.append(x - claimant)
        claimant_d, claimant_gt = csw.disparity[y, claimant], gt[y, claimant]
        claimant_right.append(bool(np.isfinite(claimant_gt)
                                   and abs(claimant_d - claimant_gt) <= 1))
        shortfall.append(csw.disparity[y, claimant] - gt[y, x])
    distances = np.array(distances)
    return {"name": name, "tau": tau, "new_bad": int(new_bad.sum()),
            "explained": len(distances), "near": 100.0 * np.mean(distances <= 2),
            "adjacent": 100.0 * np.mean(distances == 1),
            "claimant_wrong": 100.0 * (1 - np.mean(claimant_right)),
            "shortfall": float(np.median(shortfall))}


ABLATION = [
    ("literal, auto τ (the paper's rule)", dict(rule="literal"), "auto"),
    ("literal, auto τ, claims skip the next pixel", dict(rule="literal", slack=1), "auto"),
    ("distinct claims only (margin 12%), literal binding",
     dict(rule="unique", csw_margin=12, slack=0),
     "none"),
    ("unique: distinct claims + claims skip the next pixel",
     dict(rule="unique", csw_margin=12), "none"),
]

def ablation(name):
    """Work saved and Δ bad-1 with each half of the unique rule switched on alone."""
    pair = D.load(name)
    dmax = DMAX.get(name, pair.dmax)
    settings = dict(engine="fast", window=9, dmin=0, dmax=dmax, cost="sad")
    plain = kernels.match(pair.left, pair.right, **settings)
    base = bad1_all(plain.disparity, pair)
    out = []
    for label, options, tau in ABLATION:
        value = paper_tau(plain.min_cost) if tau == "auto" else float("inf")
        result = kernels.match(pair.left, pair.right, csw=True, tau=value, **options,
                               **settings)
        out.append((label, 100 * result.work_saved, bad1_all(result.disparity, pair) - base))
    return out


def markdown(figures):
    """The report's text (scripts/templates/tradeoff.md) from main()'s figures: the
    mechanism() and ablation() figures, and each sweep's (rows, command, plot)."""
    names, results, parts = figures["names"], figures["sweeps"], figures["ablation"]
    summary = ["| dataset | d | plain bad-1 (%) | literal, auto τ: saved / Δ | unique, τ none: "
               "saved / Δ | target | met |", "|---|---|---|---|---|---|---|"]
    for name in names:
        rows = results[name][0]
        lit, uni = pick(rows, "literal", "1x"), pick(rows, "unique", "none")
        target = TARGETS.get(name)
        met = ""
        if target:
            met = "yes" if uni["work_saved"] >= target[0] and uni["delta"] <= target[1] else "no"
        summary.append(
            f"| {name} | 0..{rows[0]['dmax']} | {fmt(rows[0]['error_rate'])} "
            f"| {fmt(lit['work_saved'], 1)}% / {lit['delta']:+.2f} "
            f"| {fmt(uni['work_saved'], 1)}% / {uni['delta']:+.2f} "
            f"| {'≥ {:.0f}% saved, Δ ≤ +{:.1f}'.format(*target) if target else ''} | {met} |")
    mechanism = ["| dataset | τ (auto) | new errors | claimant 1 column back | claimant ≤ 2 "
                 "back | claimant itself wrong | claimant's d − pixel's true d (median) |",
                 "|---|---|---|---|---|---|---|"]
    mechanism += [f"| {m['name']} | {m['tau']:.0f} | {m['new_bad']} | {m['adjacent']:.0f}% "
                  f"| {m['near']:.0f}% | {m['claimant_wrong']:.0f}% | {m['shortfall']:+.2f} |"
                  for m in figures["mechanism"]]
    ablation_rows = ["| rule | " + " | ".join(parts) + " |", "|---|" + "---|" * len(parts)]
    for i, (label, _, _) in enumerate(ABLATION):
        cells = [f"{parts[n][i][1]:.1f}% / {parts[n][i][2]:+.2f}" for n in parts]
        ablation_rows.append(f"| {label} | " + " | ".join(cells) + " |")
    blocks = [("head", dict(date=figures["date"], summary="\n".join(summary),
                            mechanism="\n".join(mechanism),
                            ablation="\n".join(ablation_rows)))]
    for name in names:
        rows, cmd, plot = results[name]
        blocks.append(("dataset", dict(name=name, command=cmd, plot=plot, table=table(rows),
                                       auto_tau=rows[1]["auto_tau"])))
    blocks.append(("other_costs", {}))
    for cost, (rows, cmd, plot) in figures["other_costs"].items():
        blocks.append(("cost", dict(title=cost.upper(), command=cmd, cost=cost, plot=plot,
                                    table=table(rows))))
    return fill_template("tradeoff", blocks)


def main(out):
    out = Path(out)
    (out.parent / "img").mkdir(parents=True, exist_ok=True)
    today = now_utc()
    names = D.names()
    mech = [mechanism(n) for n in ("tsukuba", "cones", "teddy", "venus")]
    parts = {n: ablation(n) for n in ("tsukuba", "cones", "teddy", "venus")}
    results = {name: sweep(name, out.parent) for name in names}
    other_costs = {c: sweep("tsukuba", out.parent, c, "1x,3x,none")
                   for c in ("ssd", "shd")}
    out.write_text(markdown(dict(date=today, names=names, mechanism=mech, ablation=parts,
                                 sweeps=results, other_costs=other_costs)))
    print(f"wrote {out}", file=sys.stderr)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "reports/csw-tradeoff.md")

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
from report_common import command, fmt, now_utc

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

WHY = """
Nearly every claim that cost a later pixel its match was itself wrong, typically with a
disparity about 3 below the blocked pixel's true one, and often from a pixel only one
or two columns back. Two causes fit these numbers. On surfaces whose disparity grows
along the row (slanted or curved), two neighbouring left pixels can share one right
pixel at integer precision, so the first one's claim takes the second one's match away,
and the second, pushed off its match, claims a wrong pixel in turn. And a low cost is
not a confident match: in weak or repetitive texture a wrong disparity can cost little,
and the literal rule lets it claim. The unique rule answers both: a claim binds only
from the second pixel after the claimant, and it must be distinct (no candidate 2 or
more disparities away comes within 12% of the best).

Neither half is enough alone. Letting claims skip the next pixel removes most of the
literal rule's loss, but leaves +0.3 to +2 points; distinctiveness alone, with no cost
threshold and the literal binding, claims far too much. Together they keep plain
matching's accuracy:

Work saved / Δ bad-1 in points; SAD 9×9, the same ranges; computed by the kernels,
whose `slack` argument switches the binding half:

{ablation}

Also tried while designing the rule, in a throwaway simulation on the same scenes:
re-evaluating the blocked candidates whenever the best free one was not distinct
("verify on doubt") saved less work and gained no accuracy, so it was dropped. A τ per
region was not needed once distinctiveness decides the claims: τ then changes little
(compare 3x and none for the unique rule in the tables below).

## Every dataset
"""


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


def main(out):
    out = Path(out)
    (out.parent / "img").mkdir(parents=True, exist_ok=True)
    today = now_utc()
    names = D.names()
    mech = [mechanism(n) for n in ("tsukuba", "cones", "teddy", "venus")]
    parts = {n: ablation(n) for n in ("tsukuba", "cones", "teddy", "venus")}
    results = {name: sweep(name, out.parent) for name in names}
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
    other_costs = {c: sweep("tsukuba", out.parent, c, "1x,3x,none")
                   for c in ("ssd", "shd")}

    text = [f"""# CSW's trade-off: work saved against accuracy

Generated by `scripts/tradeoff.sh` (`make tradeoff`) on {today}. SAD, 9×9 window, d from 0
to the registry's range (Tsukuba: the paper's 0..16). Work saved is the share of
candidate costs CSW skipped; it is counted by the kernels and is the same for both
engines, which give identical maps (the sweeps use the fast one). bad-1 is over all known
ground truth, invalid pixels counted as bad; Δ is CSW's bad-1 minus plain matching's.
τ labels: Nx is N times the auto τ (the paper's rule: the width of the first of 10 bins
of the plain min-cost histogram); none is no cost threshold.

## Summary

The literal rule (the paper's) buys its savings with accuracy everywhere but on the
synthetic scene. The **unique** rule (`--csw-rule unique`, margin 12%, no τ) keeps
plain matching's bad-1 within the targets on Tsukuba, Cones, Teddy and Venus while still
skipping 30–45% of the candidate costs:

""", "\n".join(summary), """

**Recommendation:** `csw match --csw --csw-rule unique` (τ none, margin 12; 25 for
SSD). Where a cost threshold is wanted anyway, `--tau` at about 3× the auto τ changes
little. The literal rule stays the default, for reproducing the paper; with it, the
auto τ (`--tau auto`, shown in every table below as 1x) is the paper's rule, and it
raises bad-1 by the Δ shown.

The margins are thin on Cones (about 30% saved against a 30% target) and Teddy (Δ about
+0.2 against +0.5): the rule meets the targets here, but a scene with more repetitive
texture may not.

## Why the literal rule loses accuracy

For every pixel that plain matching got right and literal CSW (auto τ) got wrong, the
right pixel of its plain answer had been claimed by an earlier pixel. From the kernels'
outputs:

| dataset | τ (auto) | new errors | claimant 1 column back | claimant ≤ 2 back | claimant itself wrong | claimant's d − pixel's true d (median) |
|---|---|---|---|---|---|---|
"""]
    for m in mech:
        text.append(f"| {m['name']} | {m['tau']:.0f} | {m['new_bad']} | {m['adjacent']:.0f}% "
                    f"| {m['near']:.0f}% | {m['claimant_wrong']:.0f}% | {m['shortfall']:+.2f} |\n")
    ablation_rows = ["| rule | " + " | ".join(parts) + " |", "|---|" + "---|" * len(parts)]
    for i, (label, _, _) in enumerate(ABLATION):
        cells = [f"{parts[n][i][1]:.1f}% / {parts[n][i][2]:+.2f}" for n in parts]
        ablation_rows.append(f"| {label} | " + " | ".join(cells) + " |")
    text.append(WHY.format(ablation="\n".join(ablation_rows)))
    for name in names:
        rows, cmd, plot = results[name]
        text.append(f"\n### {name}\n\n`{cmd}`\n\n![{name}]({plot})\n\n{table(rows)}\n")
        text.append(f"\n`--tau auto` chooses τ = {rows[1]['auto_tau']:.0f} here.\n")
    text.append("\n## Other costs on Tsukuba\n\nSSD's costs are squares of SAD-like "
                "differences, so the unique rule's default margin is 25% there (1.12² ≈ "
                "1.25); SHD uses 12%.\n")
    for cost, (rows, cmd, plot) in other_costs.items():
        text.append(f"\n### {cost.upper()}\n\n`{cmd}`\n\n![{cost}]({plot})\n\n{table(rows)}\n")
    out.write_text("".join(text))
    print(f"wrote {out}", file=sys.stderr)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "reports/csw-tradeoff.md")

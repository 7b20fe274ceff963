"""Benchmarks: TABLE II of the paper, measured here, for any pair.

``bench_rows`` is what ``csw bench`` prints, one row per (pair, cost, engine, variant);
``total_rows`` sums them over the pairs of a benchmark folder.  Progress goes to an
optional callback, so the library prints nothing.
"""

import statistics
import time

from .. import kernels
from ..config import paper, params
from ..config.params import (
    BENCH_REPEAT,
    BENCH_THREADS,
    EXPERIMENT_PRESET,
    OFF_STAGES,
    PRESETS,
    csw_margin_for,
)
from ..config.tau import resolve_tau
from ..data.datasets import NOT_VERIFIED
from ..matching.pipeline import run as run_pipeline
from .scoring import THRESHOLDS, metric_for, score, summary

RULE_LABELS = {None: "", "literal": " + CSW", "unique": " + CSW-unique"}


def time_variants(left, right, settings, variants, repeat, progress, stages=OFF_STAGES):
    """Median seconds of each variant (a dict of kernel options) through the pipeline's
    stages, interleaved so that drifts in machine load hit all alike."""
    times = [[] for _ in variants]
    for i in range(repeat):
        progress(f"repeat {i + 1}/{repeat}")
        for options, samples in zip(variants, times, strict=True):
            start = time.perf_counter()
            run_pipeline(left, right, dict(options, **settings), stages)
            samples.append(time.perf_counter() - start)
    return [statistics.median(samples) for samples in times]


def bench_rows(pair, *, cost, window, dmin, dmax, engine, rules=("literal",), tau=None,
               unique_tau=None, csw_margin=None, repeat=BENCH_REPEAT, threads=BENCH_THREADS,
               progress=None, stages=OFF_STAGES):
    """TABLE II rows for one pair, cost and engine: plain, then CSW with each rule.

    pair: a :class:`csw.datasets.Pair`.  tau: the literal rule's tau (number, "auto",
    "none", "paper" or None for the rule's default); unique_tau likewise for the unique
    rule.  stages: the pipeline's stages around every variant (csw.matching.pipeline; off: the
    paper's raw maps).  Returns a list of dicts, the plain row first.
    """
    settings = dict(engine=engine, window=window, dmin=dmin, dmax=dmax, cost=cost,
                    threads=threads)
    ds = pair.dataset
    paper_taus = (paper.preset(ds) or (None, {}))[1]
    progress = progress or (lambda step: None)

    def report(step):
        progress(f"{pair.name} {cost.upper()} {engine} engine {step}")

    # Warm-up runs: their outputs are what gets scored (timing does not change them).
    plain_map, _, plain = run_pipeline(pair.left, pair.right,
                                       dict(settings, csw=False, tau=-1), stages)
    variants = [dict(csw=False, tau=-1)]
    taus = [(None, None)]
    for rule in rules:
        given = tau if rule == "literal" else unique_tau
        taus.append(resolve_tau(given, rule, plain_min_cost=lambda: plain.min_cost,
                                paper_value=paper_taus.get(cost)))
        variants.append(dict(csw=True, tau=taus[-1][0], rule=rule,
                             csw_margin=csw_margin_for(cost, csw_margin)))
    runs = [(plain_map, plain)] + [run_pipeline(pair.left, pair.right, dict(v, **settings),
                                                stages)[::2] for v in variants[1:]]
    seconds = time_variants(pair.left, pair.right, settings, variants, repeat, report, stages)

    height, width = pair.left.shape
    rows = []
    staged = stages.changed()
    metric = metric_for(pair.layout)  # the pair's benchmark's own: KITTI's D1, else bad-2
    for (disp, result), variant, (tau_value, tau_source), secs in zip(runs, variants, taus,
                                                                      seconds, strict=True):
        is_csw = variant["csw"]
        rule = variant.get("rule")
        metrics = score(disp, pair.gt, pair.masks)
        figures = summary(disp, pair.gt, pair.masks["all"], metric)
        paper_row = paper.TABLE2.get((ds.paper if ds else None, cost, is_csw)) \
            if rule in (None, "literal") else None
        rows.append({
            "dataset": pair.name,
            "size": f"{width}x{height}",
            "cost": cost,
            "csw": is_csw,
            "algorithm": cost.upper() + (" + SGM" if stages.aggregate == "sgm" else "")
            + RULE_LABELS[rule],
            "engine": engine,
            "rule": rule,
            "tau": tau_value,
            "tau_source": tau_source,
            "csw_margin": csw_margin_for(cost, csw_margin) if rule == "unique" else None,
            "window": window,
            "dmin": dmin,
            "dmax": dmax,
            "stages": staged,
            "error_rate": metrics["all"]["bad"][1.0],
            "bad": {f"{t:g}": metrics["all"]["bad"][t] for t in THRESHOLDS},
            "metric": metric,
            "density": figures["density"],
            "bad_valid": figures["bad_valid"],
            "filled_bad": figures["filled"],
            "invalid": metrics["all"]["invalid"],
            "regions": {name: {"bad1": m["bad"][1.0], "pixels": m["pixels"],
                               "bad1_count": m["bad_count"][1.0]}
                        for name, m in metrics.items()},
            "mae": metrics["all"]["mae"],
            "rms": metrics["all"]["rms"],
            "time_s": secs,
            "time_reduced": 100.0 * (1.0 - secs / seconds[0]) if is_csw else None,
            "work_saved": 100.0 * result.work_saved if is_csw else None,
            "evaluated": result.evaluated,
            "candidates": result.candidates,
            "threads": threads,
            "repeat": repeat,
            "paper_error_rate": paper_row[0] if paper_row else None,
            "paper_time_reduced": paper_row[1] if paper_row else None,
            "verified": pair.verified,
        })
    return rows


# What preset="paper" sets, unless given: the paper's method exactly (window engine,
# literal rule, its costs, ranges and taus).  Otherwise both engines and both rules.
PAPER_PRESET = {"engines": (PRESETS["paper"]["engine"],), "rules": ("literal",),
                "tau": "paper"}
PLAIN_PRESET = {"engines": ("window", "fast"), "rules": ("literal", "unique"), "tau": None}


def paper_costs(pair):
    """The costs TABLE II has for a pair (all three for Tsukuba, SAD for the 2006 scenes)."""
    preset = paper.preset(pair.dataset)
    return list(preset[1]) if preset else ["sad"]


def run_bench(pairs, *, preset=None, costs=None, engines=None, rules=None, tau=None,
              unique_tau=None, csw_margin=None, window=None, dmin=0, dmax=None,
              repeat=BENCH_REPEAT, threads=BENCH_THREADS, progress=None, stages=None):
    """What ``csw bench`` prints: bench rows for every pair, then, when pairs from folders
    (not the registry) number more than one, their totals.

    pairs: an iterable of :class:`csw.datasets.Pair`, consumed one at a time.
    preset: None or "paper" (the paper's method and settings), or one of
    csw.defaults.PRESETS for its stages and cost.  costs, engines, rules: lists, or None
    for the preset's.  stages: pipeline stage options over the preset's (see
    csw.matching.pipeline).  window: None for the preset's.  dmax: None for each pair's own
    range (or the paper's with the paper preset).  Presets that aggregate (sgm) get plain
    rows only, on the fast engine: semi-global matching needs every cost, so CSW has
    nothing to skip.  Returns (rows, caption).
    """
    from ..matching.pipeline import entries

    chosen = PAPER_PRESET if preset == "paper" else PLAIN_PRESET
    named = params.resolve(preset=preset or EXPERIMENT_PRESET, **(stages or {}))
    stage_values = named.stages
    if costs is None and preset not in (None, "paper", "raw"):
        costs = [named.cost]
    aggregated = stage_values.aggregate != "none"
    if aggregated and "window" in (engines or ()):
        raise ValueError("semi-global matching computes its own costs; drop the window "
                         "engine")
    engines = engines or (("fast",) if aggregated else chosen["engines"])
    # CSW's skips are local matching's: an aggregating preset gets its plain rows only.
    rules = () if aggregated else rules or chosen["rules"]
    tau = chosen["tau"] if tau is None else tau
    if preset == "paper" and window not in (None, PRESETS["paper"]["window"]):
        raise ValueError("the paper preset uses the paper's 9x9 window; drop the window")
    window = named.window if window is None else window
    compiled = {}
    rows, registry, folder_rows, unverified = [], [], [], False
    for pair in pairs:
        unverified |= not pair.verified
        preset_range = paper.preset(pair.dataset) if preset == "paper" else None
        top = dmax if dmax is not None else (preset_range[0] if preset_range else pair.dmax)
        for cost in costs or (paper_costs(pair) if preset == "paper" else ["sad"]):
            for engine in engines:
                key = (engine, cost, pair.left.dtype.str)
                if key not in compiled:
                    args = dict(engine=engine, cost=cost, window=window, dmin=dmin)
                    compiled[key] = kernels.native.ensure(
                        entries(dict(args, csw=False), stage_values, pair.left.dtype) +
                        (entries(dict(args, csw=True), stage_values, pair.left.dtype)
                         if rules else []))
                new = bench_rows(pair, cost=cost, window=window, dmin=dmin, dmax=top,
                                 engine=engine, rules=rules, tau=tau, unique_tau=unique_tau,
                                 csw_margin=csw_margin, repeat=repeat, threads=threads,
                                 progress=progress, stages=stage_values)
                rows += new
                if pair.dataset is None:
                    folder_rows += new
        if pair.dataset is not None:
            registry.append(pair.dataset)  # folders may hold many scenes: keep no pixels
    if len({r["dataset"] for r in folder_rows}) > 1:
        rows += total_rows(folder_rows)
    text = caption(registry, preset == "paper", window, threads, repeat,
                   sum(compiled.values()))
    if aggregated:
        text += ("\nSemi-global matching needs every cost, so CSW has none to skip: plain "
                 "rows only.")
    staged = stage_values.changed()
    if staged:
        text += ("\nPipeline stages around every row: "
                 + ", ".join(f"{k} {v}" for k, v in staged.items()) + ".")
    if unverified:
        text += "\nWARNING: " + NOT_VERIFIED + "."
    return rows, text


def total_rows(rows):
    """One "total" row per (algorithm, engine) over every pair in ``rows``: bad-1 pooled
    over all scored pixels, times and candidate counts summed (so time reduced and work
    saved are those of the whole set)."""
    groups = {}
    for r in rows:
        groups.setdefault((r["algorithm"], r["engine"]), []).append(r)
    plain_time = {}
    totals = []
    for (algorithm, engine), group in groups.items():
        pixels = sum(r["regions"]["all"]["pixels"] for r in group)
        bad = sum(r["regions"]["all"]["bad1_count"] for r in group)
        secs = sum(r["time_s"] for r in group)
        evaluated = sum(r["evaluated"] for r in group)
        candidates = sum(r["candidates"] for r in group)
        first = group[0]
        if not first["csw"]:
            plain_time[(first["cost"], engine)] = secs
        base = plain_time.get((first["cost"], engine))
        totals.append({
            "dataset": f"total ({len(group)} scenes)", "size": "", "cost": first["cost"],
            "csw": first["csw"], "algorithm": algorithm, "engine": engine,
            "rule": first["rule"], "tau": None, "tau_source": "per scene",
            "error_rate": 100.0 * bad / pixels if pixels else float("nan"),
            "time_s": secs, "evaluated": evaluated, "candidates": candidates,
            "time_reduced": 100.0 * (1 - secs / base) if first["csw"] and base else None,
            "work_saved": 100.0 * (1 - evaluated / candidates) if first["csw"] else None,
            "scenes": len(group),
        })
    return totals


def caption(datasets, preset_paper, window, threads, repeat, compile_s):
    """The paragraph printed above a bench table: what was measured, and how.
    datasets: the registry entries benched."""
    lines = [f"CSW vs plain matching, {window}x{window} window, {threads} thread(s), "
             f"median of {repeat} interleaved runs after warm-up (compile/load "
             f"{compile_s:.2f} s, not included). Error rate: bad-1 (%) over all known "
             "ground truth; invalid pixels count as bad. Density, bad over valid and bad "
             "filled (after the evaluation kits' background fill) by each benchmark's "
             "measure (Metric): KITTI's D1 (error over 3 px and over 5% of the truth), "
             "bad-2 elsewhere. Work saved: share of candidate costs CSW skipped. The "
             "window engine sums the full window per candidate (the paper's method), so "
             "skipped candidates save time; the fast engine's running sums compute every "
             "cost anyway, so CSW saves it no time."]
    if preset_paper and any(ds.size_factor != 1 for ds in datasets):
        lines.append("The paper ran Wood, Baby and Bowling at full size with d 0..150; here "
                     "they exist only at reduced size, so the range is scaled by the size "
                     "factor (third size: d 0..50, half size: d 0..75) and tau is the "
                     "paper's unchanged.")
    return "\n".join(lines)

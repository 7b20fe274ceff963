"""``csw bench``: TABLE II of the paper, measured here, for any dataset."""

import statistics
import time

import click

from . import options as opt
from . import paper
from .datasets import DataError, load
from .engine import load_kernels, paper_tau, run_match, warm_up
from .report import emit
from .scoring import THRESHOLDS, score

COLUMNS = [
    ("dataset", "Image", 0),
    ("algorithm", "Algorithm", 0),
    ("engine", "Engine", 0),
    ("tau", "τ", 0),
    ("error_rate", "Error rate (%)", 2),
    ("time_s", "Time (s)", 4),
    ("time_reduced", "Time reduced (%)", 2),
    ("work_saved", "Work saved (%)", 2),
]
PAPER_COLUMNS = [
    ("paper_error_rate", "Paper error (%)", 2),
    ("paper_time_reduced", "Paper time reduced (%)", 2),
]


def resolve_tau(tau, pair, cost, plain_result, preset):
    """(tau, note) for a CSW row: a number, 'auto' (the paper's histogram rule on the
    plain min-cost map) or 'paper' (the paper's value; auto where it has none)."""
    if tau == "paper":
        if preset and cost in preset[1]:
            return float(preset[1][cost]), "paper"
        return paper_tau(plain_result.min_cost), "auto (no paper value)"
    if tau == "auto":
        return paper_tau(plain_result.min_cost), "auto"
    return float(tau), "given"


def time_variants(left, right, settings, variants, repeat, progress):
    """Median seconds of each variant (a dict of run_match options), interleaved so that
    drifts in machine load hit all alike."""
    times = [[] for _ in variants]
    for i in range(repeat):
        progress(f"repeat {i + 1}/{repeat}")
        for options, samples in zip(variants, times, strict=True):
            start = time.perf_counter()
            run_match(left, right, **options, **settings)
            samples.append(time.perf_counter() - start)
    return [statistics.median(samples) for samples in times]


def bench_rows(pair, cost, tau, window, dmin, dmax, repeat, threads, engine="window",
               rules=("literal",), unique_tau=None, uniqueness=None):
    """TABLE II rows for one pair, cost and engine: plain, then CSW with each rule."""
    settings = dict(engine=engine, window=window, dmin=dmin, dmax=dmax, cost=cost,
                    threads=threads)
    ds = pair.dataset
    preset = paper.preset(ds)

    def progress(step):
        click.echo(f"bench: {pair.name} {cost.upper()} {engine} engine {step}", err=True)

    # Warm-up runs: their outputs are what gets scored (timing does not change them).
    plain = run_match(pair.left, pair.right, csw=False, tau=-1, **settings)
    variants = [dict(csw=False, tau=-1)]
    taus = [(None, None)]
    for rule in rules:
        if rule == "literal":
            taus.append(resolve_tau(tau, pair, cost, plain, preset))
        else:
            chosen = opt.tau_value(unique_tau, rule)
            taus.append((chosen, "none") if chosen == float("inf")
                        else resolve_tau(chosen, pair, cost, plain, preset))
        variants.append(dict(csw=True, tau=taus[-1][0], rule=rule, uniqueness=uniqueness))
    results = [plain] + [run_match(pair.left, pair.right, **v, **settings)
                         for v in variants[1:]]
    seconds = time_variants(pair.left, pair.right, settings, variants, repeat, progress)

    height, width = pair.left.shape
    rows = []
    for result, variant, (tau_value, tau_source), secs in zip(results, variants, taus,
                                                              seconds, strict=True):
        is_csw = variant["csw"]
        rule = variant.get("rule")
        metrics = score(result.disparity, pair.gt, pair.masks)
        paper_row = paper.TABLE2.get((ds.paper if ds else None, cost, is_csw)) \
            if rule in (None, "literal") else None
        label = {None: "", "literal": " + CSW", "unique": " + CSW-unique"}[rule]
        rows.append({
            "dataset": pair.name,
            "size": f"{width}x{height}",
            "cost": cost,
            "csw": is_csw,
            "algorithm": cost.upper() + label,
            "engine": engine,
            "rule": rule,
            "tau": tau_value,
            "tau_source": tau_source,
            "uniqueness": (load_kernels().contract.resolve_uniqueness(cost, uniqueness)
                           if rule == "unique" else None),
            "window": window,
            "dmin": dmin,
            "dmax": dmax,
            "error_rate": metrics["all"]["bad"][1.0],
            "bad": {f"{t:g}": metrics["all"]["bad"][t] for t in THRESHOLDS},
            "invalid": metrics["all"]["invalid"],
            "regions": {name: {"bad1": m["bad"][1.0], "pixels": m["pixels"]}
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
        })
    return rows


def caption_for(pairs, preset_paper, window, threads, repeat, compile_s):
    lines = [f"CSW vs plain matching, {window}x{window} window, {threads} thread(s), "
             f"median of {repeat} interleaved runs after warm-up (compile/load "
             f"{compile_s:.2f} s, not included). Error rate: bad-1 (%) over all known "
             "ground truth; invalid pixels count as bad. Work saved: share of candidate "
             "costs CSW skipped. The window engine sums the full window per candidate (the "
             "paper's method), so skipped candidates save time; the fast engine's running "
             "sums compute every cost anyway, so CSW saves it no time."]
    if preset_paper and any(p.dataset and p.dataset.size_factor != 1 for p in pairs):
        lines.append("The paper ran Wood, Baby and Bowling at full size with d 0..150; here "
                     "they exist only at reduced size, so the range is scaled by the size "
                     "factor (third size: d 0..50, half size: d 0..75) and tau is the "
                     "paper's unchanged.")
    return "\n".join(lines)


@click.command(short_help="Score and time plain vs CSW matching (the paper's TABLE II).")
@opt.dataset_option()
@opt.cost_option(multiple=True)
@click.option("--engine", "engines", default="window,fast", show_default=True,
              callback=opt.comma_list("window", "fast"),
              help="Comma-separated engines to bench: window (the paper's method, where "
                   "CSW saves real work) and/or fast (running sums).")
@click.option("--tau", default=None, type=opt.TauType(),
              help="N, 'auto' (histogram rule on the plain min-cost map) or 'paper' "
                   "[default: paper with --preset paper, else auto].")
@click.option("--csw-rule", "rules", default="literal,unique", show_default=True,
              callback=opt.comma_list("literal", "unique"),
              help="CSW rules to bench beside plain matching (comma-separated).")
@click.option("--unique-tau", type=opt.TauType(), default=None,
              help="tau for the unique rule's rows [default: none, no cost threshold].")
@opt.uniqueness_option
@click.option("--preset", type=click.Choice(["paper"]), default=None,
              help="The paper's settings: 9x9 window, its disparity ranges and taus.")
@opt.window_option
@click.option("--dmin", type=click.IntRange(min=0), default=0, show_default=True)
@click.option("--dmax", type=click.IntRange(min=0), default=None,
              help="Largest disparity [default: the dataset's range, or the paper's].")
@click.option("--repeat", type=click.IntRange(min=1), default=5, show_default=True,
              help="Timed runs of each variant; the median is reported.")
@click.option("--threads", "-j", type=click.IntRange(min=1), default=1, show_default=True,
              help="Threads (1 = the paper's single core).")
@click.option("--paper-figures/--no-paper-figures", default=False, show_default=True,
              help="Add the paper's error rate and time reduction beside each row.")
@opt.format_option
@opt.data_dir_option
@opt.download_option
def bench(datasets, costs, engines, tau, rules, unique_tau, uniqueness, preset, window, dmin,
          dmax, repeat, threads, paper_figures, fmt, data_dir, download):
    """Match each dataset plain and with CSW, score both, and time both.

    \b
    Examples:
      csw bench --dataset tsukuba --preset paper
      csw bench -d synthetic -d cones --cost sad,ssd --tau auto --format json
    """
    if tau is None:
        tau = "paper" if preset == "paper" else "auto"
    if preset == "paper" and window != paper.WINDOW:
        raise click.UsageError("--preset paper uses the paper's 9x9 window; drop --window")
    compile_s = sum(warm_up(engine=e, cost=c) for c in costs for e in engines)
    rows, pairs = [], []
    for name in datasets:
        try:
            pair = load(name, data_dir, allow_download=download)
        except DataError as exc:
            raise click.ClickException(str(exc)) from None
        pairs.append(pair)
        preset_range = paper.preset(pair.dataset) if preset == "paper" else None
        top = dmax if dmax is not None else (preset_range[0] if preset_range else pair.dmax)
        for cost in costs:
            for engine in engines:
                rows.extend(bench_rows(pair, cost, tau, window, dmin, top, repeat, threads,
                                       engine, rules, unique_tau, uniqueness))
    columns = COLUMNS + (PAPER_COLUMNS if paper_figures else [])
    emit(rows, columns, fmt, caption_for(pairs, preset == "paper", window, threads, repeat,
                                         compile_s))

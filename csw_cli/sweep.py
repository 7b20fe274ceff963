"""``csw sweep``: CSW's trade-off between work saved and accuracy, over tau and rules."""

import click

from . import options as opt
from .datasets import DataError, load
from .engine import paper_tau, run_match
from .report import emit, pyplot, save_figure
from .scoring import bad1_all, score

DEFAULT_TAUS = "0.25x,0.5x,1x,1.5x,2x,3x,5x,none"
COLUMNS = [("dataset", "Image", 0), ("algorithm", "Algorithm", 0), ("tau_label", "τ", 0),
           ("tau", "τ value", 0), ("work_saved", "Work saved (%)", 1),
           ("error_rate", "bad-1 (%)", 2), ("delta", "Δ bad-1 (points)", 2),
           ("nonocc", "nonocc bad-1 (%)", 2)]


def parse_taus(ctx, param, value):
    """Comma-separated items: a number, 'Nx' (N times the auto tau), 'a:b:step' (numbers
    from a to b inclusive), or 'none'.  Returns a list of (label, spec) pairs."""
    items = []
    for item in (v.strip() for v in value.split(",") if v.strip()):
        try:
            if item == "none":
                items.append(("none", ("none", None)))
            elif item.endswith("x"):
                items.append((item, ("times", float(item[:-1]))))
            elif ":" in item:
                start, stop, step = (float(v) for v in item.split(":"))
                if step <= 0:
                    raise ValueError
                value = start
                while value <= stop + 1e-9:
                    items.append((f"{value:g}", ("abs", value)))
                    value += step
            else:
                items.append((item, ("abs", float(item))))
        except ValueError:
            raise click.BadParameter(f"{item!r}: use numbers, Nx, a:b:step or none") from None
    if not items:
        raise click.BadParameter("give at least one tau")
    return items


def parse_ints(ctx, param, value):
    if value is None:
        return [None]
    try:
        values = [int(v) for v in value.split(",") if v.strip()]
    except ValueError:
        raise click.BadParameter(f"{value!r}: comma-separated whole percentages") from None
    if not values or any(not 0 <= v <= 1000 for v in values):
        raise click.BadParameter("uniqueness values run from 0 to 1000")
    return values


def sweep_rows(pair, cost, rules, taus, uniquenesses, window, dmax, threads, progress):
    """Plain matching, then every (rule, uniqueness, tau) with CSW, as dicts."""
    settings = dict(engine="fast", window=window, dmin=0, dmax=dmax, cost=cost,
                    threads=threads)
    plain = run_match(pair.left, pair.right, csw=False, tau=-1, **settings)
    plain_bad1 = bad1_all(plain.disparity, pair)
    auto = paper_tau(plain.min_cost)

    def row(result, rule, uniqueness, label, tau):
        metrics = score(result.disparity, pair.gt, pair.masks, (1.0,))
        name = {None: "", "literal": " + CSW", "unique": " + CSW-unique"}[rule]
        if rule == "unique":
            name += f" U={uniqueness}" if uniqueness is not None else ""
        return {"dataset": pair.name, "cost": cost, "rule": rule, "uniqueness": uniqueness,
                "algorithm": cost.upper() + name, "tau_label": label, "tau": tau,
                "auto_tau": auto, "window": window, "dmax": dmax,
                "work_saved": 100.0 * result.work_saved if rule else None,
                "error_rate": metrics["all"]["bad"][1.0],
                "delta": metrics["all"]["bad"][1.0] - plain_bad1 if rule else None,
                "nonocc": metrics.get("nonocc", {}).get("bad", {}).get(1.0)}

    rows = [row(plain, None, None, "", None)]
    for rule in rules:
        for uniqueness in (uniquenesses if rule == "unique" else [None]):
            for label, (kind, number) in taus:
                tau = {"none": float("inf"), "abs": number}.get(kind)
                tau = auto * number if kind == "times" else tau
                progress(f"{pair.name} {cost.upper()} {rule} tau {label}")
                result = run_match(pair.left, pair.right, csw=True, tau=tau, rule=rule,
                                   uniqueness=uniqueness, **settings)
                rows.append(row(result, rule, uniqueness, label, tau))
    return rows


def plot(path, rows, title):
    """Work saved (x) against bad-1 (y): one curve per rule and uniqueness."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    plain = rows[0]["error_rate"]
    ax.axhline(plain, color="#555555", linestyle="--", label=f"plain ({plain:.2f}%)")
    curves = {}
    for r in rows[1:]:
        curves.setdefault(r["algorithm"], []).append(r)
    for label, points in curves.items():
        xs = [p["work_saved"] for p in points]
        ys = [p["error_rate"] for p in points]
        ax.plot(xs, ys, marker="o", label=label)
        for p in points:
            ax.annotate(p["tau_label"], (p["work_saved"], p["error_rate"]), fontsize=7,
                        textcoords="offset points", xytext=(3, 3))
    # Keep the interesting range readable: literal CSW with a huge tau goes off the chart.
    top = max(r["error_rate"] for r in rows)
    limit = min(top, 2.5 * plain + 5)
    ax.set_ylim(min(r["error_rate"] for r in rows) - 1, limit + 1)
    if top > limit + 1:
        ax.text(0.01, 0.98, "points above the chart are left out of view", fontsize=7,
                transform=ax.transAxes, va="top")
    ax.set_xlabel("work saved (% of candidate costs skipped)")
    ax.set_ylabel("bad-1 over all known ground truth (%)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)


@click.command(short_help="Sweep tau and CSW rules: work saved against bad-1.")
@opt.dataset_option()
@opt.cost_option()
@click.option("--rule", "rules", default="literal,unique", show_default=True,
              help="Comma-separated CSW rules to sweep.",
              callback=opt.comma_list("literal", "unique"))
@click.option("--tau-range", "taus", default=DEFAULT_TAUS, show_default=True,
              callback=parse_taus,
              help="Taus: numbers, Nx (N times the auto tau), a:b:step, none.")
@click.option("--uniqueness", "uniquenesses", default=None, callback=parse_ints,
              help="Comma-separated uniqueness percentages for the unique rule "
                   "[default: 12; 25 for SSD].")
@opt.window_option
@click.option("--dmax", type=click.IntRange(min=0), default=None,
              help="Largest disparity [default: the dataset's range].")
@opt.threads_option
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False),
              help="Also write the curves as a PNG (one dataset only; needs matplotlib).")
@opt.format_option
@opt.data_dir_option
@opt.download_option
def sweep(datasets, cost, rules, taus, uniquenesses, window, dmax, threads, plot_path, fmt,
          data_dir, download):
    """Run CSW over a range of tau for each rule and report work saved against bad-1.

    Results are the same with either engine; the sweep uses the fast one.

    \b
    Examples:
      csw sweep --dataset tsukuba --dmax 16
      csw sweep -d cones --rule unique --uniqueness 8,12,20 --tau-range 1x,3x,none
      csw sweep -d teddy --tau-range 200:1200:200 --plot teddy.png
    """
    from .match import check_output

    plot_path = check_output(plot_path, (".png",), "--plot")
    if plot_path and len(datasets) != 1:
        raise click.UsageError("--plot draws one dataset; give a single --dataset")
    rows = []
    for name in datasets:
        try:
            pair = load(name, data_dir, allow_download=download)
        except DataError as exc:
            raise click.ClickException(str(exc)) from None
        top = pair.dmax if dmax is None else dmax
        rows += sweep_rows(pair, cost, rules, taus, uniquenesses, window, top, threads,
                           lambda step: click.echo(f"sweep: {step}", err=True))
    caption = (f"CSW trade-off, {cost.upper()} {window}x{window}: work saved (candidate "
               "costs skipped) against bad-1 over all known ground truth; Nx = N times the "
               "auto tau (the paper's histogram rule), none = no cost threshold.")
    emit(rows, COLUMNS, fmt, caption)
    if plot_path:
        plot(plot_path, rows, f"{datasets[0]}: {cost.upper()} {window}x{window}, d 0..{top}")


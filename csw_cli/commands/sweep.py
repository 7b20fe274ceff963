"""``csw sweep``: CSW's trade-off between work saved and accuracy, over tau and rules."""

import click

from csw.config import params
from csw.config.tau import parse_sweep
from csw.eval.sweep import DEFAULT_TAUS

from .. import options as opt
from ..report import emit

COLUMNS = [("dataset", "Image", 0), ("algorithm", "Algorithm", 0), ("tau_label", "τ", 0),
           ("tau", "τ value", 0), ("work_saved", "Work saved (%)", 1),
           ("error_rate", "bad-1 (%)", 2), ("delta", "Δ bad-1 (points)", 2),
           ("nonocc", "nonocc bad-1 (%)", 2)]


def parse_taus(ctx, param, value):
    try:
        return parse_sweep(value)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None


def parse_ints(ctx, param, value):
    if value is None:
        return [None]
    try:
        values = [int(v) for v in value.split(",") if v.strip()]
    except ValueError:
        raise click.BadParameter(f"{value!r}: comma-separated whole percentages") from None
    if not values or len(values) > 100 or any(not 0 <= v <= 1000 for v in values):
        raise click.BadParameter("give 1 to 100 margins, each from 0 to 1000")
    return values


@click.command()
@opt.dataset_option(required=False)
@opt.dataset_dir_option
@opt.option("cost", default=params.DEFAULTS["cost"])
@opt.option("csw_rule", multiple=True, default="literal,unique")
@click.option("--tau-range", "taus", default=DEFAULT_TAUS, show_default=True,
              callback=parse_taus,
              help="Taus: numbers, Nx (N times the auto tau), a:b:step, none "
                   "(at most 1000 in all).")
@click.option("--csw-margin", "csw_margins", default=None, callback=parse_ints,
              help="Comma-separated margins (percent) for the unique rule "
                   f"[default: {params.CSW_MARGIN_TEXT}].")
@opt.option("window", short="-w", default=params.DEFAULTS["window"])
@opt.dataset_dmax_option()
@opt.option("threads", short="-j")
@click.option("--plot", type=click.Path(dir_okay=False),
              help="Also write the curves as a PNG (one dataset only; needs matplotlib).")
@opt.format_option
@opt.data_dir_option
@opt.download_option
@opt.verify_option
@opt.stage_options(params.EXPERIMENT_PRESET)
@click.pass_context
def sweep(ctx, datasets, dataset_dirs, cost, csw_rules, taus, csw_margins, window, dmax,
          threads, plot, fmt, data_dir, download, verify, **stage_values):
    """Run CSW over a range of tau for each rule and report work saved against bad-1.

    Results are the same with either engine; the sweep uses the fast one.

    \b
    Examples:
      csw sweep --dataset tsukuba --dmax 16
      csw sweep -d cones --csw-rule unique --csw-margin 8,12,20 --tau-range 1x,3x,none
      csw sweep -d teddy --tau-range 200:1200:200 --plot teddy.png
    """
    from csw import sweep_rows
    from csw.io.outputs import PairOutputs

    with opt.library_errors():
        PairOutputs({"plot": plot}).check_paths()
        stages = params.experiment_stages(**opt.given(ctx, ["preset", *params.OFF]))
    if plot and len(datasets) + len(dataset_dirs) != 1:
        raise click.UsageError("--plot draws one dataset; give a single --dataset")
    rows, names = [], []
    for pair in opt.pairs(datasets, dataset_dirs, data_dir, download, verify):
        top = pair.dmax if dmax is None else dmax
        names.append(pair.name)
        with opt.library_errors():
            rows += sweep_rows(pair, cost=cost, rules=csw_rules, taus=taus,
                               csw_margins=csw_margins, window=window, dmax=top,
                               threads=threads, stages=stages,
                               progress=lambda step: click.echo(f"sweep: {step}", err=True))
    caption = (f"CSW trade-off, {cost.upper()} {window}x{window}: work saved (candidate "
               "costs skipped) against bad-1 over all known ground truth; Nx = N times the "
               "auto tau (the paper's histogram rule), none = no cost threshold.")
    emit(rows, COLUMNS, fmt, caption)
    if plot:
        from csw.eval import plots

        if len(names) != 1:
            raise click.UsageError("--plot draws one scene; this folder holds several")
        with opt.library_errors():
            plots.tradeoff(plot, rows,
                           f"{names[0]}: {cost.upper()} {window}x{window}, d 0..{top}")

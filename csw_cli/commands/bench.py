"""``csw bench``: TABLE II of the paper, measured here, for any dataset."""

import click

from csw.config import params
from csw.config.tau import WORDS, parse_tau

from .. import options as opt
from ..report import emit

COLUMNS = [
    ("dataset", "Image", 0),
    ("algorithm", "Algorithm", 0),
    ("engine", "Engine", 0),
    ("tau", "τ", 0),
    ("error_rate", "Error rate (%)", 2),
    ("metric", "Metric", 0),
    ("density", "Density (%)", 1),
    ("bad_valid", "Bad valid (%)", 2),
    ("filled_bad", "Bad filled (%)", 2),
    ("time_s", "Time (s)", 4),
    ("time_reduced", "Time reduced (%)", 2),
    ("work_saved", "Work saved (%)", 2),
]
PAPER_COLUMNS = [
    ("paper_error_rate", "Paper error (%)", 2),
    ("paper_time_reduced", "Paper time reduced (%)", 2),
]


def literal_tau(ctx, param, value):
    """bench's --tau also takes 'paper': the paper's tau where it has one."""
    try:
        return parse_tau(value, WORDS)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None


@click.command()
@opt.dataset_option(required=False)
@opt.dataset_dir_option
@opt.option("cost", multiple=True, preset=params.EXPERIMENT_PRESET)
@opt.option("engine", multiple=True,
            help=params.ENGINE_HELP + " [default: window,fast; with --preset paper: window]")
@click.option("--tau", default=None, callback=literal_tau,
              help="tau of the literal rule's rows: N, 'auto' (histogram rule on the plain "
                   "min-cost map), 'none' or 'paper' [default: paper with --preset paper, "
                   "else auto].")
@opt.option("csw_rule", multiple=True,
            help=params.RULE_HELP + " [default: literal,unique; with --preset paper: literal]")
@opt.option("tau", flag="--unique-tau", dest="unique_tau",
            help="tau for the unique rule's rows [default: none, no cost threshold].")
@opt.option("csw_margin")
@opt.option("preset", preset=params.EXPERIMENT_PRESET,
            help="paper: the paper's method and settings (window engine, literal rule, 9x9, "
                 "its costs, disparity ranges and taus); raw, accurate or sgm: that pipeline "
                 "(see csw match) around every row.")
@opt.option("window", short="-w",
            help="Odd window side [default: the preset's: 9, 5 for sgm].")
@opt.experiment_dmin_option
@opt.dataset_dmax_option()
@click.option("--repeat", type=click.IntRange(1, 1000), default=params.BENCH_REPEAT,
              show_default=True, help="Timed runs of each variant; the median is reported.")
@opt.bench_threads_option
@click.option("--paper-figures/--no-paper-figures", default=False, show_default=True,
              help="Add the paper's error rate and time reduction beside each row.")
@opt.format_option
@opt.data_dir_option
@opt.download_option
@opt.verify_option
@opt.stage_options(params.EXPERIMENT_PRESET, skip=("preset",))
@click.pass_context
def bench(ctx, datasets, dataset_dirs, costs, engines, tau, csw_rules, unique_tau, csw_margin,
          preset, window, dmin, dmax, repeat, threads, paper_figures, fmt, data_dir, download,
          verify, **stage_values):
    """Match each dataset plain and with CSW, score both, and time both.

    Datasets come from the registry (--dataset) or from benchmark folders as published
    (--dataset-dir: Middlebury 2014/2021 scenes, KITTI 2012/2015 training folders); a
    folder's rows end with a total over its scenes.  Density is the share of known pixels
    with a disparity; bad valid is over those; bad filled after the evaluation kits'
    background fill; bad by the benchmark's measure (Metric): KITTI's D1, else bad-2.
    Presets that aggregate (sgm) give plain rows only: CSW has no cost to skip there.

    \b
    Examples:
      csw bench --dataset tsukuba --preset paper
      csw bench -d synthetic -d cones --cost sad,ssd --tau auto --format json
      csw bench --dataset-dir MiddEval3/trainingQ --engine fast --csw-rule unique
      csw bench --dataset-dir kitti2015 --preset sgm --dmax 191
    """
    def progress(step):
        click.echo(f"bench: {step}", err=True)

    from csw import run_bench

    with opt.library_errors():
        rows, caption = run_bench(
            opt.pairs(datasets, dataset_dirs, data_dir, download, verify), preset=preset,
            costs=costs, engines=engines, rules=csw_rules, tau=tau, unique_tau=unique_tau,
            csw_margin=csw_margin, window=window, dmin=dmin, dmax=dmax, repeat=repeat,
            threads=threads, progress=progress,
            stages=opt.given(ctx, list(params.OFF)))
    emit(rows, COLUMNS + (PAPER_COLUMNS if paper_figures else []), fmt, caption)

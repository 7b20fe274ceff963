"""Options shared by several commands, defined once (as rasterio's rio/options.py)."""

import click


class TauType(click.ParamType):
    """tau: a number, 'auto' for the paper's histogram rule, or 'none' for no cost
    threshold (every match that the rule finds distinct claims its pixel)."""

    name = "tau"

    def __init__(self, extra=()):
        self.words = ("auto", "none", *extra)

    def convert(self, value, param, ctx):
        if isinstance(value, (int, float)) or value in self.words:
            return value
        try:
            number = float(value)
        except ValueError:
            self.fail(f"{value!r} is not a number or one of {', '.join(self.words)}", param,
                      ctx)
        if number != number:  # NaN
            self.fail("tau must be a number, not NaN", param, ctx)
        return number


def tau_value(tau, rule):
    """The number a tau option stands for; None (not given) means the rule's default:
    'auto' for the literal rule, 'none' for the unique rule."""
    if tau is None:
        tau = "none" if rule == "unique" else "auto"
    return float("inf") if tau == "none" else tau


def comma_list(*allowed):
    """A callback that reads a comma-separated option value as a list of the allowed
    names, in the order given, each once."""

    def parse(ctx, param, value):
        names = [v.strip().lower() for v in value.split(",") if v.strip()]
        unknown = [n for n in names if n not in allowed]
        if unknown or not names:
            raise click.BadParameter(f"unknown {', '.join(unknown) or repr(value)}; use one or "
                                     f"more of {', '.join(allowed)}, separated by commas")
        return list(dict.fromkeys(names))

    return parse


def cost_option(multiple=False):
    if multiple:
        return click.option("--cost", "costs", default="sad", show_default=True,
                            help="Comma-separated costs from sad, ssd, shd.",
                            callback=comma_list("sad", "ssd", "shd"))
    return click.option("--cost", type=click.Choice(["sad", "ssd", "shd"]), default="sad",
                        show_default=True, help="Matching cost.")


window_option = click.option("--window", "-w", type=int, default=9, show_default=True,
                             help="Odd window side (9 = the paper's 9x9).")
dmin_option = click.option("--dmin", type=int, default=0, show_default=True,
                           help="Smallest disparity searched.")
dmax_option = click.option("--dmax", type=int, default=64, show_default=True,
                           help="Largest disparity searched (less than the width).")
threads_option = click.option("--threads", "-j", type=click.IntRange(min=1), default=None,
                              help="Threads for row-parallel matching [default: all cores].")
csw_option = click.option("--csw/--no-csw", default=False, show_default=True,
                          help="Skip right pixels already claimed by a confident match.")
tau_option = click.option(
    "--tau", type=TauType(), default=None,
    help="CSW threshold on the minimum cost: a number, 'auto' for the paper's rule (width "
         "of the first of 10 histogram bins), or 'none' [default: auto for the literal "
         "rule, none for the unique rule].")
rule_option = click.option(
    "--csw-rule", "rule", type=click.Choice(["literal", "unique"]), default="literal",
    show_default=True,
    help="literal: the paper's rule, a match with m <= tau claims its right pixel for good. "
         "unique: only distinct matches claim, and a claim does not bind the next pixel; it "
         "keeps plain matching's accuracy (see reports/csw-tradeoff.md).")
uniqueness_option = click.option(
    "--uniqueness", type=click.IntRange(0, 1000), default=None,
    help="The unique rule's margin in percent: the best cost must beat every candidate 2 "
         "or more disparities away by this much [default: 12; 25 for SSD].")
format_option = click.option(
    "--format", "fmt", type=click.Choice(["table", "github", "latex", "csv", "json"]),
    default="table", show_default=True, help="Output format of the table on stdout.")


def _dataset_names():
    from .datasets import names

    return names()


data_dir_option = click.option(
    "--data-dir", type=click.Path(file_okay=False), envvar="CSW_DATA_DIR",
    help="Folder holding the datasets (default: $CSW_DATA_DIR, then the user cache, then "
         "a download from the official Middlebury URLs).")
download_option = click.option(
    "--download/--no-download", default=True, show_default=True,
    help="Download missing dataset files from the official URLs into the user cache.")


def dataset_option(multiple=True, required=True):
    return click.option("--dataset", "-d", "datasets" if multiple else "dataset",
                        multiple=multiple, required=required,
                        type=click.Choice(_dataset_names()),
                        help="A registered dataset (see 'csw datasets')"
                             + ("; repeat for several." if multiple else "."))

engine_option = click.option(
    "--engine", type=click.Choice(["fast", "window"]), default="fast", show_default=True,
    help="fast: running sums, O(1) per (pixel, disparity); window: a full window sum per "
         "candidate, the paper's method, where CSW's skipped candidates save real time. "
         "Both give identical results.")

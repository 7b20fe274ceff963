"""Options shared by several commands, defined once (as rasterio's rio/options.py).

Defaults come from the library's table (csw.defaults.MATCH) and choice lists from the
kernels' registries, so the CLI repeats neither.
"""

import contextlib

import click

from csw import kernels
from csw.datasets import DataError
from csw.defaults import BENCH_REPEAT, BENCH_THREADS, MATCH
from csw.io import ImageError
from csw.tau import WORDS, parse_tau

__all__ = ["BENCH_REPEAT", "WORDS"]  # re-exported for the commands, beside the options

COSTS = list(kernels.COSTS)
RULES = list(kernels.RULES)
ENGINES = list(kernels.ENGINES)


@contextlib.contextmanager
def library_errors(hint=None):
    """Turn the library's errors into Click's: a bad input file or value is a usage error
    (exit 2, naming ``hint`` where given), as is bad data in a folder the user named;
    registry data that can't be had is a runtime error (exit 1)."""
    try:
        yield
    except ImageError as exc:
        raise click.BadParameter(str(exc), param_hint=hint) from None
    except DataError as exc:
        if hint:
            raise click.BadParameter(str(exc), param_hint=hint) from None
        raise click.ClickException(str(exc)) from None
    except ValueError as exc:
        if hint:
            raise click.BadParameter(str(exc), param_hint=hint) from None
        raise click.UsageError(str(exc)) from None
    except ImportError as exc:
        raise click.ClickException(str(exc)) from None


class TauType(click.ParamType):
    """tau: a number >= 0, or one of the words csw.tau knows ('auto', 'none', and for
    bench 'paper')."""

    name = "tau"

    def __init__(self, words=("auto", "none")):
        self.words = words

    def convert(self, value, param, ctx):
        try:
            return parse_tau(value, self.words)
        except ValueError as exc:
            self.fail(str(exc), param, ctx)


def comma_list(*allowed):
    """A callback that reads a comma-separated option value as a list of the allowed
    names, in the order given, each once.  None (not given) stays None."""

    def parse(ctx, param, value):
        if value is None:
            return None
        names = [v.strip().lower() for v in value.split(",") if v.strip()]
        unknown = [n for n in names if n not in allowed]
        if unknown or not names:
            raise click.BadParameter(f"unknown {', '.join(unknown) or repr(value)}; use one or "
                                     f"more of {', '.join(allowed)}, separated by commas")
        return list(dict.fromkeys(names))

    return parse


def cost_option(multiple=False, default=MATCH["cost"]):
    if multiple:
        return click.option("--cost", "costs", default=default, show_default=True,
                            help=f"Comma-separated costs from {', '.join(COSTS)}.",
                            callback=comma_list(*COSTS))
    return click.option("--cost", type=click.Choice(COSTS), default=default,
                        show_default=default is not None,
                        help="Matching cost" + (" [default: the preset's]." if default is None
                                                else "."))


def engine_option(multiple=False, default=MATCH["engine"]):
    text = ("fast: running sums, O(1) per (pixel, disparity); window: a full window sum per "
            "candidate, the paper's method, where CSW's skipped candidates save real time. "
            "Both give identical results.")
    if multiple:
        return click.option("--engine", "engines", default=default, show_default=True,
                            callback=comma_list(*ENGINES),
                            help="Comma-separated engines. " + text)
    return click.option("--engine", type=click.Choice(ENGINES), default=default,
                        show_default=default is not None,
                        help=text + (" [default: the preset's]" if default is None else ""))


RULE_HELP = ("literal: the paper's rule, a match with m <= tau claims its right pixel for "
             "good. unique: only distinct matches claim, and a claim does not bind the next "
             "pixel; it keeps plain matching's accuracy (see reports/csw-tradeoff.md).")


def rule_option(multiple=False, default=MATCH["csw_rule"]):
    """--csw-rule, the same flag in every command."""
    if multiple:
        return click.option("--csw-rule", "rules", default=default, show_default=True,
                            callback=comma_list(*RULES),
                            help="Comma-separated CSW rules. " + RULE_HELP)
    return click.option("--csw-rule", "rule", type=click.Choice(RULES), default=default,
                        show_default=True, help=RULE_HELP)


def window_option(default=MATCH["window"]):
    return click.option("--window", "-w", type=int, default=default,
                        show_default=default is not None,
                        help="Odd window side (9 = the paper's 9x9)"
                             + (" [default: the preset's]." if default is None else "."))


dmin_option = click.option("--dmin", type=click.IntRange(min=0), default=MATCH["dmin"],
                           show_default=True, help="Smallest disparity searched.")
dmax_option = click.option("--dmax", type=click.IntRange(min=0), default=MATCH["dmax"],
                           show_default=True,
                           help="Largest disparity searched (less than the width).")
dataset_dmax_option = click.option(
    "--dmax", type=click.IntRange(min=0), default=None,
    help="Largest disparity [default: the dataset's range].")
threads_option = click.option("--threads", "-j", type=click.IntRange(min=1), default=None,
                              help="Threads for row-parallel matching [default: all cores].")
bench_threads_option = click.option("--threads", "-j", type=click.IntRange(min=1),
                                    default=BENCH_THREADS, show_default=True,
                                    help="Threads (1 = the paper's single core).")
csw_option = click.option("--csw/--no-csw", default=MATCH["csw"], show_default=True,
                          help="Skip right pixels already claimed by a confident match.")
tau_option = click.option(
    "--tau", type=TauType(), default=None,
    help="CSW threshold on the minimum cost: a number, 'auto' for the paper's rule (width "
         "of the first of 10 histogram bins), or 'none' [default: auto for the literal "
         "rule, none for the unique rule]. Needs --csw.")
uniqueness_option = click.option(
    "--uniqueness", type=click.IntRange(0, 1000), default=MATCH["uniqueness"],
    help="The unique rule's margin in percent: the best cost must beat every candidate 2 "
         "or more disparities away by this much [default: 12; 25 for SSD].")
format_option = click.option(
    "--format", "fmt", type=click.Choice(["table", "github", "latex", "csv", "json"]),
    default="table", show_default=True, help="Output format of the table on stdout.")


def _dataset_names():
    from csw.datasets import names

    return names()


data_dir_option = click.option(
    "--data-dir", type=click.Path(file_okay=False, exists=True), envvar="CSW_DATA_DIR",
    help="Folder holding the registered datasets (default: $CSW_DATA_DIR, then the user "
         "cache, then a download from the official Middlebury URLs).")
download_option = click.option(
    "--download/--no-download", default=True, show_default=True,
    help="Download missing dataset files from the official URLs into the user cache.")
verify_option = click.option(
    "--verify/--no-verify", default=True, show_default=True,
    help="Check registered dataset files against their sha256 before first use (the check "
         "is remembered). --no-verify uses modified data knowingly; every report says so.")
dataset_dir_option = click.option(
    "--dataset-dir", "dataset_dirs", multiple=True, type=click.Path(file_okay=False),
    help="A benchmark folder as published: a Middlebury 2014/2021 scene or a folder of "
         "them, or a KITTI 2012/2015 training folder; every scene in it is used. Repeat "
         "for several.")


def dataset_option(multiple=True, required=True):
    return click.option("--dataset", "-d", "datasets" if multiple else "dataset",
                        multiple=multiple, required=required,
                        type=click.Choice(_dataset_names()),
                        help="A registered dataset (see 'csw datasets')"
                             + ("; repeat for several." if multiple else "."))


NOT_VERIFIED = ("warning: dataset files were not checked against their sha256 "
                "(--no-verify); figures from modified data are not the benchmark's")


def pairs(datasets, dataset_dirs, data_dir, download, verify=True):
    """Every pair the options name, loaded one at a time: registered datasets first, then
    each scene of each --dataset-dir.  Library errors become Click errors."""
    from csw import datasets as registry
    from csw import layouts

    if not datasets and not dataset_dirs:
        raise click.UsageError("give --dataset NAME or --dataset-dir PATH")
    if not verify and datasets:
        click.echo(NOT_VERIFIED, err=True)
    for name in datasets:
        with library_errors():
            pair = registry.load(name, data_dir, allow_download=download, verify=verify)
        yield pair
    for folder in dataset_dirs:
        with library_errors():
            scenes = layouts.scan(folder)
        for scene in scenes:
            with library_errors():
                pair = scene.load()
            yield pair


class OffOrInt(click.ParamType):
    """A whole number >= 0, or 'off'."""

    name = "N|off"

    def convert(self, value, param, ctx):
        if value is None or (isinstance(value, str) and value.strip().lower() == "off"):
            return None
        try:
            number = int(value)
        except (TypeError, ValueError):
            self.fail(f"{value!r} is not a whole number or 'off'", param, ctx)
        if number < 0:
            self.fail("must be >= 0, or 'off'", param, ctx)
        return number


def _preset_names():
    from csw.defaults import PRESETS

    return list(PRESETS)


# The pipeline's stages (csw.pipeline), with their library names.  Their defaults come
# from the preset (csw.defaults.PRESETS), so the CLI passes only what the user gives.
STAGE_OPTIONS = [
    click.option("--preset", type=click.Choice(_preset_names()), default=None,
                 help=f"accurate: census, left-right check and speckle removal, for real "
                      f"photographs; raw: the contract's winner-take-all map; paper: the "
                      f"paper's method (window engine, SAD 9x9, no stage) "
                      f"[default: {MATCH['preset']}]."),
    click.option("--prefilter", type=click.Choice(["none", "xsobel"]), default=None,
                 help="xsobel: StereoBM's x-Sobel prefilter, clipped to +-cap."),
    click.option("--prefilter-cap", type=click.IntRange(1, 63), default=None,
                 help=f"The prefilter's cap [default: {MATCH['prefilter_cap']}]."),
    click.option("--census-window", type=click.IntRange(3, 7), default=None,
                 help="Census window side for --cost census (odd; 7 or less for 64 bits)."),
    click.option("--lr-check", type=OffOrInt(), default=None,
                 help="Left-right check from the same costs: invalid where the right "
                      "image's match differs by more than N; 'off' to drop it."),
    click.option("--uniqueness-ratio", type=OffOrInt(), default=None,
                 help="StereoBM's: invalid where a candidate 2+ away costs within N% of "
                      "the best."),
    click.option("--texture-threshold", type=OffOrInt(), default=None,
                 help="StereoBM's: invalid where the window's summed |x-Sobel| is below N."),
    click.option("--subpixel", type=click.Choice(["none", "parabola", "linear"]),
                 default=None, help="Subpixel fit through the costs at d-1, d, d+1."),
    click.option("--speckle-size", type=click.IntRange(0, 10**7), default=None,
                 help="Invalidate regions of similar disparity under N pixels (0: off)."),
    click.option("--speckle-range", type=click.FloatRange(0, 1000), default=None,
                 help="Largest step between neighbours of one speckle region."),
    click.option("--median", type=click.Choice(["0", "3", "5", "7"]), default=None,
                 help="A KxK median over valid pixels (0: off)."),
    click.option("--fill", type=click.Choice(["none", "background"]), default=None,
                 help="background: fill invalid pixels as the Middlebury/KITTI kits do."),
]
STAGE_NAMES = ["preset", "prefilter", "prefilter_cap", "census_window", "lr_check",
               "uniqueness_ratio", "texture_threshold", "subpixel", "speckle_size",
               "speckle_range", "median", "fill"]


def stage_options(command):
    """Decorate a command with every pipeline stage option."""
    for option in reversed(STAGE_OPTIONS):
        command = option(command)
    return command


def given(ctx, names, rename=None):
    """The options among ``names`` that the user gave (on the command line or through
    the environment), under their library names: the library's table supplies the rest."""
    from click.core import ParameterSource

    rename = rename or {}
    out = {}
    for name in names:
        if ctx.get_parameter_source(name) not in (ParameterSource.DEFAULT, None):
            value = ctx.params[name]
            out[rename.get(name, name)] = int(value) if name == "median" else value
    return out

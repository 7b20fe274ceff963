"""Options shared by several commands, defined once (as rasterio's rio/options.py).

Every matching option is built from the library's table (csw.config.params.OPTIONS): its flag,
type, allowed values, help and default text come from there, so the CLI repeats none of
them.  The CLI passes on only the options the user gave (see :func:`given`); the library
fills in the rest.
"""

import contextlib
from pathlib import Path

import click

from csw.config import params
from csw.config.params import OPTIONS

FORMATS = ["table", "github", "latex", "csv", "json"]


class InputError(click.ClickException):
    """A bad value or file that the command line itself got right: exit 2, and one line,
    "Error: Invalid value for OPTION: why", without the usage lines Click puts before a
    malformed command line's error."""

    exit_code = 2

    def __init__(self, message, hint=None):
        super().__init__(message)
        self.hint = hint

    def format_message(self):
        return f"Invalid value for {self.hint}: {self.message}" if self.hint else \
            self.message


@contextlib.contextmanager
def library_errors(hint=None):
    """Turn the library's errors into Click's.  A bad value or file is an InputError
    (exit 2, one line), naming the option it belongs to (the error's ``option``, as a
    flag of the running command) or ``hint``, but for an environment variable's (the
    error's ``variable``, which its message names); registry data that can't be had is
    a runtime error (exit 1)."""
    from csw import DataError

    try:
        yield
    except DataError as exc:
        if hint:
            raise InputError(str(exc), hint) from None
        raise click.ClickException(str(exc)) from None
    except ValueError as exc:  # csw.ImageError among them
        if getattr(exc, "variable", None) is not None:
            raise InputError(str(exc)) from None
        raise InputError(str(exc), _hint(exc) or hint) from None
    except ImportError as exc:
        raise click.ClickException(str(exc)) from None


def _hint(exc):
    """The running command's flag (or argument) for the option an error names."""
    name = getattr(exc, "option", None)
    ctx = click.get_current_context(silent=True)
    if name is None or ctx is None:
        return None
    for param in ctx.command.params:
        if param.name in (name, name + "s"):
            return param.opts[0] if isinstance(param, click.Option) else param.human_readable_name
    return None


class LibraryType(click.ParamType):
    """A value checked by the library's table: the same reading and the same message as
    csw.config.params gives a notebook user."""

    def __init__(self, option):
        self.option = option
        self.name = {"tau": "tau", "off_int": "N|off"}.get(option.kind, "value")

    def convert(self, value, param, ctx):
        try:
            return self.option.check(value)
        except ValueError as exc:
            self.fail(str(exc), param, ctx)


class Sectioned(click.Command):
    """A command whose --help lists its options in sections, in the order a user reads
    them (``sections``: (title, option names) pairs); an option in none of them is listed
    last, under "Other options"."""

    sections = ()

    def format_options(self, ctx, formatter):
        records = {p.name: p.get_help_record(ctx) for p in self.get_params(ctx)
                   if isinstance(p, click.Option)}
        placed = set()
        for title, names in self.sections:
            rows = [records[n] for n in names if records.get(n)]
            placed.update(names)
            if rows:
                with formatter.section(title):
                    formatter.write_dl(rows)
        rest = [record for name, record in records.items() if record and name not in placed]
        if rest:
            with formatter.section("Other options"):
                formatter.write_dl(rest)


def sectioned(*sections):
    """The ``cls`` for a click.command whose help has these sections (see Sectioned)."""
    return type("SectionedCommand", (Sectioned,), {"sections": sections})


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


def option(name, *, default=None, multiple=False, show_default=None, help=None, flag=None,
           short=None, dest=None, preset=params.DEFAULTS["preset"]):
    """The Click option for a matching option of the library's table.

    default: None (the command passes nothing unless given; the help names the library's
    default, as ``preset`` sets it) or a value of the command's own.  multiple: a
    comma-separated list of choices (experiments that compare several).  help: text to
    use instead of the table's.
    """
    o = OPTIONS[name]
    names = [flag or o.cli_flag] + ([short] if short else [])
    dest = dest or (name + "s" if multiple else name)
    text = help or o.help
    if default is None and show_default is None and "[default:" not in text:
        if name == "preset":
            shown = preset
        else:
            value = params.PRESETS[preset].get(name, o.default)
            shown = str(value) if value is not None else \
                o.default_text or ("off" if o.kind == "off_int" else None)
            if name in params.PRESETS[preset] and value != o.default:
                shown += f", the {preset} preset's"
        text += f" [default: {shown}]" if shown else ""
    if multiple:
        return click.option(*names, dest, default=default, show_default=bool(default),
                            callback=comma_list(*o.choices),
                            help=f"Comma-separated; {text[0].lower()}{text[1:]}")
    if o.kind == "bool":
        flag_name = names[0].lstrip("-")
        return click.option(f"--{flag_name}/--no-{flag_name}", dest, default=default,
                            show_default=show_default or default is not None, help=text)
    kind = (click.Choice([str(c) for c in o.choices]) if o.choices else LibraryType(o))
    return click.option(*names, dest, type=kind, default=default,
                        show_default=show_default or default is not None, help=text)


def stage_options(preset=params.DEFAULTS["preset"], skip=()):
    """A decorator adding --preset and every pipeline stage option, their help naming the
    values of the command's default ``preset``."""
    def decorate(command):
        for name in reversed(["preset", *params.OFF]):
            if name not in skip:
                command = option(name, preset=preset)(command)
        return command
    return decorate


def given(ctx, names, rename=None):
    """The options among ``names`` that the user gave (on the command line or through
    the environment), under their library names: the library's table supplies the rest."""
    from click.core import ParameterSource

    rename = rename or {}
    out = {}
    for name in names:
        if ctx.get_parameter_source(name) not in (ParameterSource.DEFAULT, None):
            out[rename.get(name, name)] = ctx.params[name]
    return out


format_option = click.option(
    "--format", "fmt", type=click.Choice(FORMATS), default="table", show_default=True,
    help="Output format of the table on stdout.")


def _existing_folder(ctx, param, value):
    """The datasets' folder, checked here rather than by Click's Path(exists=True), whose
    error named --data-dir, after its usage lines, where CSW_DATA_DIR gave the folder."""
    if value is None:
        return None
    from click.core import ParameterSource

    named = "CSW_DATA_DIR" if ctx.get_parameter_source(param.name) is \
        ParameterSource.ENVIRONMENT else param.opts[0]
    folder = Path(value).expanduser()
    if not folder.is_dir():
        why = "is not a folder" if folder.exists() else "does not exist"
        raise InputError(f"{named} names {value!r}, which {why}")
    return value


data_dir_option = click.option(
    "--data-dir", type=click.Path(), envvar="CSW_DATA_DIR", callback=_existing_folder,
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
bench_threads_option = click.option(
    "--threads", "-j", type=click.IntRange(min=1), default=params.BENCH_THREADS,
    show_default=True, help="Threads (1 = the paper's single core).")


# The experiments' ranges (bench, hist, sweep): numbers, or the dataset's; 'auto', which
# finds a pair's range as csw match does, is not theirs (their rows compare one range).
def dataset_dmax_option(help="Largest disparity [default: the dataset's range]."):
    return click.option("--dmax", type=click.IntRange(min=0), default=None, help=help)


experiment_dmin_option = click.option(
    "--dmin", type=int, default=0, show_default=True,
    help="Smallest disparity searched; below 0 for convergent rigs.")


def _dataset_names():
    from csw.data.datasets import names

    return names()


def dataset_option(multiple=True, required=True):
    return click.option("--dataset", "-d", "datasets" if multiple else "dataset",
                        multiple=multiple, required=required,
                        type=click.Choice(_dataset_names()),
                        help="A registered dataset (see 'csw datasets')"
                             + ("; repeat for several." if multiple else "."))


def pairs(datasets, dataset_dirs, data_dir, download, verify=True):
    """Every pair the options name, loaded one at a time: registered datasets first, then
    each scene of each --dataset-dir.  Library errors become Click errors."""
    from csw.data import datasets as registry
    from csw.data import layouts

    if not datasets and not dataset_dirs:
        raise click.UsageError("give --dataset NAME or --dataset-dir PATH")
    if not verify and datasets:
        click.echo("warning: " + registry.NOT_VERIFIED, err=True)
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


def calibration_options(beside_left=False):
    """A decorator adding --calib FILE, or --focal/--baseline/--cx/--cy/--doffs, and
    --units: the pair's calibration (csw.camera.calibration.from_options turns them into one).
    beside_left: the command falls back on the calib.txt beside its LEFT image, and its
    help says so."""
    from csw.camera.calibration import UNITS

    fallback = " [default: the calib.txt beside LEFT, if any]" if beside_left else ""
    decorators = [
        click.option("--calib", type=click.Path(dir_okay=False),
                     help="The pair's calibration: a Middlebury calib.txt, a KITTI calib "
                          "(P2/P3 or P_rect_02/03), an OpenCV YAML/XML with Q, a 4x4 Q in "
                          ".npy, or a one-file rig as --rig takes (rectified, alpha 0)"
                          f"{fallback}."),
        click.option("--focal", type=float, help="Or by hand: the focal length (pixels)."),
        click.option("--baseline", type=float,
                     help="By hand: the baseline (depth comes out in its units)."),
        click.option("--cx", type=float,
                     help="By hand: the principal point's x [default: the centre]."),
        click.option("--cy", type=float,
                     help="By hand: the principal point's y [default: the centre]."),
        click.option("--doffs", type=float,
                     help="By hand: the right principal point's x less the left's "
                          "[default: 0]."),
        click.option("--units", type=click.Choice(list(UNITS)),
                     help="Depth and points in these units [default: the calibration's: "
                          "mm for Middlebury, m for KITTI; an OpenCV Q's or values given "
                          "by hand are taken to be in these units]."),
        click.option("--calib-units", type=click.Choice(list(UNITS)),
                     help="The units of a calibration that doesn't say them (an OpenCV Q, "
                          "--baseline), so that --units converts from them."),
    ]
    def decorate_all(command):
        for decorate in reversed(decorators):
            command = decorate(command)
        return command
    return decorate_all


def calibration(ctx_params):
    """The Calibration (or None) the calibration options name; Click errors for bad ones."""
    from csw.camera.calibration import from_options

    with library_errors():
        return from_options(*(ctx_params[k] for k in ("calib", "focal", "baseline", "cx",
                                                       "cy", "doffs", "calib_units")))


def write_error(exc):
    """The one-line error (exit 1) for an OSError while writing."""
    where = f" {exc.filename}" if getattr(exc, "filename", None) else ""
    return click.ClickException(f"can't write{where}: {exc.strerror or exc}")

"""The ``csw`` command group: a thin group, one module per command in commands/, each
imported only when it runs (a command's imports are what its start-up costs)."""

import importlib
import sys

import click

# Command name -> (module in commands/, function), with its one-line help: `csw --help`
# lists them without importing any.
COMMANDS = {
    "bench": ("bench", "bench", "Score and time plain vs CSW matching (the paper's TABLE II)."),
    "cloud": ("depth", "cloud", "Turn a disparity map into a point cloud (PLY)."),
    "compile": ("compile", "compile_", "Compile the presets' kernels ahead (CI, Docker)."),
    "datasets": ("datasets", "datasets", "List the registered datasets."),
    "depth": ("depth", "depth", "Turn a disparity map into depth, with a calibration."),
    "hist": ("hist", "hist", "Histogram of the minimum-cost map m (the paper's Fig. 9)."),
    "match": ("match", "match", "Compute disparity maps for rectified pairs."),
    "score": ("score", "score", "Score a disparity map against ground truth."),
    "sweep": ("sweep", "sweep", "Sweep tau and CSW rules: work saved against bad-1."),
    "synth": ("synth", "synth", "Write a synthetic stereo pair with exact ground truth."),
}


class LazyGroup(click.Group):
    """A group whose commands are imported when they are run or asked for help."""

    def list_commands(self, ctx):
        return sorted(COMMANDS)

    def get_command(self, ctx, name):
        if name not in COMMANDS:
            return None
        module, function, short_help = COMMANDS[name]
        command = getattr(importlib.import_module(f".commands.{module}", __package__),
                          function)
        command.short_help = short_help
        return command

    def format_commands(self, ctx, formatter):
        rows = [(name, COMMANDS[name][2]) for name in self.list_commands(ctx)]
        with formatter.section("Commands"):
            formatter.write_dl(rows)


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="csw", prog_name="csw")
def cli():
    """Stereo matching with the Constrained Sliding Window (CSW) algorithm.

    \b
    Examples:
      csw synth out/scene
      csw match out/scene/left.png out/scene/right.png -o out/disp.pfm --csw
    """



def main(args=None):
    """The ``csw`` entry point: the group, with Ctrl-C reported as an interrupt (exit 130,
    one line) instead of Click's "Aborted!" and exit 1.  Outputs are written through
    temporary files, so an interrupted run leaves none behind."""
    try:
        code = cli.main(args=args, prog_name="csw", standalone_mode=False)
    except (KeyboardInterrupt, click.exceptions.Abort):
        click.echo("csw: interrupted; no partial file was left", err=True)
        sys.exit(130)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.ClickException as exc:
        exc.show()
        sys.exit(exc.exit_code)
    sys.exit(code if isinstance(code, int) else 0)

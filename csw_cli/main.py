"""The ``csw`` command group: a thin group, one module per command in commands/."""

import sys

import click

from . import __version__
from .commands.bench import bench
from .commands.datasets import datasets
from .commands.hist import hist
from .commands.match import match
from .commands.score import score
from .commands.sweep import sweep
from .commands.synth import synth


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="csw")
def cli():
    """Stereo matching with the Constrained Sliding Window (CSW) algorithm.

    \b
    Examples:
      csw synth out/scene
      csw match out/scene/left.png out/scene/right.png -o out/disp.pfm --csw
    """


for command in (bench, datasets, hist, match, score, sweep, synth):
    cli.add_command(command)


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

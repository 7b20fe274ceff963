"""``csw compile``: compile every preset's kernels into the kernel cache, once."""

import click

from csw.config import params


@click.command("compile")
@click.option("--preset", "presets", multiple=True, type=click.Choice(list(params.PRESETS)),
              help="Only this preset's kernels (repeat for several) [default: all].")
def compile_(presets):
    """Compile the kernels of every preset (plain and with --csw, for 8- and 16-bit
    images) into the kernel cache, so that later runs start at once.  Run it in a Docker
    build or a CI cache step; the cache follows NUMBA_CACHE_DIR (or CSW_KERNEL_CACHE).

    \b
    Examples:
      csw compile
      NUMBA_CACHE_DIR=.cache/numba csw compile --preset accurate
    """
    from csw.kernels import native
    from csw.matching.setup import compile_kernels, preset_entries
    from csw.scale.executor import progress_bar

    total = len(preset_entries(presets or None))
    with progress_bar(total, "csw compile", "kernel") as bar:
        compiled, found, seconds = compile_kernels(presets or None,
                                                   progress=lambda key, new: bar.update())
    click.echo(f"{compiled} kernel(s) compiled, {found} already in the cache, in "
               f"{seconds:.1f} s: {native.cache_dir()}", err=True)

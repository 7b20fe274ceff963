"""``csw compile``: compile every kernel a run can load into the kernel cache, once."""

import click

from csw.config import params


@click.command("compile")
@click.option("--preset", "presets", multiple=True, type=click.Choice(list(params.PRESETS)),
              help="Only the kernels this preset runs with its own settings, plain and with "
                   "--csw (repeat for several; seconds rather than minutes) [default: "
                   "every kernel any option can need].")
def compile_(presets):
    """Compile every kernel a run can load (any option's values, windows up to 31, 8- and
    16-bit images) into the kernel cache, so that no later run compiles: about half an
    hour on 2 cores, once.  Run it in a Docker build or a CI cache step; the cache follows
    NUMBA_CACHE_DIR (or CSW_KERNEL_CACHE).

    \b
    Examples:
      csw compile
      NUMBA_CACHE_DIR=.cache/numba csw compile --preset accurate
    """
    from csw.io.progress import progress_bar
    from csw.kernels import catalogue, native
    from csw.matching.setup import compile_kernels, preset_entries

    total = len(preset_entries(presets) if presets else catalogue.every_entry())
    with progress_bar(total, "csw compile", "kernel") as bar:
        compiled, found, seconds = compile_kernels(presets or None,
                                                   progress=lambda key, new: bar.update())
    click.echo(f"{compiled} kernel(s) compiled, {found} already in the cache, in "
               f"{seconds:.1f} s: {native.cache_dir()}", err=True)

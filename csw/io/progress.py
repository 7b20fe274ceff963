"""Progress on stderr: one kind of bar for every run of many items (pairs, frames,
stripes, kernels)."""

import sys


def progress_bar(total, desc, unit, enabled=True, initial=0):
    """A progress bar on stderr (tqdm), or one that does nothing."""
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, desc=desc, unit=unit, file=sys.stderr,
                disable=not enabled)

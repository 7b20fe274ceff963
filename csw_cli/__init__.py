"""The ``csw`` command line: Click commands that parse, call the csw library and print."""

from csw import __version__

__all__ = ["__version__"]

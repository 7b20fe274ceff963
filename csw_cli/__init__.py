"""csw: stereo matching with the Constrained Sliding Window algorithm (the CLI)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("csw")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0+unknown"

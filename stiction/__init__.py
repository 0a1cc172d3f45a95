"""The ``stiction`` command."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("stiction")
except PackageNotFoundError:  # run from a source tree that was never installed
    __version__ = "0+unknown"

"""nanoblock: Persson's nanoblock model of dry friction, from blocks to rate-and-state."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("nanoblock")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]

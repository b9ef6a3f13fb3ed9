"""The ``nanoblock`` console script (and ``python -m nanoblock``): the command line of
:mod:`nanoblock.cli`, imported here so that an interrupt while its modules load (the
first second or two) ends in one line and exit code 130, as one during a command does."""

from __future__ import annotations

import sys


def main() -> None:
    """Import and run the command line; Ctrl-C before a command starts exits 130."""
    try:
        from nanoblock.cli import app

        app()
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        raise SystemExit(130) from None


if __name__ == "__main__":
    main()

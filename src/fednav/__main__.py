"""``fednav`` and ``python -m fednav``: the command line (:mod:`fednav.cli`).

``fednav --version`` answers before the command line's modules are imported (they
import the sensor registry, numba and pydantic to build the commands' options)."""

from __future__ import annotations

import sys


def main() -> None:
    """The console script's entry point."""
    if sys.argv[1:] == ["--version"]:
        from . import __version__

        print(f"fednav {__version__}")
        return
    from .cli import app

    app(prog_name="fednav")


if __name__ == "__main__":
    main()

"""``fednav`` and ``python -m fednav``: the command line (:mod:`fednav.cli`).

``fednav --version`` answers before the command line's modules are imported (they
import the sensor registry, numba and pydantic to build the commands' options).  A
finished command exits without Python's finalization (:func:`exit_now`)."""

from __future__ import annotations

import sys


def main() -> None:
    """The console script's entry point."""
    if sys.argv[1:] == ["--version"]:
        from . import __version__

        print(f"fednav {__version__}")
        return
    from .cli import app

    try:
        app(prog_name="fednav")
    except SystemExit as e:
        exit_now(e.code)
    exit_now(0)


def exit_now(code) -> None:
    """End the process with ``code`` (a :class:`SystemExit`'s: None, a status, or a
    message for stderr and status 1) once the exit handlers have run (``atexit``: the
    libraries' cleanup, temporary folders, worker pools) and stdout and stderr are
    flushed — without the rest of Python's finalization: taking down every module and
    freeing every object took 0.5 s after a 10-minute ``fednav process`` (a fifth of
    its wall time), for nothing a finished command needs."""
    import atexit
    import os

    if code is not None and not isinstance(code, int):
        print(code, file=sys.stderr)
        code = 1
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # (a reader that went away: `| head`; closed)
            pass
    os._exit(code or 0)


if __name__ == "__main__":
    main()

"""The exceptions fednav raises for input it cannot use or a computation that fails.

Every one of them carries a one-line message that names the file, field, filter or step
and the problem; the command line prints that line (``--debug`` shows the traceback).
This module imports nothing heavy so the command line can catch them before loading
numpy or numba.
"""


class FednavError(Exception):
    """Base class of fednav's own errors (one-line message)."""


class DataError(FednavError, ValueError):
    """A sensor data file that cannot be used (one line naming the file and the field)."""


class Interrupted(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised in the main thread as Ctrl-C raises KeyboardInterrupt
    (so every command stops the same way: files being written removed, Dask workers
    stopped in order)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


#: The stop signals this command received (the command line's handler records each
#: before it raises :class:`Interrupted`): a long loop's :func:`check_stop` raises it
#: again where library code caught the first one.
STOPS: list[int] = []


def check_stop() -> None:
    """Raise :class:`Interrupted` when a stop signal came and the command still runs (a
    checkpoint for long loops: a library that catches every exception, KeyboardInterrupt
    included, would otherwise let a stopped command run to its end)."""
    if STOPS:
        raise Interrupted(STOPS[0])


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

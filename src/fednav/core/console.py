"""The terminal console of the command line: full-width tables when the output is not a
terminal.

rich sizes its tables to the terminal, and when standard output is a pipe or a file it
still takes the width of whichever standard stream *is* a terminal (often 80 columns), so
``fednav ... | less`` or ``> out.txt`` cut column names (``north…``,
``degree_filter_un…``). :class:`PipeConsole` gives output that is not a terminal a width
of :data:`PIPE_WIDTH` columns instead (tables keep their natural width, text lines are
not wrapped), unless ``COLUMNS`` is set in the environment or a width is given.
"""

from __future__ import annotations

from rich.console import Console, ConsoleDimensions

#: Columns of output that is not a terminal (a pipe, a file, a test's captured output).
PIPE_WIDTH = 1000


class PipeConsole(Console):
    """A :class:`rich.console.Console` that is :data:`PIPE_WIDTH` columns wide when its
    output is not a terminal (and neither ``COLUMNS`` nor ``width`` says otherwise)."""

    @property
    def size(self) -> ConsoleDimensions:
        dims = super().size
        if (self._width is None and "COLUMNS" not in self._environ
                and not self.is_terminal):
            return ConsoleDimensions(PIPE_WIDTH, dims.height)
        return dims

    @size.setter
    def size(self, new_size) -> None:
        Console.size.fset(self, new_size)

"""Command line: ``fednav reproduce 002`` and friends."""

from __future__ import annotations

import os
import time
from pathlib import Path

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeElapsedColumn

from . import __version__
from .config import ConfigError

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="fednav — federated multi-sensor integrated navigation.")
console = Console()


def _papers():
    from .scenarios import paper002, paper003

    return (paper002, paper003)


def _paper_module(paper: str):
    for mod in _papers():
        if paper.lower() in mod.ALIASES:
            return mod
    known = ", ".join(a for m in _papers() for a in m.ALIASES)
    raise typer.BadParameter(f"unknown paper '{paper}'; available: {known}")


@app.command()
def reproduce(
    paper: str = typer.Argument(..., help="paper number or alias: 002 / cruise-missile, "
                                          "003 / federated-ukf"),
    runs: int = typer.Option(10, min=1, help="Monte Carlo runs"),
    seed: int = typer.Option(1, help="seed of the first run (run i uses seed + i)"),
    out: Path = typer.Option(None, help="output folder [default: results/<paper>]"),
    jobs: int = typer.Option(min(2, os.cpu_count() or 1), min=1, help="worker processes"),
    scenario: Path = typer.Option(None, help="alternative scenario YAML"),
    max_time: float = typer.Option(None, help="truncate the flight (smoke runs only)"),
) -> None:
    """Reproduce a paper's experiment and print its tables beside the paper's."""
    mod = _paper_module(paper)
    try:
        scn = mod.load_scenario(scenario)
    except ConfigError as e:
        typer.echo(f"error: {e}", err=True)
        raise typer.Exit(2) from None
    t0 = time.perf_counter()
    with Progress("[progress.description]{task.description}", BarColumn(),
                  MofNCompleteColumn(), TimeElapsedColumn(), console=console,
                  transient=False) as prog:
        task = prog.add_task(f"paper {mod.PAPER}: {scn.name}", total=runs)
        rep = mod.reproduce(scn, runs, seed, jobs, max_time,
                            progress=lambda: prog.advance(task))
    mod.print_summary(rep["summary"], console)
    out = out or Path("results") / mod.PAPER
    files = mod.write_outputs(out, rep)
    console.print(f"wrote {', '.join(str(f) for f in files)} "
                  f"in {time.perf_counter() - t0:.1f} s")


@app.command()
def version() -> None:
    """Print the fednav version."""
    console.print(__version__)


def main() -> None:  # pragma: no cover
    app()

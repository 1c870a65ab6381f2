"""What a paper's experiment is to the campaign machinery: one interface every paper
implements (:mod:`fednav.scenarios`).

A paper is its scenario YAML, the units of work a reproduction flies (each a module-level
function and its arguments: a Monte Carlo run, an analysis, a sweep point), the tables it
computes from their results, and its plots.  :meth:`Paper.reproduce` hands the units to
the campaign store (:func:`fednav.campaign.store.run_units`: resumable, local processes or
Dask) in one batch, so the progress bar counts every unit and a resumed campaign reuses
every stored one; :meth:`Paper.write_outputs` writes ``runs.csv``, the paper's plots and
files, and ``summary.json`` last (its presence means the run finished).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from ..core.atomic import write_frame, write_json
from .evaluation import NULL_REASONS
from .montecarlo import run_seeds


@dataclass(frozen=True)
class Unit:
    """One unit of a campaign's work: ``fn(args)``.  ``fn`` is a module-level function
    (workers import it by name) and the pair keys the stored result, so a unit computed
    once is reused by every later reproduction with the same scenario and seed."""

    fn: Callable
    args: tuple


class Paper(ABC):
    """A paper's experiment.

    Attributes: ``number`` ("002"), ``tables`` (the paper's published values: table ->
    row -> column -> value), ``titles`` (table -> heading), ``options`` (the extra
    keyword options its :meth:`units` takes, e.g. ``particles``; the command line offers
    them for this paper only).  A paper gives :meth:`load_scenario`, :meth:`units` and
    :meth:`summarize`, and may add :meth:`plots` and :meth:`files`.
    """

    number: str = ""
    #: The name of the units' kernel plan (:mod:`fednav.campaign.kernel_plan`; None:
    #: none), compiled by one worker on a first run.
    kernel_plan: str | None = None
    tables: dict = {}
    titles: dict = {}
    options: tuple[str, ...] = ()

    # ------------------------------------------------------------------ the experiment
    @abstractmethod
    def load_scenario(self, path=None):
        """The packaged scenario (or another file of the same layout)."""

    @abstractmethod
    def units(self, scn, runs: int, seed: int, max_time: float | None = None,
              **options) -> list[Unit]:
        """Every unit of work of a reproduction, in the order they are handed out (the
        long ones first)."""

    @staticmethod
    def per_seed(fn: Callable, scn, runs: int, seed: int, max_time: float | None,
                 *extra) -> list[Unit]:
        """``fn((scn, seed + i, max_time, *extra))`` for the ``runs`` Monte Carlo runs."""
        return [Unit(fn, (scn, seed + i, max_time, *extra)) for i in range(runs)]

    @abstractmethod
    def summarize(self, scn, runs: int, seed: int, max_time: float | None, results: list,
                  **options) -> dict:
        """The report from the units' results (in :meth:`units` order): ``rows`` (one
        dict per run and mode, ``runs.csv``), ``series`` (the first run's error series,
        by mode), ``runs_series`` (the error series of every Monte Carlo run, for the
        plots), ``summary`` (the tables, ``summary.json``) and whatever the paper's plots
        and files read."""

    def reproduce(self, scn, runs: int, seed: int, jobs: int = 1,
                  max_time: float | None = None, progress=None, campaign=None,
                  **options) -> dict:
        """Fly every unit (reusing those stored in ``campaign``) and summarize."""
        work = self.units(scn, runs, seed, max_time, **options)
        results = run_seeds([u.fn for u in work], [u.args for u in work], jobs, progress,
                            campaign, self.kernel_plan)
        return self.summarize(scn, runs, seed, max_time, results, **options)

    # ---------------------------------------------------------------------- outputs
    def print_summary(self, summary: dict, console) -> None:
        """The tables beside the paper's on the console."""
        from .report import print_tables

        print_tables(summary, self.titles, console)

    def plots(self, out: Path, rep: dict) -> list[Path]:
        """The paper's figures (default: every mode's errors over the Monte Carlo runs,
        ``rep["runs_series"]``, else the first run's, ``rep["series"]``)."""
        from .report import plot_errors

        runs = rep.get("runs_series") or ([rep["series"]] if rep.get("series") else [])
        return [plot_errors(runs, out / "errors.png", f"Paper {self.number}")] if runs else []

    def files(self, out: Path, rep: dict) -> list[Path]:
        """Data files beyond ``runs.csv`` (a sweep's runs, say)."""
        return []

    def write_outputs(self, out: Path, rep: dict) -> list[Path]:
        """``runs.csv``, the plots and files, then ``summary.json`` (listed first)."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        written = [write_frame(pd.DataFrame(rep["rows"]), out / "runs.csv")]
        written += self.files(out, rep) + self.plots(out, rep)
        summary = write_json(out / "summary.json", rep["summary"], why=NULL_REASONS)
        return [summary, *written]

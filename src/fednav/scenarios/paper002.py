"""Paper 002 — SINS/CNS/SAR for a cruise missile: Tables 2 and 3.

Statistic (paper): errors sampled every 1 s, absolute value averaged over the flight.
Columns: ``dlambda_m`` / ``dL_m`` = east / north position error [m], ``dVx_mps`` /
``dVy_mps`` = east / north velocity error [m/s], ``phiE/N/U_arcsec`` misalignment.
"""

from __future__ import annotations

from .. import units
from ..config import Scenario
from ..config import load_scenario as _load
from ..evaluation import error_stats
from ..montecarlo import run_seeds
from ..simulate import make_run_data, run_all_modes
from . import scenario_path

PAPER = "002"
ALIASES = ("002", "cruise-missile")

PAPER_TABLES = {
    "T2": {
        "SINS": {"dlambda_m": 267, "dL_m": 70.60, "dVx_mps": 0.20, "dVy_mps": 0.63},
        "SINS/SAR": {"dlambda_m": 0.89, "dL_m": 1.04, "dVx_mps": 0.019, "dVy_mps": 0.017},
        "SINS/CNS": {"dlambda_m": 24.8, "dL_m": 10.81, "dVx_mps": 0.024, "dVy_mps": 0.067},
        "SINS/CNS/SAR": {"dlambda_m": 0.79, "dL_m": 0.85, "dVx_mps": 0.013, "dVy_mps": 0.014},
    },
    "T3": {
        "SINS": {"phiE_arcsec": 10.56, "phiN_arcsec": 3.06, "phiU_arcsec": 2.51},
        "SINS/SAR": {"phiE_arcsec": 4.00, "phiN_arcsec": 2.78, "phiU_arcsec": 12.92},
        "SINS/CNS": {"phiE_arcsec": 0.64, "phiN_arcsec": 0.75, "phiU_arcsec": 0.73},
        "SINS/CNS/SAR": {"phiE_arcsec": 0.60, "phiN_arcsec": 0.73, "phiU_arcsec": 0.75},
    },
}
TABLE_TITLES = {
    "T2": "Table 2 — mean absolute position / velocity error",
    "T3": "Table 3 — mean absolute misalignment (arc-seconds)",
}


def load_scenario(path=None) -> Scenario:
    """The packaged paper-002 scenario (or another file with the same layout)."""
    return _load(path or scenario_path("paper002"))


def run_statistics(result) -> dict[str, float]:
    """Table columns of one mode of one run."""
    p = error_stats(result.pos)["mean_abs"]
    v = error_stats(result.vel)["mean_abs"]
    a = units.to_arcsec(error_stats(result.att)["mean_abs"])
    return {"dlambda_m": p[0], "dL_m": p[1], "dVx_mps": v[0], "dVy_mps": v[1],
            "phiE_arcsec": a[0], "phiN_arcsec": a[1], "phiU_arcsec": a[2]}


def one_run(args) -> tuple[list[dict], dict]:
    """All modes of one Monte Carlo run; returns per-mode statistics and the error series."""
    scn, seed, max_time = args
    series = run_all_modes(scn, make_run_data(scn, seed, max_time), max_time)
    rows = [{"seed": seed, "mode": k, **run_statistics(r)} for k, r in series.items()]
    return rows, series


def run_monte_carlo(scn: Scenario, runs: int, seed: int, jobs: int = 1,
                    max_time: float | None = None, progress=None):
    """Run ``runs`` Monte Carlo runs with seeds ``seed, seed+1, ...``.

    Returns (list of per-run rows, error series of the first run).
    """
    out = run_seeds(one_run, [(scn, seed + i, max_time) for i in range(runs)], jobs, progress)
    return [r for rows, _ in out for r in rows], out[0][1]


def reproduce(scn: Scenario, runs: int, seed: int, jobs: int = 1,
              max_time: float | None = None, progress=None) -> dict:
    """Monte Carlo reproduction: per-run rows, the first run's series and the summary."""
    from ..report import summarize

    rows, series = run_monte_carlo(scn, runs, seed, jobs, max_time, progress)
    return {"rows": rows, "series": series,
            "summary": summarize(rows, PAPER_TABLES, PAPER, runs, seed)}


def print_summary(summary: dict, console) -> None:
    from ..report import print_tables

    print_tables(summary, TABLE_TITLES, console)


def write_outputs(out, rep: dict) -> list:
    from ..report import write_outputs as _write

    return _write(out, rep["summary"], rep["rows"], rep["series"])


__all__ = ["ALIASES", "PAPER", "PAPER_TABLES", "TABLE_TITLES", "load_scenario",
           "print_summary", "reproduce", "run_monte_carlo", "run_statistics", "write_outputs"]

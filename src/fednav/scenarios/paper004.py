"""Paper 004 — INS/SAR with asynchronous, delayed measurements: Tables 1 and 2.

Statistics per run over the 1500 s flight (errors every 1 s): Table 1 the range
[min, max], Table 2 the standard deviation, of the east (``lon``) / north (``lat``) /
height position errors [m], the heading error [arc-minutes] and the east / north velocity
errors [m/s]; one row per delay strategy.  ``recompute`` (re-running the filter from the
capture epoch) is fednav's reference, not in the paper.  A second experiment sweeps the
SAR latencies (the decoded "1–6 s" / "1–4 s" are uncertain) and a third records the cost
of each strategy.
"""

from __future__ import annotations

import time

import numpy as np

from ..campaign.evaluation import mean_ci95
from ..campaign.paper import Paper, Unit
from ..core import plots, units
from ..core.atomic import write_frame
from ..sim.runs import make_run_data, run_configured_mode
from ..sim.scenario import Scenario
from ..sim.scenario import load_scenario as _load
from . import ALIASES as _REGISTRY
from . import scenario_path

PAPER = "004"
ALIASES = _REGISTRY[PAPER]
METHODS = ("uncompensated", "curve_fit", "ins_increment", "recompute")
QUANTITIES = (("lon", "m"), ("lat", "m"), ("h", "m"), ("yaw", "arcmin"), ("vE", "mps"),
              ("vN", "mps"))
T1_COLS = tuple(f"{q}_{s}_{u}" for q, u in QUANTITIES for s in ("min", "max"))
T2_COLS = tuple(f"{q}_std_{u}" for q, u in QUANTITIES)
_P1 = {  # Table 1 (paper): [min, max] per quantity
    "uncompensated": (-2539.61, 1655.47, -1855.55, 1990.48, -334.13, 28.51, -113.62, 147.72,
                      -18.86, 15.06, -26.88, 13.85),
    "ins_increment": (-36.77, 3.94, -16.15, 3.74, -18.13, 11.18, -1.83, 5.27, -0.45, 0.22,
                      -0.50, 0.21),
    "curve_fit": (-74.32, 68.82, -67.06, 58.17, -22.01, 18.42, -15.64, 23.27, -2.44, 1.26,
                  -2.87, 1.91),
}
_P2 = {
    "uncompensated": (762.90, 654.73, 95.10, 34.35, 3.81, 4.62),
    "ins_increment": (10.71, 4.56, 4.81, 1.20, 0.14, 0.10),
    "curve_fit": (21.07, 9.53, 4.96, 3.05, 0.30, 0.28),
}
PAPER_TABLES = {
    "T1": {m: dict(zip(T1_COLS, _P1.get(m, (None,) * 12), strict=True)) for m in METHODS},
    "T2": {m: dict(zip(T2_COLS, _P2.get(m, (None,) * 6), strict=True)) for m in METHODS},
}
TABLE_TITLES = {
    "T1": "Table 1 — error range over the flight (min, max)",
    "T2": "Table 2 — error standard deviation over the flight",
    "cost": "Cost — wall time of one 1500 s run (s)",
    "sweep": "Latency sweep — horizontal position error std (m) against the SAR latency "
             "(first min(runs, 4) seeds)",
}
#: Latency scale factors of the sweep (SAR [1, 6] s and velocity [1, 4] s times f).
SWEEP = (0.25, 0.5, 1.0, 1.5)


def load_scenario(path=None) -> Scenario:
    return _load(path or scenario_path("paper004"))


def error_table(result) -> np.ndarray:
    """(K, 6): east, north, up [m]; heading [arcmin]; vE, vN [m/s]."""
    return np.column_stack([result.pos, units.to_arcmin(result.euler[:, 2]),
                            result.vel[:, :2]])


def run_statistics(result) -> dict[str, float]:
    e = error_table(result)
    out = {}
    for j, (q, u) in enumerate(QUANTITIES):
        out[f"{q}_min_{u}"] = float(e[:, j].min())
        out[f"{q}_max_{u}"] = float(e[:, j].max())
        out[f"{q}_std_{u}"] = float(e[:, j].std())
    return out


def with_latency_scale(scn: Scenario, f: float) -> Scenario:
    """The scenario with every uniform SAR latency range multiplied by ``f``."""
    sensors = {}
    for name in ("sar", "sarvel"):
        cfg = scn.sensors[name]
        lo, hi = cfg.timing.latency_range_s
        sensors[name] = cfg.model_copy(update={"timing": cfg.timing.model_copy(
            update={"latency_range_s": (lo * f, hi * f)})})
    return scn.model_copy(update={"sensors": scn.sensors.replace(**sensors)})


def one_run(args):
    scn, seed, max_time = args
    data = make_run_data(scn, seed, max_time)
    rows, series = [], {}
    for m in scn.modes:
        t0 = time.perf_counter()
        r = run_configured_mode(scn, m, data, max_time)
        rows.append({"seed": seed, "mode": m.name, "time_s": time.perf_counter() - t0,
                     **run_statistics(r)})
        series[m.name] = r
    return rows, series


def sweep_run(args):
    scn, seed, max_time, f = args
    rows, _ = one_run((with_latency_scale(scn, f), seed, max_time))
    return [{"scale": f, "max_latency_s": f * 6.0, **r} for r in rows]


def _cost(rows) -> dict:
    import pandas as pd

    df = pd.DataFrame(rows)
    ref = df[df["mode"] == "ins_increment"]["time_s"].mean()
    out = {}
    for m, g in df.groupby("mode", sort=False):
        mean, h = mean_ci95(g["time_s"])
        out[m] = {"time_s": {"ours": mean, "ci95": h, "paper": None},
                  "x_ins_increment": {"ours": float(mean / ref), "ci95": None, "paper": None}}
    return out


def _sweep(rows) -> dict:
    import pandas as pd

    df = pd.DataFrame(rows)
    df["pos_std_m"] = np.hypot(df["lon_std_m"], df["lat_std_m"])
    out = {}
    for m, g in df.groupby("mode", sort=False):
        out[m] = {}
        for mx, gg in g.groupby("max_latency_s"):
            mean, h = mean_ci95(gg["pos_std_m"])
            out[m][f"pos_std_m@{mx:g}s"] = {"ours": mean, "ci95": h, "paper": None}
    return out


def sweep_figure(rows):
    """Horizontal position error std [m] against the SAR fix latency [s], per delay
    strategy (mean over the sweep's runs), as a :class:`~matplotlib.figure.Figure`: a
    log axis (the uncompensated filter is 100 times off), strategies that coincide drawn
    dashed over a wide solid line and named in a note, the legend beside the axes."""
    import pandas as pd
    from matplotlib.lines import Line2D

    df = pd.DataFrame(rows)
    df["pos_std_m"] = np.hypot(df["lon_std_m"], df["lat_std_m"])
    curves = {m: g.groupby("max_latency_s")["pos_std_m"].mean()
              for m, g in df.groupby("mode", sort=False)}
    values = {m: [c.to_numpy()] for m, c in curves.items()}
    groups = plots.coinciding_groups(values)
    styles = plots.mode_styles(list(curves), groups)
    fig, axes = plots.new_figure(1, 1, figsize=(8.5, 4.6))
    ax = axes[0, 0]
    for m, c in curves.items():
        st = styles[m]
        ax.semilogy(c.index, c.to_numpy(), marker="o", color=st["color"], ls=st["ls"],
                    lw=st["lw"], ms=7 - 2 * (st["ls"] != "-"))
    ax.set_xlabel("maximum SAR fix latency [s] (velocity: 2/3 of it)")
    ax.set_ylabel("horizontal position error std [m]")
    ax.grid(alpha=0.3, which="both")
    plots.legend_outside(fig, [Line2D([], [], marker="o", label=m, **styles[m])
                               for m in curves], x=0.74, y=0.9)
    plots.note(fig, plots.identical_note(groups, values, "latencies"))
    fig.suptitle("Paper 004: latency sweep", fontsize=11)
    fig.subplots_adjust(left=0.1, right=0.72, bottom=0.2, top=0.9)
    return fig


def plot_sweep(rows, path):
    """Write :func:`sweep_figure` to ``path``."""
    return plots.save(sweep_figure(rows), path)


class Paper004(Paper):
    """Paper 004 as a campaign: one unit per Monte Carlo run (every delay strategy on the
    run's data) and one per latency-sweep point and run (the first min(runs, 4) seeds)."""

    number = PAPER
    tables = PAPER_TABLES
    titles = TABLE_TITLES

    def load_scenario(self, path=None) -> Scenario:
        return load_scenario(path)

    def units(self, scn, runs, seed, max_time=None, **_) -> list[Unit]:
        return (self.per_seed(one_run, scn, runs, seed, max_time)
                + [u for f in SWEEP
                   for u in self.per_seed(sweep_run, scn, min(runs, 4), seed, max_time, f)])

    def summarize(self, scn, runs, seed, max_time, results, **_) -> dict:
        from ..campaign.report import summarize

        rows = [r for o in results[:runs] for r in o[0]]
        summary = summarize(rows, PAPER_TABLES, PAPER, runs, seed)
        summary["tables"]["cost"] = {"rows": _cost(rows)}
        sweep_rows = [r for o in results[runs:] for r in o]
        summary["tables"]["sweep"] = {"rows": _sweep(sweep_rows), "runs": min(runs, 4)}
        return {"rows": rows, "series": results[0][1],
                "runs_series": [o[1] for o in results[:runs]], "sweep_rows": sweep_rows,
                "summary": summary}

    def files(self, out, rep) -> list:
        import pandas as pd

        return [write_frame(pd.DataFrame(rep["sweep_rows"]), out / "sweep_runs.csv")]

    def plots(self, out, rep) -> list:
        return [*super().plots(out, rep), plot_sweep(rep["sweep_rows"],
                                                     out / "latency_sweep.png")]


EXPERIMENT = Paper004()
reproduce = EXPERIMENT.reproduce
print_summary = EXPERIMENT.print_summary
write_outputs = EXPERIMENT.write_outputs

__all__ = ["ALIASES", "EXPERIMENT", "PAPER", "PAPER_TABLES", "TABLE_TITLES", "load_scenario",
           "print_summary", "reproduce", "run_statistics", "write_outputs"]

"""Paper 000 — stratospheric airship: AEKF, RAUKF and CUKF without and with wind.

Table 1: mean and standard deviation over the 1000 s flight of the horizontal position
error norm [m] and the horizontal velocity error norm [m/s] (errors every 1 s), for each
filter without wind (``/none``) and with the wind field (``/wind``).  A second table,
``limitation``, shows the CUKF when the wind estimate feeding ``d`` is biased by 2 m/s,
and when the air data / wind estimate are noisier than the scenario's 0.02 m/s.
"""

from __future__ import annotations

import numpy as np

from ..campaign.paper import Paper, Unit
from ..core.atomic import save_figure
from ..sim.runs import make_run_data, run_configured_mode
from ..sim.scenario import Scenario
from ..sim.scenario import load_scenario as _load
from . import ALIASES as _REGISTRY
from . import scenario_path

PAPER = "000"
ALIASES = _REGISTRY[PAPER]
COLS = ("pos_mean_m", "vel_mean_mps", "pos_std_m", "vel_std_mps")
_P = {"AEKF/none": (2.37, 0.326, 1.53, 0.178), "AEKF/wind": (4.56, 0.496, 2.36, 0.361),
      "RAUKF/none": (1.50, 0.120, 0.50, 0.066), "RAUKF/wind": (3.01, 0.309, 1.56, 0.276),
      "CUKF/none": (1.63, 0.123, 0.51, 0.070), "CUKF/wind": (2.02, 0.151, 1.26, 0.121)}
PAPER_TABLES = {"T1": {k: dict(zip(COLS, v, strict=True)) for k, v in _P.items()}}
#: CUKF variants of the limitation experiment (all with wind): name -> air-data changes.
LIMITATION = {
    "CUKF/wind": {},
    "CUKF/wind, wind estimate +2 m/s east": {"wind_bias_mps": (2.0, 0.0)},
    "CUKF/wind, air data 0.05 m/s": {"sigma_airspeed_mps": 0.05, "wind_sigma_mps": 0.05},
    "CUKF/wind, air data 0.2 m/s": {"sigma_airspeed_mps": 0.2, "wind_sigma_mps": 0.2},
}
TABLE_TITLES = {
    "T1": "Table 1 — horizontal position / velocity error, mean and std over the flight",
    "limitation": "CUKF limitation — the constraint is only as good as d (wind on)",
}
WINDOW = (200.0, 800.0)


def load_scenario(path=None) -> Scenario:
    return _load(path or scenario_path("paper000"))


def variants(scn: Scenario) -> dict[str, Scenario]:
    """``none`` (no wind at all) and ``wind`` (the scenario's wind field)."""
    return {"none": scn.model_copy(update={"wind": None}), "wind": scn}


def with_air_data(scn: Scenario, **changes) -> Scenario:
    ad = scn.sensors.airdata.model_copy(update=changes)
    return scn.model_copy(update={"sensors": scn.sensors.replace(airdata=ad)})


def run_statistics(result) -> dict[str, float]:
    p = np.hypot(result.pos[:, 0], result.pos[:, 1])
    v = np.hypot(result.vel[:, 0], result.vel[:, 1])
    return {"pos_mean_m": float(p.mean()), "vel_mean_mps": float(v.mean()),
            "pos_std_m": float(p.std()), "vel_std_mps": float(v.std())}


def one_run(args):
    scn, seed, max_time = args
    rows, series = [], {}
    for wname, s in variants(scn).items():
        data = make_run_data(s, seed, max_time)
        for m in s.modes:
            r = run_configured_mode(s, m, data, max_time)
            name = f"{m.name}/{wname}"
            rows.append({"seed": seed, "mode": name, **run_statistics(r)})
            series[name] = r
    cukf = next(m for m in scn.modes if m.name == "CUKF")
    for name, changes in LIMITATION.items():
        if not changes:
            continue
        s = with_air_data(scn, **changes)
        r = run_configured_mode(s, cukf, make_run_data(s, seed, max_time), max_time)
        rows.append({"seed": seed, "mode": name, **run_statistics(r)})
        series[name] = r
    return rows, series


def plot_window(series: dict, path, window=WINDOW):
    """Horizontal position and velocity error norms over the wind window, every filter
    without and with wind (first Monte Carlo run)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(11, 7), sharex=True)
    for name, r in series.items():
        if name.count("/") != 1 or "," in name:
            continue
        m = (r.t >= window[0]) & (r.t <= window[1])
        ls = "-" if name.endswith("wind") else ":"
        axes[0].plot(r.t[m], np.hypot(r.pos[m, 0], r.pos[m, 1]), ls, lw=0.9, label=name)
        axes[1].plot(r.t[m], np.hypot(r.vel[m, 0], r.vel[m, 1]), ls, lw=0.9, label=name)
    axes[0].set_ylabel("horizontal position error [m]")
    axes[1].set_ylabel("horizontal velocity error [m/s]")
    axes[1].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, ncol=3)
    fig.suptitle(f"Errors during the wind window {window[0]:g}–{window[1]:g} s (first run)")
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
    return path


class Paper000(Paper):
    """Paper 000 as a campaign: one unit per Monte Carlo run (every filter without and
    with wind, and the CUKF limitation variants, on the run's data)."""

    number = PAPER
    tables = PAPER_TABLES
    titles = TABLE_TITLES

    def load_scenario(self, path=None) -> Scenario:
        return load_scenario(path)

    def units(self, scn, runs, seed, max_time=None, **_) -> list[Unit]:
        return self.per_seed(one_run, scn, runs, seed, max_time)

    def summarize(self, scn, runs, seed, max_time, results, **_) -> dict:
        from ..campaign.report import summarize

        rows = [r for o in results for r in o[0]]
        tables = dict(PAPER_TABLES)
        tables["limitation"] = {k: dict.fromkeys(COLS) for k in LIMITATION}
        tables["limitation"]["CUKF/wind"] = dict(PAPER_TABLES["T1"]["CUKF/wind"])
        return {"rows": rows, "series": results[0][1], "runs_series": [o[1] for o in results],
                "summary": summarize(rows, tables, PAPER, runs, seed)}

    def plots(self, out, rep) -> list:
        from ..campaign.report import plot_errors

        runs = [{k: v for k, v in s.items() if "," not in k} for s in rep["runs_series"]]
        return [plot_errors(runs, out / "errors.png", "Paper 000"),
                plot_window(rep["series"], out / "wind_window.png")]


EXPERIMENT = Paper000()
reproduce = EXPERIMENT.reproduce
print_summary = EXPERIMENT.print_summary
write_outputs = EXPERIMENT.write_outputs

__all__ = ["ALIASES", "EXPERIMENT", "PAPER", "PAPER_TABLES", "TABLE_TITLES", "load_scenario",
           "print_summary", "reproduce", "write_outputs"]

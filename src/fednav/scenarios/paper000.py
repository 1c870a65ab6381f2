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
from ..core import plots
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


def window_figure(runs_series, window=WINDOW):
    """Horizontal position and velocity error norms over the wind window, every filter
    without and with wind, as a :class:`~matplotlib.figure.Figure`: per mode the RMS over
    the Monte Carlo runs (line) and the 5-95 % band of the runs (shaded); modes that
    coincide drawn dashed over a wide solid line and named in a note."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    if isinstance(runs_series, dict):
        runs_series = [runs_series]
    modes = [k for k in runs_series[0] if k.count("/") == 1 and "," not in k]
    stats = {}
    for name in modes:
        res = [rs[name] for rs in runs_series if name in rs]
        n = min(len(r.t) for r in res)
        t = res[0].t[:n]
        m = (t >= window[0]) & (t <= window[1])
        stats[name] = (t[m], [plots.monte_carlo(np.stack([np.hypot(getattr(r, q)[:n, 0],
                                                                   getattr(r, q)[:n, 1])[m]
                                                          for r in res]))
                              for q in ("pos", "vel")], len(res))
    curves = {k: [a for p in v[1] for a in (p["rms"], p["lo"], p["hi"])]
              for k, v in stats.items()}
    groups = plots.coinciding_groups(curves)
    styles = plots.mode_styles(modes, groups)
    fig, axes = plots.new_figure(2, 1, figsize=(12, 7.5), sharex=True)
    for name, (t, panels, _) in stats.items():
        st = styles[name]
        for ax, p in zip(axes[:, 0], panels, strict=True):
            ax.fill_between(t, p["lo"], p["hi"], color=st["color"], alpha=0.1, lw=0)
            ax.plot(t, p["rms"], color=st["color"], ls=st["ls"], lw=st["lw"])
    axes[0, 0].set_ylabel("horizontal position error [m]")
    axes[1, 0].set_ylabel("horizontal velocity error [m/s]")
    axes[1, 0].set_xlabel("time [s]")
    for ax in axes[:, 0]:
        ax.set_ylim(bottom=0.0)
        ax.grid(alpha=0.3)
    runs = max(v[2] for v in stats.values()) if stats else 0
    handles = [Line2D([], [], color=styles[m]["color"], ls=styles[m]["ls"],
                      lw=styles[m]["lw"], label=m) for m in modes]
    handles += [Line2D([], [], color="k", lw=1.3,
                       label=f"RMS over {runs} run{'s' if runs != 1 else ''}"),
                Patch(facecolor="0.4", alpha=0.3, lw=0, label="5–95 % of the runs")]
    plots.legend_outside(fig, handles, x=0.8, y=0.9)
    plots.note(fig, plots.identical_note(groups, curves))
    fig.suptitle(f"Paper 000: horizontal errors during the wind window {window[0]:g}–"
                 f"{window[1]:g} s, {runs} Monte Carlo run{'s' if runs != 1 else ''}")
    fig.subplots_adjust(left=0.08, right=0.78, bottom=0.1, top=0.91, hspace=0.12)
    return fig


def plot_window(runs_series, path, window=WINDOW):
    """Write :func:`window_figure` to ``path``."""
    return plots.save(window_figure(runs_series, window), path)


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
                plot_window(rep["runs_series"], out / "wind_window.png")]


EXPERIMENT = Paper000()
reproduce = EXPERIMENT.reproduce
print_summary = EXPERIMENT.print_summary
write_outputs = EXPERIMENT.write_outputs

__all__ = ["ALIASES", "EXPERIMENT", "PAPER", "PAPER_TABLES", "TABLE_TITLES", "load_scenario",
           "print_summary", "reproduce", "write_outputs"]

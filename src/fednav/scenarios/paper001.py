"""Paper 001 — SINS/GPS/CNS in the launch inertial frame: federated PF vs federated EKF.

Tables:

* ``T1`` (the paper's Table 1): RMS error over the flight of the attitude error
  (misalignment, LI axes) [arcsec], position and velocity (LI axes) per run, mean over
  runs, for the federated PF (``PF``) and the federated EKF (``EKF``) on the same data;
* ``particles``: the federated PF with N = 100 ... 3000 particles per local filter — 3-D
  position RMS [m], 3-D attitude RMS [arcsec] (``sqrt(mean |e|^2)`` over the flight) and
  seconds per run;
* ``regime``: the same 3-D figures for PF and EKF under the scenario's ``regimes`` (large
  initial attitude errors with a late star sensor, sparse GPS, heavy-tailed GPS ...), and
  the fraction of runs in which each filter lost track (final 3-D position error above
  :data:`LOST_M`, or a filter failure).
"""

from __future__ import annotations

import numpy as np

from ..campaign.evaluation import mean_ci95
from ..campaign.paper import Paper, Unit
from ..core import plots, units
from ..filters import FilterError
from ..launch.navigate import make_data, run
from ..launch.scenario import LaunchScenario, load_launch_scenario
from . import ALIASES as _REGISTRY
from . import scenario_path

PAPER = "001"
ALIASES = _REGISTRY[PAPER]
COLS = ("att_x_arcsec", "att_y_arcsec", "att_z_arcsec", "pos_x_m", "pos_y_m", "pos_z_m",
        "vel_x_mps", "vel_y_mps", "vel_z_mps")
_P = {"PF": (4.731, 4.081, 4.790, 3.437, 2.363, 2.760, 0.095, 0.076, 0.047),
      "EKF": (6.808, 6.339, 7.249, 3.910, 3.043, 4.029, 0.145, 0.109, 0.152)}
PAPER_TABLES = {"T1": {k: dict(zip(COLS, v, strict=True)) for k, v in _P.items()}}
#: A run has "lost track" when its final 3-D position error exceeds this [m].
LOST_M = 1000.0
TABLE_TITLES = {
    "T1": "Table 1 — RMS error over the flight, federated PF vs federated EKF (LI axes)",
    "particles": "Federated PF: particles per local filter (3-D RMS over the flight)",
    "regime": "When does the PF pay? PF vs EKF under other conditions (3-D RMS)",
}


def load_scenario(path=None) -> LaunchScenario:
    return load_launch_scenario(path or scenario_path("paper001"))


def rms3(result) -> tuple[float, float]:
    """3-D RMS over the flight: position [m], attitude [arcsec]."""
    pos = float(np.sqrt((result.pos**2).sum(axis=1).mean()))
    att = float(np.sqrt((result.att**2).sum(axis=1).mean()) / units.ARCSEC)
    return pos, att


def _run(scn, data, kind, max_time, particles=None):
    """One filter run, or the FilterError that stopped it (a diverged or degenerate
    filter is a result of the experiment, recorded, not a crash of the reproduction)."""
    try:
        return run(scn, data, kind, max_time, particles=particles)
    except FilterError as e:
        return str(e)


def _failed(r) -> bool:
    return isinstance(r, str)


def _task(args):
    """One unit of work: ('T1', scn, seed) | ('particles', scn, seed, N) |
    ('regime', scn, seed, name)."""
    kind, scn, seed, extra, max_time = args
    data = make_data(scn, seed, max_time)
    nan = float("nan")
    if kind == "particles":
        r = _run(scn, data, "pf", max_time, particles=extra)
        pos, att = (nan, nan) if _failed(r) else rms3(r)
        return [{"table": kind, "seed": seed, "mode": f"N = {extra}", "pos_rms_m": pos,
                 "att_rms_arcsec": att,
                 "seconds_per_run": nan if _failed(r) else r.run_time_s,
                 "failure": r if _failed(r) else ""}], None
    res = {k: _run(scn, data, k, max_time) for k in ("pf", "ekf")}
    if kind == "T1":
        rows = [{"table": kind, "seed": seed, "mode": k.upper(),
                 **(dict.fromkeys(COLS, nan) if _failed(r) else r.rms()),
                 "seconds_per_run": nan if _failed(r) else r.run_time_s,
                 "min_ess": nan if _failed(r) else r.min_ess,
                 "failure": r if _failed(r) else ""}
                for k, r in res.items()]
        return rows, {k: r for k, r in res.items() if not _failed(r)}
    (pp, pa), (ep, ea) = ((nan, nan) if _failed(res[k]) else rms3(res[k])
                          for k in ("pf", "ekf"))
    lost = {k: 1.0 if _failed(r) or np.linalg.norm(r.pos[-1]) > LOST_M else 0.0
            for k, r in res.items()}
    fail = "; ".join(r for r in res.values() if _failed(r))
    return [{"table": kind, "seed": seed, "mode": extra, "pf_pos_rms_m": pp,
             "ekf_pos_rms_m": ep, "pf_att_rms_arcsec": pa, "ekf_att_rms_arcsec": ea,
             "pf_lost_fraction": lost["pf"], "ekf_lost_fraction": lost["ekf"],
             "failure": fail}], None


def tasks(scn: LaunchScenario, runs: int, seed: int, max_time=None,
          particles: int | None = None) -> list[tuple]:
    """Every unit of work of a reproduction, in a fixed order."""
    if particles is not None:
        scn = scn.model_copy(update={"filters": scn.filters.model_copy(
            update={"particles": particles})})
    out = [("T1", scn, seed + i, None, max_time) for i in range(runs)]
    for n in scn.particle_sweep:
        out += [("particles", scn, seed + i, n, max_time)
                for i in range(scn.particle_sweep_runs)]
    for reg in scn.regimes:
        s = scn.with_regime(reg)
        if particles is not None:
            s = s.model_copy(update={"filters": s.filters.model_copy(
                update={"particles": particles})})
        out += [("regime", s, seed + i, reg.name, max_time) for i in range(scn.regime_runs)]
    return out


def _table(rows: list[dict], table: str, cols: tuple[str, ...]) -> dict:
    out: dict[str, dict] = {}
    for r in rows:
        if r["table"] == table:
            out.setdefault(r["mode"], []).append(r)
    return {name: {c: dict(zip(("ours", "ci95"), mean_ci95([r[c] for r in rs]),
                               strict=True)) for c in cols}
            for name, rs in out.items()}


def _summarize(scn, runs, seed, max_time, results, particles=None) -> dict:
    from ..campaign.report import summarize

    rows = [r for o in results for r in o[0]]
    t1 = [r for r in rows if r["table"] == "T1"]
    summary = summarize(t1, PAPER_TABLES, PAPER, runs, seed)
    summary["particles_per_local_filter"] = particles or scn.filters.particles
    summary["tables"]["particles"] = {"runs": scn.particle_sweep_runs, "rows": _table(
        rows, "particles", ("pos_rms_m", "att_rms_arcsec", "seconds_per_run"))}
    summary["tables"]["regime"] = {"runs": scn.regime_runs, "rows": _table(
        rows, "regime", ("pf_pos_rms_m", "ekf_pos_rms_m", "pf_att_rms_arcsec",
                         "ekf_att_rms_arcsec", "pf_lost_fraction", "ekf_lost_fraction"))}
    summary["seconds_per_run"] = {k: mean_ci95([r["seconds_per_run"] for r in t1
                                                if r["mode"] == k])[0] for k in ("PF", "EKF")}
    #: Filter runs that stopped with a FilterError (left out of the means).
    summary["failures"] = [{"table": r["table"], "row": r["mode"], "seed": r["seed"],
                            "error": r["failure"]} for r in rows if r["failure"]]
    return {"rows": rows, "series": results[0][1], "summary": summary, "scenario": scn,
            "max_time": max_time, "runs_series": [o[1] for o in results[:runs] if o[1]]}


def _print_summary(summary: dict, console) -> None:
    from ..campaign.report import print_tables

    print_tables(summary, TABLE_TITLES, console)
    s = summary["seconds_per_run"]
    for f in summary["failures"]:
        console.print(f"[yellow]failed run[/] ({f['table']}, {f['row']}, seed {f['seed']}): "
                      f"{f['error']}")
    console.print(f"seconds per run: federated PF {s['PF']:.2f} "
                  f"({summary['particles_per_local_filter']} particles per local filter), "
                  f"federated EKF {s['EKF']:.2f}")


#: errors.png rows: LaunchResult attribute, first column of its sigma, factor from SI,
#: components (launch inertial frame), what, unit
_QUANTITIES = (("att", 0, 1.0 / units.ARCSEC, ("LI x", "LI y", "LI z"), "attitude error",
                "arcsec"),
               ("pos", 3, 1.0, ("LI x", "LI y", "LI z"), "position error", "m"),
               ("vel", 6, 1.0, ("LI x", "LI y", "LI z"), "velocity error", "m/s"))


def errors_figure(runs_series):
    """PF and EKF errors in the launch inertial frame over the Monte Carlo runs (Table 1's
    runs) as a :class:`~matplotlib.figure.Figure`: RMS over the runs, 5-95 % band, the
    fused filters' mean +-3 sigma (:func:`fednav.campaign.report.errors_figure`)."""
    from ..campaign.report import errors_figure as mc_errors

    if isinstance(runs_series, dict):
        runs_series = [runs_series]
    runs = [{k.upper(): v for k, v in rs.items()} for rs in runs_series if rs]
    return mc_errors(runs, "Paper 001, launch inertial frame", _QUANTITIES,
                     "time since launch [s]")


def plot_errors(runs_series, path):
    """Write :func:`errors_figure` to ``path``."""
    return plots.save(errors_figure(runs_series), path)


def ascent_figure(scn: LaunchScenario, max_time=None):
    """The ascent as a :class:`~matplotlib.figure.Figure`: trajectory in the launch
    plane; height [km] and speed [km/s] on two y axes; pitch and yaw programmes [deg] on
    two y axes; thrust acceleration [m/s²]."""
    from matplotlib.lines import Line2D

    tr = scn.trajectory(max_time)
    prof = scn.profile(max_time)
    lla = tr.lla()
    phi, psi, _, _ = prof.angles(tr.t)
    fig, ax = plots.new_figure(2, 2, figsize=(13, 8.5))
    c = plots.colors()

    def twin(a, x, y1, y2, label1, label2):
        """``y1`` on ``a``'s axis, ``y2`` on a second y axis; labels coloured as lines."""
        a2 = a.twinx()
        a.plot(x, y1, color=c[0], lw=1.5)
        a2.plot(x, y2, color=c[1], lw=1.5, ls="--")
        a.set_ylabel(label1, color=c[0])
        a2.set_ylabel(label2, color=c[1])
        a.tick_params(axis="y", colors=c[0])
        a2.tick_params(axis="y", colors=c[1])
        a.legend(handles=[Line2D([], [], color=c[0], lw=1.5, label=label1),
                          Line2D([], [], color=c[1], lw=1.5, ls="--", label=label2)],
                 loc="upper left", fontsize=8.5, framealpha=0.9)
        a.set_xlabel("time since launch [s]")
        return a2

    a = ax[0, 0]
    a.plot(tr.r[:, 0] / 1e3, tr.r[:, 1] / 1e3, color=c[0], label="y (up, launch plane)")
    a.plot(tr.r[:, 0] / 1e3, tr.r[:, 2] / 1e3, color=c[2], ls="--",
           label="z (out of plane)")
    a.set_xlabel("LI x, downrange [km]")
    a.set_ylabel("LI y / z [km]")
    a.set_title("trajectory in the launch inertial frame", fontsize=10)
    a.legend(loc="upper left", fontsize=8.5)
    twin(ax[0, 1], tr.t, lla[:, 2] / 1e3, np.linalg.norm(tr.v, axis=1) / 1e3,
         "height [km]", "LI speed [km/s]")
    ax[0, 1].set_title("height and speed", fontsize=10)
    twin(ax[1, 0], tr.t, units.to_deg(phi), units.to_deg(psi), "pitch programme φ [deg]",
         "yaw programme ψ [deg]")
    ax[1, 0].set_title("attitude programme", fontsize=10)
    a = ax[1, 1]
    a.plot(tr.t, prof.thrust(tr.t), color=c[3])
    a.set_xlabel("time since launch [s]")
    a.set_ylabel("thrust acceleration [m/s²]")
    a.set_title("thrust", fontsize=10)
    for a in ax.ravel():
        a.grid(alpha=0.3)
    fig.suptitle(f"Paper 001 ascent: {scn.launch.lat_deg}°N {scn.launch.lon_deg}°E, "
                 f"azimuth {scn.launch.azimuth_deg}°, LI frame x downrange, y up, z = x × y")
    fig.subplots_adjust(left=0.07, right=0.93, bottom=0.07, top=0.91, wspace=0.38,
                        hspace=0.32)
    return fig


def plot_ascent(scn: LaunchScenario, path, max_time=None):
    """Write :func:`ascent_figure` to ``path``."""
    return plots.save(ascent_figure(scn, max_time), path)


class Paper001(Paper):
    """Paper 001 as a campaign: one unit per (table, run): Table 1's PF and EKF runs, the
    particle sweep, the regimes."""

    number = PAPER
    tables = PAPER_TABLES
    titles = TABLE_TITLES
    options = ("particles",)

    def load_scenario(self, path=None) -> LaunchScenario:
        return load_scenario(path)

    def units(self, scn, runs, seed, max_time=None, particles=None, **_) -> list[Unit]:
        return [Unit(_task, t) for t in tasks(scn, runs, seed, max_time, particles)]

    def summarize(self, scn, runs, seed, max_time, results, particles=None, **_) -> dict:
        return _summarize(scn, runs, seed, max_time, results, particles)

    def print_summary(self, summary, console) -> None:
        _print_summary(summary, console)

    def plots(self, out, rep) -> list:
        return [plot_errors(rep.get("runs_series") or [rep["series"]], out / "errors.png"),
                plot_ascent(rep["scenario"], out / "ascent.png", rep["max_time"])]


EXPERIMENT = Paper001()
reproduce = EXPERIMENT.reproduce
print_summary = EXPERIMENT.print_summary
write_outputs = EXPERIMENT.write_outputs

__all__ = ["ALIASES", "EXPERIMENT", "PAPER", "PAPER_TABLES", "TABLE_TITLES", "load_scenario",
           "print_summary", "reproduce", "write_outputs"]

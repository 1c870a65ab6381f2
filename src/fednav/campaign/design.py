"""A user's own design as a Monte Carlo campaign: ``fednav run SCENARIO.yaml``.

A *design* is a scenario file of the papers' layout (:class:`~fednav.sim.scenario.Scenario`:
the flight, the IMU, the sensors, the filter, the modes to compare, the simulated errors;
``docs/designs.md`` documents it key by key) without a paper to compare with.
:class:`Design` is the :class:`~fednav.campaign.paper.Paper` experiment of any such
file, so ``fednav run`` gets the campaign machinery of ``fednav reproduce``: the
resumable store (campaign identity ``design:<name>``), local processes or Dask, the
progress bar, ``runs.csv``, ``summary.json`` and ``report.html``.

**Units of work.**  One per Monte Carlo run (seed ``seed + i``): the run's data drawn
once (:func:`~fednav.sim.runs.make_run_data`) and every mode flown on it
(:func:`~fednav.sim.runs.run_all_modes`, common random numbers: the modes differ only by
their aiding and filter).

**Statistics of one run** (at the statistics epochs, every ``stats_period_s``), for each
error quantity — horizontal position error ``hypot(east, north)`` [m], height error [m],
velocity error (3-D norm) [m/s], pitch, roll and heading errors (Euler angles, estimated
minus true) [deg]: ``rmse`` (root mean square over the epochs), ``mean`` (mean absolute
value), ``max`` (largest absolute value).  They are computed over the whole flight
(table ``flight``) and over each outage window of the sensors' ``outages_s`` (tables
``outage_<start>_<end>s``: the epochs ``start <= t < end``).  ``nis_per_dof.<local>``:
the mean over the run of each local filter's normalised innovation squared divided by
its degrees of freedom over every measurement, against the innovation covariance of the
equivalent centralized filter (about 1 for a filter whose covariance matches its errors;
:func:`fednav.navigator.health.local_nis`); ``gate_nis_per_dof.<local>``:
the local filter's own, which its chi-square gate tests (smaller in a federation that
shares out its information).

**Tables** (``summary.json``): each cell is the Monte Carlo mean of a per-run statistic
(``value``) and the half-width of its 95 % confidence interval (``ci95``, Student t over
the runs; null with a single run).  Non-finite numbers are written as null: the JSON
never holds NaN.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..core import units
from ..core.atomic import json_safe, save_figure, write_frame, write_json, write_text
from ..core.config import recording_only_keys
from ..sim.runs import make_run_data, run_all_modes
from ..sim.scenario import Scenario, load_scenario
from .evaluation import mean_ci95
from .paper import Paper, Unit

#: Error quantities of the tables: key (unit in the name) -> heading.
QUANTITIES = {
    "horizontal_position_m": "horizontal position [m]",
    "height_m": "height [m]",
    "velocity_mps": "velocity, 3-D [m/s]",
    "pitch_deg": "pitch [deg]",
    "roll_deg": "roll [deg]",
    "heading_deg": "heading [deg]",
}
#: Statistics over the epochs of one run.
STATS = ("rmse", "mean", "max")
#: The campaign store's identity of a design: this prefix and the scenario's ``name``.
IDENTITY_PREFIX = "design:"


# ------------------------------------------------------------------------ statistics
def ci95(values) -> tuple[float | None, float | None]:
    """Monte Carlo mean of ``values`` and the half-width of its 95 % confidence interval
    (Student t with n - 1 degrees of freedom), non-finite values left out; None for what
    cannot be computed (no finite value; a single value has no interval)."""
    m, h = mean_ci95(values)
    return _finite(m), _finite(h)


def _finite(x) -> float | None:
    """``x`` as a float, or None when it is missing or not finite (JSON has no NaN)."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def error_series(result) -> dict[str, np.ndarray]:
    """Absolute error of each quantity of :data:`QUANTITIES` at the result's epochs
    (K,): horizontal position and height [m], velocity norm [m/s], pitch, roll and
    heading errors [deg]."""
    e = np.abs(units.to_deg(result.euler))
    return {"horizontal_position_m": np.hypot(result.pos[:, 0], result.pos[:, 1]),
            "height_m": np.abs(result.pos[:, 2]),
            "velocity_mps": np.linalg.norm(result.vel, axis=1),
            "pitch_deg": e[:, 0], "roll_deg": e[:, 1], "heading_deg": e[:, 2]}


def _stats(x: np.ndarray) -> dict[str, float]:
    """rmse, mean, max of absolute errors ``x`` (NaN when there are none)."""
    if x.size == 0:
        return dict.fromkeys(STATS, float("nan"))
    return {"rmse": float(np.sqrt(np.mean(x * x))), "mean": float(x.mean()),
            "max": float(x.max())}


def outage_windows(scn: Scenario, max_time: float | None = None) -> list[dict]:
    """The sensors' outage windows inside the flight flown: ``key`` (the table's name),
    ``sensors`` (those out in exactly this window), ``start_s`` and ``end_s`` (clipped to
    the flight)."""
    end = scn.duration if max_time is None else min(scn.duration, max_time)
    spans: dict[tuple[float, float], list[str]] = {}
    for name in scn.sensors:
        for a, b in scn.sensors[name].outages_s:
            spans.setdefault((float(a), float(b)), []).append(name)
    out = []
    for (a, b), names in sorted(spans.items()):
        if a >= end or b <= 0.0:
            continue
        out.append({"key": f"outage_{a:g}_{b:g}s", "sensors": names,
                    "start_s": max(a, 0.0), "end_s": min(b, end)})
    return out


def run_statistics(result, windows: list[dict]) -> dict[str, float]:
    """One mode of one run: ``<table>.<quantity>.<stat>`` for the whole flight
    (``flight``) and each outage window, and ``nis_per_dof.<local>`` per local filter."""
    series = error_series(result)
    row = {}
    spans = [("flight", np.ones(len(result.t), dtype=bool))] + [
        (w["key"], (result.t >= w["start_s"]) & (result.t < w["end_s"])) for w in windows]
    for key, sel in spans:
        for q, x in series.items():
            for s, v in _stats(x[sel]).items():
                row[f"{key}.{q}.{s}"] = v
    if result.fdi is not None and len(result.fdi):
        f = result.fdi
        ratio = (f["statistic"] / f["dof"]).to_numpy()
        central = result.nis or {}
        for local in dict.fromkeys(f["local"]):
            gate = float(np.mean(ratio[(f["local"] == local).to_numpy()]))
            row[f"nis_per_dof.{local}"] = central.get(local, gate)
            row[f"gate_nis_per_dof.{local}"] = gate
    return row


def one_run(args) -> tuple[list[dict], dict]:
    """Unit of work: every mode of the design on run ``seed``'s data.  Returns the
    per-mode statistics rows and the error series by mode (without the per-measurement
    fault-detection log, summarised in the rows as NIS/dof)."""
    scn, seed, max_time = args
    data = make_run_data(scn, seed, max_time)
    series = run_all_modes(scn, data, max_time, innovations=True)
    windows = outage_windows(scn, max_time)
    rows = [{"seed": seed, "mode": m, **run_statistics(r, windows)} for m, r in series.items()]
    out = {m: replace(r, fdi=None, nis=None) for m, r in series.items()}
    if scn.integrity is None:
        return rows, out
    from . import integrity as ig

    counts = {}
    for row, mode in zip(rows, scn.modes, strict=True):
        got = ig.mode_levels(scn, mode, data, series[mode.name], max_time)
        if got is not None:
            extra, counts[mode.name] = ig.run_row(got[1], got[0], data.faults)
            row.update(extra)
    return rows, out, counts


def summarize_rows(rows: list[dict], modes: list[str], windows: list[dict],
                   runs: int) -> dict:
    """The tables from the per-run rows: ``flight`` and each outage window (mode ->
    quantity -> statistic -> {value, ci95}) and ``consistency`` (mode -> local filter ->
    {nis_per_dof: {value, ci95}})."""
    import pandas as pd

    df = pd.DataFrame(rows)
    tables = {}
    heads = [("flight", "Errors over the whole run")] + [
        (w["key"], f"Errors during the {' and '.join(w['sensors'])} outage "
                   f"({w['start_s']:g}-{w['end_s']:g} s)") for w in windows]
    for key, title in heads:
        t_rows = {}
        for m in modes:
            sub = df[df["mode"] == m]
            t_rows[m] = {q: {s: _cell(sub.get(f"{key}.{q}.{s}")) for s in STATS}
                         for q in QUANTITIES}
        tables[key] = {"title": f"{title}: RMSE, mean and max of the absolute error",
                       "runs": runs, "rows": t_rows}
    nis = {}
    for m in modes:
        sub = df[df["mode"] == m]
        cols = [c for c in sub.columns if c.startswith("nis_per_dof.")
                and sub[c].notna().any()]
        if cols:
            nis[m] = {c.split(".", 1)[1]: {"nis_per_dof": _cell(sub[c])} for c in cols}
    if nis:
        tables["consistency"] = {"title": "Filter consistency: mean NIS / dof of each "
                                          "local filter (about 1 when consistent)",
                                 "runs": runs, "rows": nis}
    return tables


def _cell(values) -> dict:
    if values is None:
        return {"value": None, "ci95": None}
    m, h = ci95(np.asarray(values, dtype=float))
    return {"value": m, "ci95": h}




# ----------------------------------------------------------------------- the experiment
class Design(Paper):
    """A user's design (any scenario file of the papers' layout) as a campaign: one unit
    of work per Monte Carlo run, the error tables with 95 % confidence intervals, the
    error plot with the Monte Carlo spread."""

    number = "design"
    titles: dict = {}

    def load_scenario(self, path=None) -> Scenario:
        if path is None:
            raise ValueError("a design needs its scenario file")
        scn = load_scenario(path)
        unused = recording_only_keys(scn)
        if unused:
            warnings.warn(f"{path}: {', '.join(unused)}: not used by fednav run (a "
                          f"simulated flight)", stacklevel=2)
        if scn.fault_experiment is not None:
            warnings.warn(f"{path}: fault_experiment is paper 003's second experiment; "
                          f"fednav run ignores it (faults: applies to every run)",
                          stacklevel=2)
        return scn

    @staticmethod
    def check(scn: Scenario, path, max_time: float | None = None) -> None:
        """Refuse in one line (:class:`~fednav.core.config.ConfigError`) what validation
        of the file alone cannot see: two modes of one name, a trajectory that cannot be
        flown (a segment that is not a whole number of IMU samples, a speed going
        negative) and a filter period that is not a whole number of IMU periods.  The
        trajectory computed here is the one the runs use (cached in this process; local
        workers inherit it)."""
        from ..core.config import ConfigError

        names = [m.name for m in scn.modes]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ConfigError(f"scenario file {path}: key 'modes': mode name "
                              f"'{twice[0]}' is used twice (each mode is a table row)")
        dt, T = scn.imu_period_s, scn.filter.period_s
        if abs(round(T / dt) * dt - T) > 1e-9 or round(T / dt) < 1:
            raise ConfigError(f"scenario file {path}: key 'filter.period_s': {T} s is not "
                              f"a whole number of IMU periods ({dt} s)")
        try:
            scn.trajectory(max_time)
        except ValueError as e:
            raise ConfigError(f"scenario file {path}: key 'segments': {e}") from None

    @staticmethod
    def identity(scn: Scenario) -> str:
        """The campaign store's name of the design (``design:<name>``)."""
        return f"{IDENTITY_PREFIX}{scn.name}"

    def units(self, scn, runs, seed, max_time=None, **_) -> list[Unit]:
        return self.per_seed(one_run, scn, runs, seed, max_time)

    def summarize(self, scn, runs, seed, max_time, results, **_) -> dict:
        rows = [r for o in results for r in o[0]]
        runs_series = [o[1] for o in results]
        modes = [m.name for m in scn.modes]
        windows = outage_windows(scn, max_time)
        flown = scn.duration if max_time is None else min(scn.duration, max_time)
        summary = {
            "design": scn.name, "description": scn.description.strip(),
            "runs": runs, "seed": seed, "max_time_s": max_time, "duration_s": flown,
            "modes": [{"name": m.name, "aiding": list(m.aiding),
                       "filter": m.filter or scn.filter.type} for m in scn.modes],
            "outage_windows": windows,
            "quantities": dict(QUANTITIES),
            "statistics": "value: Monte Carlo mean over the runs of the per-run statistic "
                          "(rmse / mean / max of the absolute error over the epochs, or "
                          "the run's mean NIS/dof); ci95: half-width of its 95 % "
                          "Student-t confidence interval (null with one run); value null "
                          "when no run has a finite value (a window outside the flight "
                          "flown)",
            "tables": summarize_rows(rows, modes, windows, runs),
        }
        integrity = {}
        if scn.integrity is not None:
            from . import integrity as ig

            integrity = ig.summarize(rows, [o[2] for o in results if len(o) > 2], modes,
                                     scn.integrity)
            summary["integrity"] = {m: {k: v for k, v in s.items() if k != "_counts"}
                                    for m, s in integrity.items()}
        return {"rows": rows, "series": runs_series[0], "runs_series": runs_series,
                "windows": windows, "summary": json_safe(summary), "integrity": integrity}

    # ---------------------------------------------------------------------- outputs
    def print_summary(self, summary: dict, console) -> None:
        print_design_tables(summary, console)
        if summary.get("integrity"):
            from rich.markup import escape

            from .integrity import integrity_lines

            console.print("[bold]Integrity: protection levels against the truth[/]\n"
                          + "\n".join(escape(x) for x in
                                      integrity_lines(summary["integrity"])),
                          highlight=False)

    def plots(self, out: Path, rep: dict) -> list[Path]:
        figs = [plot_spread(rep["runs_series"], rep["windows"], out / "errors.png",
                            rep["summary"]["design"])]
        if any(s.get("_counts") is not None for s in rep.get("integrity", {}).values()):
            from .integrity import stanford_figure

            figs.append(save_figure(stanford_figure(rep["integrity"],
                                                    rep["summary"]["design"]),
                                    out / "stanford.png"))
        return figs

    def files(self, out: Path, rep: dict) -> list[Path]:
        frame = tables_frame(rep["summary"])
        text = tables_markdown(rep["summary"])
        if rep["summary"].get("integrity"):
            from .integrity import integrity_lines

            text += ("\n## Integrity: protection levels against the truth\n\n```\n"
                     + "\n".join(integrity_lines(rep["summary"]["integrity"])) + "\n```\n")
        return [write_frame(frame, out / "tables.csv"), write_text(out / "tables.md", text)]

    def write_outputs(self, out: Path, rep: dict) -> list[Path]:
        """As :meth:`Paper.write_outputs`, with a ``summary.json`` that cannot hold NaN."""
        import pandas as pd

        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        written = [write_frame(pd.DataFrame(rep["rows"]), out / "runs.csv")]
        written += self.files(out, rep) + self.plots(out, rep)
        return [write_json(out / "summary.json", rep["summary"]), *written]


DESIGN = Design()


# --------------------------------------------------------------------------- tables
def _cells(summary: dict):
    """(table, mode, quantity, statistic, cell) for every cell of the summary."""
    for tname, t in summary["tables"].items():
        for mode, qs in t["rows"].items():
            for q, stats in qs.items():
                for s, cell in stats.items():
                    yield tname, mode, q, s, cell


def tables_frame(summary: dict):
    """Every table cell as one row: table, mode, quantity, statistic, value, ci95, runs."""
    import pandas as pd

    return pd.DataFrame([{"table": t, "mode": m, "quantity": q, "statistic": s,
                          "value": c["value"], "ci95": c["ci95"],
                          "runs": summary["tables"][t]["runs"]}
                         for t, m, q, s, c in _cells(summary)])


def _formatter(q: str, value):
    """``(x, fmt) -> text`` for the figures of a cell of quantity ``q`` holding ``value``:
    an attitude in the value's unit (:func:`~fednav.campaign.numbers.format_attitude`:
    arc-seconds below 0.01°), anything else ``fmt(x)``."""
    from .numbers import format_attitude, is_attitude_deg

    if is_attitude_deg(q):
        return lambda x, fmt: format_attitude(x, unit_of=value, fmt=fmt)
    return lambda x, fmt: fmt(x)


def _pm(cell: dict, q: str = "") -> str:
    from .numbers import format_number

    v, h = cell.get("value"), cell.get("ci95")
    num = _formatter(q, v)
    return (num(v, format_number) if h is None
            else f"{num(v, format_number)} ± {num(h, format_number)}")


def _columns(table: dict) -> list[str]:
    cols: list[str] = []
    for qs in table["rows"].values():
        for stats in qs.values():
            cols += [s for s in stats if s not in cols]
    return cols


def _label(q: str) -> str:
    return QUANTITIES.get(q, q)


def tables_markdown(summary: dict) -> str:
    """The tables as Markdown (value ± 95 % CI half-width)."""
    lines = [f"# {summary['design']}: {summary['runs']} Monte Carlo runs (seed "
             f"{summary['seed']})", "", "value ± half-width of the 95 % confidence "
             "interval of the Monte Carlo mean (no interval with one run).", ""]
    for t in summary["tables"].values():
        cols = _columns(t)
        lines += [f"## {t['title']}", "", "| mode | quantity | " + " | ".join(cols) + " |",
                  "|---|---|" + "---:|" * len(cols)]
        for mode, qs in t["rows"].items():
            for q, stats in qs.items():
                lines.append(f"| {mode} | {_label(q)} | "
                             + " | ".join(_pm(stats[c], q) if c in stats else ""
                                          for c in cols)
                             + " |")
        lines.append("")
    return "\n".join(lines)


#: Short quantity labels for the console.
SHORT = {"horizontal_position_m": "horizontal [m]", "height_m": "height [m]",
         "velocity_mps": "velocity [m/s]", "pitch_deg": "pitch [deg]",
         "roll_deg": "roll [deg]", "heading_deg": "heading [deg]"}


def _short_pm(cell: dict, q: str = "") -> str:
    """``value ±ci`` with the half-width to two significant figures (console); an
    attitude in arc-seconds below 0.01° (:func:`_formatter`)."""
    from .numbers import format_number

    v, h = cell.get("value"), cell.get("ci95")
    num = _formatter(q, v)
    return num(v, format_number) if h is None else f"{num(v, format_number)} ±{num(h, _two)}"


def _two(h: float) -> str:
    """A half-width to two significant figures (whole from 10 up)."""
    from .numbers import format_number

    return format_number(h) if abs(h) >= 10 else f"{h:#.2g}".rstrip(".")


def print_design_tables(summary: dict, console) -> None:
    """Each table on the console: a line per mode, then a line per quantity (or local
    filter) with value ± 95 % CI per statistic (fits 80 columns).  Each title is printed
    as its own lines above its table, as the paper campaigns' (a rich table title wraps
    to the table's width: at 46 columns, piped or not)."""
    from rich.markup import escape
    from rich.table import Table

    for t in summary["tables"].values():
        cols = _columns(t)
        nis = cols == ["nis_per_dof"]
        console.print(f"[bold]{escape(t['title'])}[/]\nMonte Carlo mean ±95% CI over "
                      f"{t['runs']} runs (seed {summary['seed']})", highlight=False)
        tab = Table()
        tab.add_column("mode / local filter" if nis else "mode / quantity", no_wrap=True)
        for c in cols:
            tab.add_column("NIS/dof" if nis else c.upper() if c == "rmse" else c,
                           justify="right", no_wrap=True)
        for mode, qs in t["rows"].items():
            tab.add_row(f"[bold]{escape(mode)}[/]", *[""] * len(cols))
            items = list(qs.items())
            for i, (q, stats) in enumerate(items):
                tab.add_row("  " + escape(SHORT.get(q, q)),
                            *[_short_pm(stats[c], q) if c in stats else "" for c in cols],
                            end_section=(i == len(items) - 1))
        console.print(tab)


# ----------------------------------------------------------------------------- plots
def spread_arrays(runs_series: list[dict], mode: str) -> dict:
    """One mode's errors over the runs: ``t`` (K,), and per panel (horizontal position
    [m], height [m], heading [deg]) the absolute errors (runs, K) and the mean over the
    runs of the filter's 1-sigma (K,) — horizontal ``hypot(sigma_E, sigma_N)``, up, and
    the azimuth misalignment phiU (the heading error's 1-sigma for near-level attitude);
    NaN without a filter."""
    res = [rs[mode] for rs in runs_series if mode in rs]
    n = min(len(r.t) for r in res)
    err = [error_series(r) for r in res]
    sig = np.stack([r.sigma[:n] for r in res])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN sigma (free INS)
        sig_h = np.nanmean(np.hypot(sig[..., 6], sig[..., 7]), axis=0)
        sig_u = np.nanmean(sig[..., 8], axis=0)
        sig_psi = units.to_deg(np.nanmean(sig[..., 2], axis=0))
    return {"t": res[0].t[:n],
            "horizontal_position_m": (np.stack([e["horizontal_position_m"][:n]
                                                for e in err]), sig_h),
            "height_m": (np.stack([e["height_m"][:n] for e in err]), sig_u),
            "heading_deg": (np.stack([e["heading_deg"][:n] for e in err]), sig_psi)}


def spread_figure(runs_series: list[dict], windows: list[dict], name: str = ""):
    """``errors.png`` of a design as a :class:`~matplotlib.figure.Figure`: horizontal
    position [m], height [m] and heading [deg] errors versus time [s] on linear axes from
    zero — per mode the median over the Monte Carlo runs of the absolute error (line), its
    5-95 % band (shaded) and the mean filter 1-sigma (dotted); outage windows shaded grey;
    one legend beside the axes; modes whose medians coincide drawn distinguishably
    (:func:`fednav.core.plots.mode_styles`) and named in a note.  The scale is set by
    the modes' robust scales (a start-up transient does not set it); a mode over 30 times
    the others' (a free INS) runs off the axes and a note under the figure says how
    far."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    from ..core import plots
    from .numbers import format_number

    modes = list(runs_series[0])
    panels = (("horizontal_position_m", "horizontal position error", "m"),
              ("height_m", "height error", "m"), ("heading_deg", "heading error", "deg"))
    spread = {m: spread_arrays(runs_series, m) for m in modes}
    q = {m: {key: np.percentile(a[key][0], [5, 50, 95], axis=0) for key, _, _ in panels}
         for m, a in spread.items()}
    # modes whose medians coincide in every panel are drawn distinguishably and named
    curves = {m: [q[m][key][1] for key, _, _ in panels] for m in modes}
    groups = plots.coinciding_groups(curves)
    styles = plots.mode_styles(modes, groups)
    fig, axes = plots.new_figure(3, 1, figsize=(13, 9.5), sharex=True)
    axes = axes[:, 0]
    scales: list[dict[str, float]] = [{}, {}, {}]
    peaks: list[dict[str, float]] = [{}, {}, {}]
    for m in modes:
        a, st = spread[m], styles[m]
        for j, (ax, (key, _, _)) in enumerate(zip(axes, panels, strict=True)):
            sig = a[key][1]
            lo, med, hi = q[m][key]
            ax.fill_between(a["t"], lo, hi, color=st["color"], alpha=0.18, lw=0)
            ax.plot(a["t"], med, color=st["color"], ls=st["ls"], lw=st["lw"])
            arrays = [med, hi]
            if np.isfinite(sig).any():
                ax.plot(a["t"], sig, color=st["color"], lw=1.0, ls=(0, (2, 2)), gid="sigma")
                arrays.append(sig)
            scales[j][m] = max(plots.robust_scale(v) for v in arrays)
            peaks[j][m] = float(np.nanmax(med))
    off: dict[str, list[str]] = {}
    for ax, (_, label, unit), sc, pk in zip(axes, panels, scales, peaks, strict=True):
        for w in windows:
            ax.axvspan(w["start_s"], w["end_s"], facecolor="0.5", alpha=0.15, lw=0)
        lim, gone = plots.shared_limit(sc)
        ax.set_ylim(0.0, lim)
        for m in gone:
            off.setdefault(m, []).append(f"{label.split(' error')[0]} up to "
                                         f"{format_number(pk[m])} {unit}")
        ax.set_ylabel(f"{label} [{unit}]")
        ax.grid(alpha=0.3, lw=0.5)
    axes[-1].set_xlabel("time [s]")
    runs = len(runs_series)
    handles = [Line2D([], [], color=styles[m]["color"], ls=styles[m]["ls"],
                      lw=styles[m]["lw"], label=m) for m in modes]
    handles += [Line2D([], [], color="k", lw=1.1, label="median over runs"),
                Patch(facecolor="0.35", alpha=0.45, label="5-95 % of runs"),
                Line2D([], [], color="k", lw=1.0, ls=(0, (2, 2)),
                       label="filter 1-σ\n(mean over runs)")]
    if windows:
        out = sorted({s for w in windows for s in w["sensors"]})
        handles.append(Patch(facecolor="0.92", edgecolor="0.6", lw=0.8,
                             label=f"outage: {', '.join(out)}"))
    plots.legend_outside(fig, handles, x=0.79, y=0.93, fontsize=9)
    notes = [plots.identical_note(groups, curves, "samples")]
    notes += [f"off the axes: {m} (median {', '.join(v)})" for m, v in off.items()]
    plots.note(fig, "\n".join(n for n in notes if n))
    fig.suptitle(f"{name}: absolute errors over {runs} Monte Carlo run"
                 f"{'s' if runs != 1 else ''}")
    fig.subplots_adjust(left=0.07, right=0.78, bottom=0.07, top=0.94, hspace=0.08)
    return fig


def plot_spread(runs_series: list[dict], windows: list[dict], path: Path,
                name: str = "") -> Path:
    """Write :func:`spread_figure` to ``path`` (``errors.png`` of ``fednav run``)."""
    save_figure(spread_figure(runs_series, windows, name), path)
    return Path(path)

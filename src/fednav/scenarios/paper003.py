"""Paper 003 — federated UKF (total state) vs federated linear KF; chi-square FDI.

Table 1: max, min and std over the flight of the nine errors (east/north/up position,
ENU velocity, roll/pitch/heading Euler errors) for the federated UKF (``FUKF``) and the
federated linear KF (``FKF``); improvement percentages; the fault experiment (first
1000 s, 5-sigma GNSS step fault) with and without isolation.
"""

from __future__ import annotations

import numpy as np

from ..campaign.evaluation import mean_ci95
from ..campaign.paper import Paper, Unit
from ..core import units
from ..core.atomic import write_frame
from ..core.stats import chi2_ppf
from ..sim.runs import make_run_data, run_all_modes, run_configured_mode
from ..sim.scenario import Scenario
from ..sim.scenario import load_scenario as _load
from . import ALIASES as _REGISTRY
from . import scenario_path

PAPER = "003"
ALIASES = _REGISTRY[PAPER]
COLS = ("lon_m", "lat_m", "h_m", "vE_mps", "vN_mps", "vU_mps", "roll_deg", "pitch_deg",
        "yaw_deg")
STATS = ("max", "min", "std")
PAPER_T1 = {
    "FUKF": {"max": (5.06, 4.56, 4.19, 0.19, 0.18, 0.10, 0.26, 0.24, 0.24),
             "min": (-7.04, -6.11, -4.29, -0.18, -0.33, -0.13, -0.24, -0.22, -0.24),
             "std": (1.57, 1.47, 1.17, 0.073, 0.077, 0.042, 0.07, 0.07, 0.07)},
    "FKF": {"max": (7.01, 6.51, 9.24, 0.47, 0.35, 0.39, 0.35, 0.34, 0.35),
            "min": (-9.35, -8.53, -6.39, -0.38, -0.45, -0.29, -0.37, -0.36, -0.32),
            "std": (2.46, 2.27, 1.96, 0.11, 0.11, 0.09, 0.09, 0.09, 0.09)},
}
#: Improvement of FUKF over FKF the paper states (position, velocity, attitude) [%].
PAPER_IMPROVEMENT = {"position": 25.8, "velocity": 38.8, "attitude": 22.2}
GROUPS = {"position": COLS[0:3], "velocity": COLS[3:6], "attitude": COLS[6:9]}


def load_scenario(path=None) -> Scenario:
    return _load(path or scenario_path("paper003"))


def error_table(result) -> np.ndarray:
    """(K, 9) errors in the Table-1 columns: east, north, up [m]; vE, vN, vU [m/s];
    roll, pitch, heading Euler errors [deg]."""
    e = units.to_deg(result.euler)
    return np.column_stack([result.pos, result.vel, e[:, 1], e[:, 0], e[:, 2]])


def run_statistics(result) -> dict[str, float]:
    e = error_table(result)
    out = {}
    for i, c in enumerate(COLS):
        out[f"{c}.max"] = float(e[:, i].max())
        out[f"{c}.min"] = float(e[:, i].min())
        out[f"{c}.std"] = float(e[:, i].std())
    return out


def improvement(fukf: dict, fkf: dict) -> dict[str, float]:
    """1 - mean(std FUKF) / mean(std FKF) per group, in per cent."""
    return {g: 100.0 * (1.0 - np.mean([fukf[f"{c}.std"] for c in cols])
                        / np.mean([fkf[f"{c}.std"] for c in cols]))
            for g, cols in GROUPS.items()}


def fault_metrics(result, start: float, end: float, alpha: float, period: float) -> dict:
    """Detection delay, isolation coverage, false-alarm rate (against the chi-square
    threshold, whether or not isolation was on) and position error in the fault window."""
    f = result.fdi
    g = f[f["local"] == "gnss"]
    thr = chi2_ppf(1.0 - alpha, int(g["dof"].iloc[0]))
    flagged = g["statistic"].to_numpy() > thr
    t = g["t"].to_numpy()
    inside = (t >= start) & (t <= end)
    outside = (t < start) | (t > end + period)
    hits = t[inside & flagged]
    win = (result.t >= start) & (result.t <= end)

    def mean(x):
        return float(np.mean(x)) if len(x) else float("nan")

    return {
        "detect_delay_s": float(hits[0] - start) if len(hits) else float("nan"),
        "detected_fraction": mean(flagged[inside]),
        "isolated_fraction": mean(g["isolated"].to_numpy()[inside]),
        "false_alarm_rate": mean(flagged[outside]),
        "pos_err_rms_fault_window_m": float(np.sqrt(mean((result.pos[win] ** 2).sum(axis=1)))),
    }


def one_run(args):
    scn, seed, max_time = args
    series = run_all_modes(scn, make_run_data(scn, seed, max_time), max_time)
    rows = [{"seed": seed, "mode": k, **run_statistics(r)} for k, r in series.items()]
    fault_rows, fault_series = [], {}
    fe = scn.fault_experiment
    if fe is not None:
        fscn = scn.model_copy(update={"faults": [fe.fault]})
        T = min(fe.duration_s, max_time or fe.duration_s)
        fdata = make_run_data(fscn, seed, T)
        mode = next(m for m in scn.modes if m.name == fe.mode)
        alpha = scn.filter.fdi_alpha  # required by the scenario validation
        for name, a in (("isolated", alpha), ("not_isolated", None)):
            s2 = fscn.model_copy(update={"filter": fscn.filter.model_copy(
                update={"fdi_alpha": a})})
            res = run_configured_mode(s2, mode, fdata, T)
            fault_rows.append({"seed": seed, "case": name,
                               **fault_metrics(res, fe.fault.start_s, fe.fault.end_fixed, alpha,
                                               scn.filter.period_s)})
            fault_series[name] = res
        sep = separation_case(fscn, mode, fdata, fault_series["not_isolated"], T,
                              fe.fault.start_s, fe.fault.end_fixed, scn.filter.period_s)
        if sep is not None:
            fault_rows.append({"seed": seed, "case": "separation", **sep})
    return rows, series, fault_rows, fault_series


def separation_case(scn, mode, data, full, T, start: float, end: float,
                    period: float) -> dict | None:
    """Solution separation beside the chi-square FDI (issue 42): the run without
    isolation ``full`` and the same run flown without each tested sensor
    (:func:`fednav.campaign.integrity.mode_levels`, the scenario's ``integrity:`` or the
    defaults): the first trip of a separation test in the fault window and its delay,
    the fraction of the window's epochs tripped, of those after an exclusion, the trips
    outside it, the output's position error in the window — the columns of
    :func:`fault_metrics` — and the median protection levels, the epochs whose error
    exceeds its level with no alert (misleading) and the sensor excluded.  None when the
    mode has fewer than two tested sensors."""
    from ..campaign.integrity import mode_levels
    from ..navigator.integrity import IntegrityConfig

    s = scn.model_copy(update={"integrity": scn.integrity or IntegrityConfig(),
                               "filter": scn.filter.model_copy(update={"fdi_alpha": None})})
    got = mode_levels(s, mode, data, full, T)
    if got is None:
        return None
    lv, out = got
    t = lv.t
    hit = lv.test_ratio > 1.0
    inside = (t >= start) & (t <= end)
    outside = (t < start) | (t > end + period)
    first = np.flatnonzero(hit & inside)
    win = (out.t >= start) & (out.t <= end)
    h = np.hypot(out.pos[:, 0], out.pos[:, 1])
    rows = lv.rows_at(out.t)
    misled = ((h > lv.hpl[rows]) | (np.abs(out.pos[:, 2]) > lv.vpl[rows])) & ~lv.alert[rows]

    def mean(x):
        return float(np.mean(x)) if len(x) else float("nan")

    return {
        "detect_delay_s": float(t[first[0]] - start) if len(first) else float("nan"),
        "detected_fraction": mean(hit[inside]),
        "isolated_fraction": mean((lv.excluded >= 0)[inside]),
        "false_alarm_rate": mean(hit[outside]),
        "pos_err_rms_fault_window_m": float(np.sqrt(mean((out.pos[win] ** 2).sum(axis=1)))),
        "hpl_median_m": float(np.median(lv.hpl)), "vpl_median_m": float(np.median(lv.vpl)),
        "misleading_epochs": int(misled.sum()),
        "excluded": lv.exclusions[0][1] if lv.exclusions else "",
    }


def summarize(rows: list[dict], fault_rows: list[dict], runs: int, seed: int) -> dict:
    import pandas as pd

    df = pd.DataFrame(rows)
    T1 = {"rows": {}}
    for mode in ("FUKF", "FKF"):
        sub = df[df["mode"] == mode]
        T1["rows"][mode] = {
            c: {s: dict(zip(("ours", "ci95"), mean_ci95(sub[f"{c}.{s}"]), strict=True))
                | {"paper": PAPER_T1[mode][s][i]} for s in STATS}
            for i, c in enumerate(COLS)}
    # Improvement per run (common random numbers), then its Monte Carlo mean.
    per_seed = {}
    for sd, g in df.groupby("seed"):
        r = {m: g[g["mode"] == m].iloc[0].to_dict() for m in ("FUKF", "FKF")}
        per_seed[sd] = improvement(r["FUKF"], r["FKF"])
    paper_tab = {
        m: {f"{c}.std": PAPER_T1[m]["std"][i] for i, c in enumerate(COLS)} for m in PAPER_T1}
    from_table = improvement(paper_tab["FUKF"], paper_tab["FKF"])
    imp = {"rows": {g: {"improvement_pct": dict(zip(("ours", "ci95"), mean_ci95(
        [v[g] for v in per_seed.values()]), strict=True)) | {
        "paper": PAPER_IMPROVEMENT[g], "paper_table_same_rule": from_table[g]}}
        for g in GROUPS}}
    # Same-information analysis: group std for every mode flown.
    analysis = {"rows": {}}
    for mode, sub in df.groupby("mode", sort=False):
        analysis["rows"][mode] = {
            f"{g}_std": dict(zip(("ours", "ci95"), mean_ci95(
                np.mean([sub[f"{c}.std"] for c in cols], axis=0)), strict=True))
            | {"paper": None} for g, cols in GROUPS.items()}
    tables = {"T1": T1, "improvement": imp, "analysis": analysis}
    if fault_rows:
        fd = pd.DataFrame(fault_rows)
        cols = ("detect_delay_s", "detected_fraction", "isolated_fraction",
                "false_alarm_rate", "pos_err_rms_fault_window_m")
        # solution separation (beside the chi-square FDI): its levels and misleading epochs
        levels = ("hpl_median_m", "vpl_median_m", "misleading_epochs")
        tables["fault"] = {"rows": {
            case: {c: dict(zip(("ours", "ci95"), mean_ci95(g[c]), strict=True))
                   | {"paper": None}
                   for c in cols + (levels if case == "separation" else ())}
            for case, g in fd.groupby("case", sort=False)}}
    return {"paper": PAPER, "runs": runs, "seed": seed, "tables": tables}


class Paper003(Paper):
    """Paper 003 as a campaign: one unit per Monte Carlo run (every mode, and the fault
    experiment with and without isolation, on the run's data)."""

    number = PAPER
    titles = {"T1": "Table 1 — error max / min / std over the flight",
              "improvement": "Improvement of FUKF over FKF",
              "analysis": "Mean std per group for every mode",
              "fault": "Fault experiment — 5-sigma GNSS step fault (FUKF)"}

    def load_scenario(self, path=None) -> Scenario:
        return load_scenario(path)

    def units(self, scn, runs, seed, max_time=None, **_) -> list[Unit]:
        return self.per_seed(one_run, scn, runs, seed, max_time)

    def summarize(self, scn, runs, seed, max_time, results, **_) -> dict:
        rows = [r for o in results for r in o[0]]
        fault_rows = [r for o in results for r in o[2]]
        return {"rows": rows, "fault_rows": fault_rows, "series": results[0][1],
                "runs_series": [o[1] for o in results], "fault_series": results[0][3],
                "fault_runs_series": [o[3] for o in results],
                "summary": summarize(rows, fault_rows, runs, seed)}

    def files(self, out, rep) -> list:
        import pandas as pd

        if not rep["fault_rows"]:
            return []
        return [write_frame(pd.DataFrame(rep["fault_rows"]), out / "fault_runs.csv")]

    def plots(self, out, rep) -> list:
        from ..campaign.report import plot_errors, plot_fdi

        files = [plot_errors(rep["runs_series"], out / "errors.png", "Paper 003")]
        if rep["fault_rows"]:
            files.append(plot_fdi(rep["fault_series"]["isolated"].fdi, out / "fdi.png",
                                  "Fault experiment: chi-square statistics, 5-sigma GNSS "
                                  "fault"))
            files.append(plot_errors(rep["fault_runs_series"], out / "fault_errors.png",
                                     "Paper 003, 5-sigma GNSS step fault (FUKF)"))
        return files


EXPERIMENT = Paper003()
reproduce = EXPERIMENT.reproduce
print_summary = EXPERIMENT.print_summary
write_outputs = EXPERIMENT.write_outputs

"""Paper 002 — SINS/CNS/SAR for a cruise missile: Tables 1 to 4.

* Table 1 — observability degree of every error state for the SINS/CNS/SAR measurement
  set over the flight (:mod:`fednav.ins.observability`): the paper's SVD degree (SI units,
  velocity error = 1; the singular values assigned to the states one to one, the paper's
  largest-component rule where that is one to one) beside the same in filter units and
  the unit-free covariance degree ``sigma(0) / sigma(T)``; per flight phase in
  ``observability_phases``.
* Tables 2 and 3 — statistic (paper): errors sampled every 1 s, absolute value averaged
  over the flight.  Columns: ``dlambda_m`` / ``dL_m`` = east / north position error [m],
  ``dVx_mps`` / ``dVy_mps`` = east / north velocity error [m/s], ``phiE/N/U_arcsec``
  misalignment.
* Table 4 — SINS/CNS/SAR with UKF, SGHQF and AASGHQF local filters on the same runs
  (``t4_runs`` of them): ``att_arcsec`` = mean of the three misalignment columns,
  ``vel_mps`` = mean of the two horizontal velocity columns, ``pos_m`` = mean of the two
  horizontal position columns (each the paper's mean absolute error), ``ms_per_cycle``
  the run's wall time per filter cycle, measured in the same process for all three.
"""

from __future__ import annotations

import numpy as np

from ..campaign.evaluation import error_stats
from ..campaign.montecarlo import run_seeds
from ..campaign.paper import Paper, Unit
from ..core import units
from ..sim.runs import make_run_data, run_all_modes
from ..sim.scenario import Scenario
from ..sim.scenario import load_scenario as _load
from . import ALIASES as _REGISTRY
from . import scenario_path

PAPER = "002"
ALIASES = _REGISTRY[PAPER]

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
#: Table 1 (paper): observability degree, normalised to the velocity error.
PAPER_T1 = {"phiE": 8.67, "phiN": 8.67, "phiU": 8.62, "dVE": 1.0, "dVN": 1.0, "dL": 8.2,
            "dlambda": 8.2, "eps_cx": 5.31e-5, "eps_cy": 5.31e-5, "eps_cz": 4.31e-5,
            "eps_rx": 2.38e-6, "eps_ry": 2.69e-6, "eps_rz": 2.72e-6, "nabla_cx": 6.29e-5,
            "nabla_cy": 6.32e-6, "nabla_cz": 6.87e-6}
#: fednav state (error_model.STATE_NAMES) -> Table 1 key; dvU and dh are fednav's extras.
T1_KEYS = {"phiE": "phiE", "phiN": "phiN", "phiU": "phiU", "dvE": "dVE", "dvN": "dVN",
           "dvU": "dVU", "dE": "dlambda", "dN": "dL", "dU": "dh", "eps_cx": "eps_cx",
           "eps_cy": "eps_cy", "eps_cz": "eps_cz", "eps_rx": "eps_rx", "eps_ry": "eps_ry",
           "eps_rz": "eps_rz", "nabla_x": "nabla_cx", "nabla_y": "nabla_cy",
           "nabla_z": "nabla_cz"}
#: Table 4 (paper): attitude ", velocity m/s, position m, time per cycle [s -> ms].
T4_FILTERS = ("SGHQF", "AASGHQF", "UKF")
PAPER_T4 = {"SGHQF": (0.6, 0.012, 0.80, 8.7), "AASGHQF": (0.58, 0.011, 0.75, 6.8),
            "UKF": (0.62, 0.014, 0.85, 2.1)}
T4_COLS = ("att_arcsec", "vel_mps", "pos_m", "ms_per_cycle")
TABLE_TITLES = {
    "T1": "Table 1 — observability degree, SINS/CNS/SAR (SVD: velocity error = 1, each "
          "singular value assigned to one state — the paper's largest-component rule made "
          "one to one, so that no state, e.g. a SAR-measured position, is left with 0; "
          "covariance: sigma(0)/sigma(T))",
    "T2": "Table 2 — mean absolute position / velocity error",
    "T3": "Table 3 — mean absolute misalignment (arc-seconds)",
    "T4": "Table 4 — SINS/CNS/SAR with UKF, sparse-grid (SGHQF) and adaptive anisotropic "
          "sparse-grid (AASGHQF) local filters",
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


def _nominal(tr, k):
    """Error-model linearisation point from the truth at sample k."""
    from ..core.attitude import euler_to_dcm
    from ..ins.error_model import Nominal

    C = euler_to_dcm(tr.euler[k])
    return Nominal(lat=tr.lla[k, 0], h=tr.lla[k, 2], vel=tr.vel[k], C=C,
                   fn=C @ tr.dv[min(k, len(tr.dv) - 1)] / tr.dt)


def _measurement_H(scn: Scenario, nav):
    from ..sensors import SarFix, StarAttitude

    out = []
    if scn.sensors.star is not None:
        out.append((StarAttitude().H(nav), StarAttitude().R(
            float(units.arcsec(scn.sensors.star.sigma_arcsec)) * np.ones(3)),
            scn.sensors.star.period_s))
    if scn.sensors.sar is not None:
        c = scn.sensors.sar
        out.append((SarFix().H(nav), SarFix().R(
            [c.sigma_pos_m, c.sigma_pos_m, float(units.deg(c.sigma_heading_deg))]),
            c.period_s))
    return out


def _error_process(scn: Scenario, tr):
    """``k -> ErrorProcess`` linearised on the truth at sample ``k`` of ``tr``."""
    from ..ins import error_model as em
    from ..ins.strapdown import Strapdown
    from ..navigator.system import imu_noise_model

    noise = imu_noise_model(scn, tr.dt)[0]
    baro = scn.sensors.baro.loop() if scn.sensors.baro is not None else None
    gains = Strapdown(tr.lla[0], tr.vel[0], tr.euler[0], tr.dt, baro).baro_gains[:2]
    return lambda k: em.ErrorProcess(_nominal(tr, k), scn.filter.period_s, noise, gains)


def _nav(tr, k):
    """The true navigation state at sample ``k`` of ``tr`` (the measurement models' H)."""
    from ..sensors import NavSnapshot

    return NavSnapshot(tr.lla[k], tr.vel[k], _nominal(tr, k).C)


def _segment_models(scn: Scenario, tr, proc) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """:func:`observability_models` on the trajectory ``tr`` with ``proc`` =
    :func:`_error_process`."""
    from ..ins import error_model as em

    # H and F in SI: the H rows of the measurement models map angles in the same unit on
    # both sides and metres to metres, so only the columns need the state scale.
    def H_si(k):
        return np.vstack([H for H, _, _ in _measurement_H(scn, _nav(tr, k))]) / em.SCALE

    bounds = np.cumsum([0.0] + [g.duration_s for g in scn.segments])
    bounds = bounds[bounds <= tr.t[-1] + 1e-9]
    if len(bounds) < 2:
        from ..core.config import ConfigError

        raise ConfigError(f"--max-time {tr.t[-1]:g} s: paper 002's observability table "
                          f"needs at least its first flight segment "
                          f"({scn.segments[0].duration_s:g} s)")
    mids = [int(round(0.5 * (a + b) / tr.dt)) for a, b in zip(bounds[:-1], bounds[1:],
                                                               strict=True)]
    return [(g.name, proc(k).F_si(), H_si(k))
            for g, k in zip(scn.segments, mids, strict=False)]


def observability_models(scn: Scenario, max_time: float | None = None
                         ) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The piecewise-constant system of Table 1: per flight segment flown within
    ``max_time`` [s] (default: the whole flight), ``(segment name, F (18, 18), H (m, 18))``
    linearised on the truth at the segment's middle, states in SI (rad, m/s, m, rad/s,
    m/s^2), measurements the star Euler angles [rad] and the SAR east/north position [m]
    and heading [rad]."""
    tr = scn.trajectory(max_time)
    return _segment_models(scn, tr, _error_process(scn, tr))


def observability(scn: Scenario, max_time: float | None = None) -> dict:
    """Table 1 (whole flight) and the SVD degree per flight phase (one PWCS segment per
    scenario segment, linearised at its middle), for the star + SAR measurement set."""
    from ..ins import error_model as em
    from ..ins.observability import (
        covariance_degree,
        stripped_observability_matrix,
        svd_degree,
    )
    from ..sim.runs import initial_covariance

    tr = scn.trajectory(max_time)
    proc = _error_process(scn, tr)
    T = scn.filter.period_s
    models = _segment_models(scn, tr, proc)
    Fs, Hs = [F for _, F, _ in models], [H for _, _, H in models]
    ref = em.STATE_NAMES.index("dvE")
    deg_si, _ = svd_degree(stripped_observability_matrix(Fs, Hs), ref)
    # The same in filter units: state j scaled by SCALE_j (columns of O times SCALE).
    Of = stripped_observability_matrix(Fs, Hs) * em.SCALE
    deg_f, _ = svd_degree(Of, ref)
    phases = {"si": {}, "filter_units": {}}
    for name, F, H in models:
        O1 = stripped_observability_matrix([F], [H])
        for unit, O in (("si", O1), ("filter_units", O1 * em.SCALE)):
            d, _ = svd_degree(O, ref)
            phases[unit][name] = {T1_KEYS[n]: float(v)
                                  for n, v in zip(em.STATE_NAMES, d, strict=True)}
    # Covariance degree: the KF covariance recursion with every star and SAR fix.
    per = round(T / tr.dt)
    n_cyc = (len(tr.t) - 1) // per

    def steps():
        for c in range(n_cyc):
            k = (c + 1) * per
            p = proc(k - per // 2)
            t = tr.t[k]
            meas = [(H, R) for H, R, period in _measurement_H(scn, _nav(tr, k))
                    if abs(t / period - round(t / period)) < 1e-6]
            yield p.Phi, p.Qd, meas

    shrink = covariance_degree(initial_covariance(scn), steps())
    rows = {}
    for i, n in enumerate(em.STATE_NAMES):
        key = T1_KEYS[n]
        rows[key] = {"degree": {"ours": float(deg_si[i]), "paper": PAPER_T1.get(key)},
                     "degree_filter_units": {"ours": float(deg_f[i])},
                     "sigma_shrink": {"ours": float(shrink[i])}}
    return {"rows": rows, "phases": phases}


def one_run_t4(args) -> list[dict]:
    """Table 4: SINS/CNS/SAR with each filter on one run's data, timed alike."""
    import time

    from ..sim.runs import run_configured_mode
    from ..sim.scenario import ModeConfig

    scn, seed, max_time = args
    data = make_run_data(scn, seed, max_time)
    aiding = next(m for m in scn.modes if m.name == "SINS/CNS/SAR").aiding
    rows = []
    for name in T4_FILTERS:
        mode = ModeConfig(name=name, aiding=aiding, filter=name.lower())
        t0 = time.perf_counter()
        r = run_configured_mode(scn, mode, data, max_time)
        el = time.perf_counter() - t0
        st = run_statistics(r)
        rows.append({"seed": seed, "mode": name,
                     "att_arcsec": (st["phiE_arcsec"] + st["phiN_arcsec"]
                                    + st["phiU_arcsec"]) / 3,
                     "vel_mps": (st["dVx_mps"] + st["dVy_mps"]) / 2,
                     "pos_m": (st["dlambda_m"] + st["dL_m"]) / 2,
                     "ms_per_cycle": 1e3 * el / len(r.t)})
    return rows


def run_monte_carlo(scn: Scenario, runs: int, seed: int, jobs: int = 1,
                    max_time: float | None = None, progress=None, campaign=None):
    """Run ``runs`` Monte Carlo runs with seeds ``seed, seed+1, ...``.

    Returns (list of per-run rows, error series of the first run).
    """
    out = run_seeds(one_run, [(scn, seed + i, max_time) for i in range(runs)], jobs, progress,
                    campaign)
    return [r for rows, _ in out for r in rows], out[0][1]


def observability_unit(args) -> dict:
    """:func:`observability` as a campaign unit (``args`` = (scenario, max_time))."""
    return observability(*args)


class Paper002(Paper):
    """Paper 002 as a campaign: Table 4's runs (the long units, first), Table 1's
    observability analysis (one more unit of the same batch, so a worker computes it while
    the others fly runs), then the Monte Carlo runs of Tables 2-3."""

    number = PAPER
    kernel_plan = "paper002"
    tables = PAPER_TABLES
    titles = TABLE_TITLES
    options = ("t4_runs",)

    def load_scenario(self, path=None) -> Scenario:
        return load_scenario(path)

    @staticmethod
    def _n4(runs: int, t4_runs: int | None) -> int:
        return min(runs, 3) if t4_runs is None else t4_runs

    def units(self, scn, runs, seed, max_time=None, t4_runs=None, **_) -> list[Unit]:
        n4 = self._n4(runs, t4_runs)
        return (self.per_seed(one_run_t4, scn, n4, seed, max_time)
                + [Unit(observability_unit, (scn, max_time))]
                + self.per_seed(one_run, scn, runs, seed, max_time))

    def summarize(self, scn, runs, seed, max_time, results, t4_runs=None, **_) -> dict:
        """Tables 2-3 over ``runs`` runs, Table 4 over the first ``t4_runs`` of them
        (default min(runs, 3)), Table 1."""
        from ..campaign.report import summarize

        n4 = self._n4(runs, t4_runs)
        rows4 = [r for o in results[:n4] for r in o]
        obs = results[n4]
        rows = [r for rws, _ in results[n4 + 1:] for r in rws]
        summary = summarize(rows, PAPER_TABLES, PAPER, runs, seed)
        t4 = summarize(rows4, {"T4": {k: dict(zip(T4_COLS, v, strict=True))
                                      for k, v in PAPER_T4.items()}}, PAPER, n4, seed)
        summary["tables"] = {"T1": {"rows": obs["rows"]}, **summary["tables"],
                             "T4": {"runs": n4, **t4["tables"]["T4"]}}
        summary["observability_phases"] = obs["phases"]
        return {"rows": rows + [{**r, "table": "T4"} for r in rows4],
                "series": results[n4 + 1][1],
                "runs_series": [o[1] for o in results[n4 + 1:]], "summary": summary}


EXPERIMENT = Paper002()
reproduce = EXPERIMENT.reproduce
print_summary = EXPERIMENT.print_summary
write_outputs = EXPERIMENT.write_outputs

__all__ = ["ALIASES", "EXPERIMENT", "PAPER", "PAPER_TABLES", "TABLE_TITLES", "load_scenario",
           "observability", "observability_models", "print_summary", "reproduce",
           "run_monte_carlo", "run_statistics", "write_outputs"]

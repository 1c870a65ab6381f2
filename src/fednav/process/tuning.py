"""Noise figures from the data alone (``fednav tune``).

The processing filter (:func:`fednav.process.process`) needs the IMU's white noise (ARW,
VRW), its bias instability (the Gauss–Markov sigmas) and the 1-sigma of every aiding
sensor.  Data sheets give lower bounds at best (vibration, temperature, multipath are
not in them), so fednav estimates them from the data the way the filter sees them:

1. **White noise floor** — the robust sample-to-sample scatter of the raw IMU:
   ``N = 1.4826 MAD(diff x) / sqrt(2) * sqrt(dt)`` per axis (the largest axis is kept).
   The vehicle's own motion changes little between two samples, and the median ignores
   the steps where it does, so this needs no static period.  It is the noise at the IMU
   rate, vibration included.
2. **Aiding-sensor noise** — innovation covariance matching: with ``nu = z - H x^-`` and
   ``S = H P^- H' + R``, ``E[nu nu'] = H P^- H' + R``, so ``R_jj = mean(nu_j^2) -
   mean((H P^- H')_jj)`` per component, iterated to its fixed point (a few filter runs).
   In the federated filter each local filter holds ``P / beta``; the centralized
   ``H P^- H' = beta (S_local - R)`` is used.
3. **IMU process noise** — maximum of the innovation likelihood ``L = -1/2 sum(log det S
   + nu' S^-1 nu)`` over one figure at a time (log scale: the figure x 1/3 and x 3, the
   bracket widened while an end wins, then the vertex of the parabola through the best
   three).  A figure changes only when the likelihood rises by more than 1.92 (the
   likelihood-ratio test at 95 %, one degree of freedom); otherwise it keeps its value
   and the table says the data do not determine it: the white noise of a MEMS IMU, for
   instance, is invisible in 5 Hz GNSS innovations.  One data set holds one turn-on bias,
   not its spread, so the turn-on bias sigmas and the correlation times are never changed.

Figures the base config sets are kept as they are: ``fednav tune`` estimates what the
config leaves open (start values then come from the data file, else a generic MEMS IMU).
Measurements that fault detection isolates (``fdi_alpha`` of the base config) are left
out of the matching, and every measurement's ``nu' S^-1 nu`` is capped at its 99.9 %
chi-square point in the likelihood, so a few outliers do not set the noise figures.
Units: SI (rad, m, s) as in the ``imu:`` section's SI keys
(:class:`fednav.sensors.imu.ImuConfig`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..io.data import GnssData, ImuData, VelocityData
from ..navigator.system import System, _translate_legacy
from ..sensors import GnssConfig, VelocityConfig
from ..sensors.imu import FIGURES
from .run import InnovationRecord, adjust_sensors, imu_figures, process

#: Starting IMU figures (a generic MEMS IMU) where neither the file nor the config has one.
MEMS_DEFAULTS = {"gyro_arw_rad_sqrt_s": 5.8e-4, "accel_vrw_mps_sqrt_s": 2.0e-3,
                 "gyro_bias_radps": 4.8e-4, "accel_bias_mps2": 2.0e-2,
                 "gyro_markov_radps": 4.8e-5, "accel_markov_mps2": 1.0e-3,
                 "gyro_tau_s": 100.0, "accel_tau_s": 100.0}
#: IMU figures estimated by the likelihood, in the order searched.
LIKELIHOOD_KEYS = ("accel_vrw_mps_sqrt_s", "gyro_arw_rad_sqrt_s", "accel_markov_mps2",
                   "gyro_markov_radps")
#: ln of the likelihood-search step (a factor 3).
_STEP = float(np.log(3.0))
#: log-likelihood gain a new figure must bring (the likelihood-ratio test at 95 %, 1 dof)
LR_95 = 1.92
#: log-likelihood gain at an end of the bracket that widens it (below: a flat likelihood)
_WIDEN = 0.5
#: chi-square point at which a measurement's statistic is capped in the likelihood
_CAP_P = 0.999


@dataclass
class Figure:
    """One tuned figure: its config ``key``, ``start`` and tuned ``value`` (SI; a float or
    a 3-list), how it was found and why."""

    key: str
    start: float | list
    value: float | list
    how: str


@dataclass
class Evaluation:
    """One filter run: log-likelihood and, per local filter, NIS/dof and the matched R
    diagonal (residual order)."""

    loglik: float
    nis_per_dof: dict[str, float]
    matched: dict[str, np.ndarray]


@dataclass
class TuneResult:
    config: System
    figures: list[Figure]
    before: Evaluation
    after: Evaluation
    runs: int
    run_time_s: float
    notes: list[str] = field(default_factory=list)


def white_noise(x: np.ndarray, dt: float) -> np.ndarray:
    """White-noise density [unit * sqrt(s)] of each column of samples ``x`` (N, k) taken
    every ``dt`` [s], from the robust scatter of their first differences."""
    d = np.diff(np.asarray(x, dtype=float), axis=0)
    mad = np.median(np.abs(d - np.median(d, axis=0)), axis=0)
    return 1.4826 * mad / np.sqrt(2.0) * np.sqrt(dt)


def _cap(dof: int) -> float:
    from scipy.stats import chi2

    return float(chi2.ppf(_CAP_P, dof))


def evaluate(imu: ImuData, gnss: GnssData, velocity: VelocityData | None,
             cfg: System) -> Evaluation:
    """Run the forward filter with ``cfg`` and sum up its innovations."""
    inns: list[InnovationRecord] = []
    process(imu, gnss, velocity, cfg, innovations=inns)
    ll, nis, matched = 0.0, {}, {}
    for local in dict.fromkeys(i.local for i in inns):
        mine = [i for i in inns if i.local == local]
        r = np.array([i.r for i in mine])
        R = np.array([i.R for i in mine])
        beta = np.array([i.beta for i in mine])[:, None, None]
        Sc = beta * (np.array([i.S for i in mine]) - R) + R  # centralized S
        L = np.linalg.cholesky(Sc)
        w = np.linalg.solve(L, r[..., None])[..., 0]
        q = np.einsum("ij,ij->i", w, w)
        d = r.shape[1]
        cap = _cap(d)
        logdet = 2.0 * np.log(np.diagonal(L, axis1=1, axis2=2)).sum(axis=1)
        ll -= 0.5 * float(np.sum(logdet + np.minimum(q, cap) + d * np.log(2 * np.pi)))
        nis[local] = float(np.mean(q) / d)
        use = np.array([i.accepted for i in mine]) & (q <= cap)
        if use.any():
            hph = np.diagonal(Sc - R, axis1=1, axis2=2)
            matched[local] = np.mean(r[use] ** 2, axis=0) - np.mean(hph[use], axis=0)
    return Evaluation(ll, nis, matched)


def _starting_imu(imu: ImuData, base: System, notes: list) -> dict[str, float]:
    out = imu_figures(imu, base)
    generic = [k for k, v in out.items() if v is None]
    if generic:
        out.update({k: MEMS_DEFAULTS[k] for k in generic})
        notes.append("not in the file or the config, started from a generic MEMS IMU: "
                     + ", ".join(f"{k} {MEMS_DEFAULTS[k]:g}" for k in generic))
    return out


def tune(imu: ImuData, gnss: GnssData, velocity: VelocityData | None = None,
         base: System | None = None, matching_passes: int = 2,
         progress=None) -> TuneResult:
    """Estimate the noise figures that ``base`` (default :class:`System`) leaves
    unset from the data (see the module docstring); figures ``base`` sets are kept as
    they are.  ``progress(text)`` is called before each filter run."""
    t_start = time.perf_counter()
    base = base or System()
    notes: list[str] = []
    runs = 0
    dt = imu.period()
    gc = base.sensors.gnss or GnssConfig()
    vc = base.sensors.velocity or VelocityConfig()
    if gc.lever_m is None and not np.any(gnss.lever):
        notes.append("no GNSS antenna lever arm is set (sensors.gnss.lever_m, nor in the "
                     "file): the figures are estimated for an antenna at the IMU — a lever "
                     "arm left out is absorbed into them; give it in the base config, and "
                     "process with a config that has it")
    # Figures the base config sets, by their SI key (however the config spells them).
    fixed = {FIGURES[f][2] for f in FIGURES if base.imu.si(f) is not None}
    fixed |= {k for k, v in (("sensors.gnss.sigma_pos_m", gc.sigma_pos_m),
                             ("sensors.gnss.sigma_vel_mps", gc.sigma_vel_mps),
                             ("sensors.velocity.sigma_mps", vc.sigma_mps)) if v is not None}
    # Sensor noise variances in the order of the residuals: GNSS [E, N, U] m, [E, N, U]
    # m/s; velocity sensor [E, N, U] m/s.
    _, v_adj = adjust_sensors(gnss, velocity, base)
    pos0 = np.broadcast_to(np.asarray(gnss.sigma_pos if gc.sigma_pos_m is None
                                      else gc.sigma_pos_m, dtype=float), (3,))  # N, E, U
    vel0 = np.broadcast_to(np.asarray(gnss.sigma_vel if gc.sigma_vel_mps is None
                                      else gc.sigma_vel_mps, dtype=float), (3,))  # E, N, U
    r_gnss = np.r_[pos0[[1, 0, 2]], vel0] ** 2
    r_vel = None
    if velocity is not None:
        r_vel = np.square(vc.sigma_mps) if vc.sigma_mps is not None \
            else np.median(np.diagonal(v_adj.cov, axis1=1, axis2=2), axis=0)
    start_r = (r_gnss.copy(), None if r_vel is None else r_vel.copy())
    free_g = np.r_[np.full(3, "sensors.gnss.sigma_pos_m" not in fixed),
                   np.full(3, "sensors.gnss.sigma_vel_mps" not in fixed)]
    free_v = "sensors.velocity.sigma_mps" not in fixed

    def config(fig_imu, rg, rv):
        """``base`` with these IMU figures and sensor variances (residual order)."""
        sd = np.sqrt(rg)
        sensors = {"gnss": gc.model_copy(update={
            "sigma_pos_m": tuple(map(float, sd[[1, 0, 2]])),
            "sigma_vel_mps": tuple(map(float, sd[3:]))})}
        if rv is not None or base.sensors.velocity is not None:
            sensors["velocity"] = vc.model_copy(update={
                "sigma_mps": None if rv is None else tuple(map(float, np.sqrt(rv)))})
        return base.model_copy(update={
            "imu": base.imu.model_copy(update={k: v for k, v in fig_imu.items()
                                               if k not in fixed}),
            "sensors": base.sensors.replace(**sensors)})

    def run(fig_imu, rg, rv, what):
        nonlocal runs
        runs += 1
        if progress is not None:
            progress(what)
        return evaluate(imu, gnss, velocity, config(fig_imu, rg, rv))

    def match(rg, rv, ev):
        """Covariance matching of the free sensor variances (floored at 1e-3 of the
        current value: one pass cannot zero a variance)."""
        new_g = rg if "gnss" not in ev.matched else \
            np.where(free_g, np.maximum(ev.matched["gnss"], 1e-3 * rg), rg)
        if rv is not None and free_v and "velocity" in ev.matched:
            rv = np.maximum(ev.matched["velocity"], 1e-3 * rv)
        return new_g, rv

    fig_imu = _starting_imu(imu, base, notes)
    start_imu = dict(fig_imu)
    figures: list[Figure] = []
    before = run(start_imu, r_gnss, r_vel, "starting figures")
    # 1. White-noise floor from the sample-to-sample scatter.
    scatter = {"gyro_arw_rad_sqrt_s": float(np.max(white_noise(imu.gyro, dt))),
               "accel_vrw_mps_sqrt_s": float(np.max(white_noise(imu.accel, dt)))}
    fig_imu.update({k: v for k, v in scatter.items() if k not in fixed})
    # 2. Aiding-sensor noise by covariance matching (the first pass from the run with
    # the starting figures).
    ev = before
    for p in range(matching_passes):
        r_gnss, r_vel = match(r_gnss, r_vel, ev)
        ev = run(fig_imu, r_gnss, r_vel, f"covariance matching {p + 1}")
    # 3. IMU process noise by the likelihood, one figure at a time.
    for key in LIKELIHOOD_KEYS:
        if key in fixed:
            figures.append(Figure(f"imu.{key}", start_imu[key], start_imu[key],
                                  "kept: set in the config"))
            continue
        ev, figure = _search(key, fig_imu, ev, lambda f, what: run(f, r_gnss, r_vel, what),
                             "sample scatter" if key in scatter else "start")
        figure.start = start_imu[key]
        figures.append(figure)
    # 4. The sensor noise again, with the process noise found.
    r_gnss, r_vel = match(r_gnss, r_vel, ev)
    ev = run(fig_imu, r_gnss, r_vel, "covariance matching, final")
    sd0, sd = np.sqrt(start_r[0]), np.sqrt(r_gnss)
    sensors = [("sensors.gnss.sigma_pos_m", sd0[[1, 0, 2]], sd[[1, 0, 2]]),
               ("sensors.gnss.sigma_vel_mps", sd0[3:], sd[3:])]
    if r_vel is not None:
        sensors.append(("sensors.velocity.sigma_mps", np.sqrt(start_r[1]), np.sqrt(r_vel)))
    for key, s0, s1 in sensors:
        figures.append(Figure(key, [float(x) for x in s0], [float(x) for x in s1],
                              "kept: set in the config" if key in fixed
                              else "innovation covariance matching"))
    for key in ("gyro_bias_radps", "accel_bias_mps2", "gyro_tau_s", "accel_tau_s"):
        figures.append(Figure(f"imu.{key}", start_imu[key], fig_imu[key],
                              "kept: set in the config" if key in fixed else
                              "kept: one data set holds one draw of it, not its "
                              "spread"))
    return TuneResult(config(fig_imu, r_gnss, r_vel), figures, before, ev, runs,
                      time.perf_counter() - t_start, notes)


def _search(key: str, fig_imu: dict, ev: Evaluation, run, origin: str):
    """Maximise the likelihood over ``fig_imu[key]`` (log scale) from the evaluation
    ``ev`` of the current figures; ``fig_imu`` is updated in place when the best value
    beats the current one by more than :data:`LR_95`.  Returns (evaluation of the figures
    kept, :class:`Figure`)."""
    x0 = float(np.log(fig_imu[key]))
    tried = {0.0: ev}

    def at(u):
        if u not in tried:
            tried[u] = run({**fig_imu, key: float(np.exp(x0 + u))},
                           f"likelihood of imu.{key} x {np.exp(u):.3g}")
        return tried[u].loglik

    at(-_STEP), at(_STEP)
    for _ in range(6):  # widen while an end of the bracket wins (by more than noise)
        us = sorted(tried)
        best = max(tried, key=at)
        if best not in (us[0], us[-1]) or at(best) - tried[0.0].loglik < _WIDEN:
            break
        at(best + (2 * _STEP if best == us[-1] else -2 * _STEP))
    us = sorted(tried)
    best = max(tried, key=at)
    k = us.index(best)
    if 0 < k < len(us) - 1:  # refine at the vertex of the parabola through the best three
        u = np.array(us[k - 1:k + 2])
        a, b, _ = np.polyfit(u, [tried[v].loglik for v in u], 2)
        if a < 0:
            vertex = float(np.clip(-b / (2 * a), u[0], u[2]))
            if abs(vertex - best) > 0.1 and at(vertex) > at(best):
                best = vertex
    gain = at(best) - tried[0.0].loglik
    lo, hi = float(np.exp(min(tried))), float(np.exp(max(tried)))
    if gain <= LR_95:
        return ev, Figure(f"imu.{key}", fig_imu[key], fig_imu[key],
                          f"kept ({origin}): likelihood at most {gain:+.1f} "
                          f"over x{lo:.2g}..x{hi:.2g}")
    start = fig_imu[key]
    fig_imu[key] = float(np.exp(x0 + best))
    return tried[best], Figure(f"imu.{key}", start, fig_imu[key],
                               f"innovation likelihood: {gain:+.1f} over the "
                               f"{origin} value")


def config_yaml(res: TuneResult, base: dict | None = None, header: str = "") -> str:
    """The tuned config as YAML for ``fednav process --config``: the ``base`` mapping
    (the user's config, kept key for key) with the tuned figures, a comment per figure."""
    import warnings

    import yaml

    with warnings.catch_warnings():  # the user's 0.1 keys are written in today's places
        warnings.simplefilter("ignore", FutureWarning)
        data = _translate_legacy(dict(base or {}))
    c = res.config
    given = data.get("imu") or {}  # the user's own figures are written as given
    data["imu"] = {**given, **{k: float(f"{v:.6g}") for k, v in
                               c.imu.model_dump(exclude_defaults=True).items()
                               if k not in given}}
    sensors = {k: dict(v or {}) for k, v in (data.get("sensors") or {}).items()}
    for name, key in (("gnss", "sigma_pos_m"), ("gnss", "sigma_vel_mps"),
                      ("velocity", "sigma_mps")):
        section = c.sensors.get(name)
        v = None if section is None else getattr(section, key)
        if v is not None and key not in sensors.get(name, {}):
            sensors.setdefault(name, {})[key] = [float(f"{x:.6g}") for x in v]
    if sensors:
        data["sensors"] = sensors
    lines = [f"# {line}" for line in header.splitlines()]
    lines.append("# mean NIS/dof before -> after: " + ", ".join(
        f"{k} {res.before.nis_per_dof[k]:.2f} -> {res.after.nis_per_dof[k]:.2f}"
        for k in res.after.nis_per_dof))
    for f in res.figures:
        lines.append(f"# {f.key}: {format_value(f.start)} -> {format_value(f.value)} ({f.how})")
    for n in res.notes:
        lines.append(f"# note: {n}")
    return "\n".join(lines) + "\n" + yaml.safe_dump(data, sort_keys=False)


def format_value(v) -> str:
    """A figure (a number or a 3-list) to 3 significant digits."""
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(f"{x:.3g}" for x in v) + "]"
    return f"{v:.3g}"

"""Noise figures from the data (``fednav tune``), scored on data they were not fitted to.

The processing filter (:func:`fednav.process.process`) needs the IMU's white noise (ARW,
VRW), its bias instability (the Gauss–Markov sigmas) and the 1-sigma of every aiding
sensor.  Data sheets give lower bounds at best (vibration, temperature, multipath are
not in them), so fednav estimates them from the data the way the filter sees them, and
checks the result on data it did not fit (docs/tuning.md has the method with measured
figures):

0. **Held-back blocks** — the run is cut into alternating time blocks (60 s): the filter
   runs over all of it, but only the innovations of the even blocks are *fitted* (the
   covariance matching and the likelihood below); those of the odd blocks are *held back*
   and score the result (time-series cross-validation with contiguous blocks, so that
   the autocorrelated innovations of one stretch of road do not score themselves).
1. **Floors: what the data's own scatter supports** — the IMU's white noise from the
   robust sample-to-sample scatter (``N = 1.4826 MAD(diff x) / sqrt(2) * sqrt(dt)``, the
   largest axis; vibration included) and from the scatter of the filter-period means
   (second differences); the smaller of the two is the floor below which a white-noise
   figure is never set.  A sensor's floor is the robust scatter of the differences of
   its own measurements that cancel the motion (third differences of positions, second
   of velocities): its white part, the least 1-sigma its data show.
2. **Aiding-sensor noise** (only where no one gave it, or with ``tune_sensors``) —
   innovation covariance matching on the fitted blocks (Mehra 1970): ``R_jj =
   mean(nu_j^2) - mean((H P^- H')_jj)``, iterated to its fixed point, never below the
   floor.  In the federated filter each local filter holds ``P / beta``; the centralized
   ``H P^- H' = beta (S_local - R)`` is used.  The 1-sigma the base config, the file or
   the receiver gives is kept by default: matching a time-correlated error (multipath,
   atmosphere) drives it toward the white part alone, the filter then follows the
   fixes' wander, and the drift through an outage grows.
3. **IMU process noise** — maximum of the fitted blocks' innovation likelihood ``L =
   -1/2 sum(log det S + nu' S^-1 nu)`` over one figure at a time (log scale: x 1/3 and
   x 3, the bracket widened while an end wins, then the vertex of the parabola through
   the best three; a white-noise figure never below its floor).  A figure moves only
   when the likelihood rises by more than 1.92 (the likelihood-ratio test at 95 %, one
   degree of freedom) and the held-back blocks' likelihood does not fall with it (a veto:
   the held-back blocks are therefore seen twice, here and at the acceptance).  The base
   config's figures are the starting point, not a constraint: a white-noise figure below
   its floor starts at the floor.  One data set
   holds one turn-on bias, not its spread, so the turn-on bias sigmas and the
   correlation times are never changed.
4. **Acceptance** — the tuned config replaces the untuned one (the base config's
   figures, else the file's, else a generic MEMS IMU) only if, on the held-back blocks,
   the innovation log-likelihood is not lower and no sensor's NIS/dof moves further out
   of [0.5, 2]; otherwise the base figures are kept and the result says why.
5. **Simulated outages** — GNSS withheld in a few windows of the held-back blocks (3 x
   30 s): the horizontal distance of the solution from the withheld fixes at each
   window's end, before and after tuning (reported; the held-back innovations decide).

Figures the user marks as fixed (``fixed``) are kept, whatever the data say; so are the
lever arms, the options and the sensor sigmas that the files or the base config give
(unless ``tune_sensors``).  Measurements that fault detection isolates (``fdi_alpha`` of
the base config) are left out of the matching, and every measurement's ``nu' S^-1 nu``
counts in the likelihood as itself up to its 99.9 % chi-square point and as its square
root beyond (:func:`huber`), so a few outliers do not set the noise figures.  Units: SI
(rad, m, s) as in the ``imu:`` section's SI keys (:class:`fednav.sensors.imu.ImuConfig`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from math import comb

import numpy as np

from ..core import attitude, earth
from ..core.config import ConfigError
from ..io.data import DataError, FixData, ImuData, VelocityData
from ..navigator.health import centralized_S
from ..navigator.system import System, _translate_legacy
from ..sensors import registry
from ..sensors.imu import FIGURES
from .run import (
    InnovationRecord,
    imu_figures,
    old_layout,
    own_section,
    process,
    recordings,
    with_imu_figures,
)

#: Starting IMU figures (a generic MEMS IMU) where neither the file nor the config has one.
MEMS_DEFAULTS = {"gyro_arw_rad_sqrt_s": 5.8e-4, "accel_vrw_mps_sqrt_s": 2.0e-3,
                 "gyro_bias_radps": 4.8e-4, "accel_bias_mps2": 2.0e-2,
                 "gyro_markov_radps": 4.8e-5, "accel_markov_mps2": 1.0e-3,
                 "gyro_tau_s": 100.0, "accel_tau_s": 100.0}
#: IMU figures estimated by the likelihood, in the order searched.
LIKELIHOOD_KEYS = ("accel_vrw_mps_sqrt_s", "gyro_arw_rad_sqrt_s", "accel_markov_mps2",
                   "gyro_markov_radps")
#: The white-noise figures (with a sample-scatter floor) and their per-sample spelling.
WHITE_KEYS = {"gyro_arw_rad_sqrt_s": "gyro_white_deg_h",
              "accel_vrw_mps_sqrt_s": "accel_white_ug"}
#: IMU figures tune never changes (one data set holds one draw of a turn-on bias).
KEPT_KEYS = ("gyro_bias_radps", "accel_bias_mps2", "gyro_tau_s", "accel_tau_s")


def sensor_keys() -> tuple[str, ...]:
    """The sensor sigmas tune may estimate, by their config key (each registered
    sensor's ``SensorSpec.tuned``: the GNSS's position and velocity, the velocity
    sensor's)."""
    return tuple(f"sensors.{n}.{k}" for n, s in registry.SENSORS.items() for k in s.tuned)


def old_sensor_keys() -> dict[str, str]:
    """Old spellings of those keys -> today's (each section's ``old_keys``; read with a
    FutureWarning for one more release)."""
    return {f"sensors.{n}.{o}": f"sensors.{n}.{k}" for n, s in registry.SENSORS.items()
            for o, k in s.config.old_keys.items() if k in s.tuned}


#: The sensor sigmas tune may estimate and their old spellings (fednav 0.2's names;
#: :func:`sensor_keys`, :func:`old_sensor_keys` follow the registry).
SENSOR_KEYS, OLD_SENSOR_KEYS = sensor_keys(), old_sensor_keys()
#: The band of NIS/dof a consistent filter's held-back innovations fall in.
NIS_BAND = (0.5, 2.0)
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
    """One figure: its config ``key``, ``start`` and written ``value`` (SI; a float or a
    3-list), how it was found and why; ``floor``: the least value the data's scatter
    supports (None where the scatter says nothing)."""

    key: str
    start: float | list
    value: float | list
    how: str
    floor: float | list | None = None


@dataclass
class Evaluation:
    """One filter run, per local filter: NIS/dof and log-likelihood of the fitted blocks
    (``nis_per_dof``, ``loglik``) and of the held-back ones (``nis_held``,
    ``loglik_held``), the matched R diagonal of the fitted blocks (residual order)."""

    loglik: float
    nis_per_dof: dict[str, float]
    matched: dict[str, np.ndarray]
    loglik_held: float = float("nan")
    nis_held: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class Blocks:
    """Alternating time blocks of ``length_s`` from ``t0``: even ones fitted, odd ones
    held back."""

    t0: float
    length_s: float

    def held(self, t) -> np.ndarray:
        return (np.floor((np.asarray(t, dtype=float) - self.t0) / self.length_s) % 2) == 1


@dataclass
class TuneResult:
    """The config to write (``config``: the tuned one if ``accepted``, else the base's
    figures), every figure, the untuned (``before``) and tuned (``after``) evaluations,
    the simulated outages (``outages``: (start, end) s) and the horizontal distance [m]
    from the withheld fixes at the end of each, untuned and tuned (``drift_before``,
    ``drift_after``); ``warnings`` (no lever arm, a sensor out of the NIS band) and
    ``notes``."""

    config: System
    figures: list[Figure]
    before: Evaluation
    after: Evaluation
    runs: int
    run_time_s: float
    notes: list[str] = field(default_factory=list)
    accepted: bool = True
    tuned: Evaluation | None = None
    blocks: Blocks | None = None
    outages: list[tuple[float, float]] = field(default_factory=list)
    drift_before: list[float] = field(default_factory=list)
    drift_after: list[float] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    fixed: set[str] = field(default_factory=set)
    #: the antenna lever arm of the fixes' file where the base config has none (written
    #: with it)
    lever_from_file: tuple | None = None
    #: the sensor whose fixes the figures were fitted to (None: the registry's,
    #: :func:`~fednav.sensors.registry.fix_sensor`)
    fix_sensor: str | None = None

    def summary(self) -> list[str]:
        """The before -> after lines the command prints and the config's header holds."""
        def nis(d):
            return ", ".join(f"{k} {v:.2f}" for k, v in d.items())

        b, a = self.before, self.after
        lines = [f"held-back NIS/dof (band {NIS_BAND[0]:g}..{NIS_BAND[1]:g}) before -> "
                 f"after: " + ", ".join(f"{k} {b.nis_held.get(k, np.nan):.2f} -> "
                                       f"{a.nis_held.get(k, np.nan):.2f}"
                                       for k in a.nis_held),
                 f"held-back log-likelihood before -> after: {b.loglik_held:.1f} -> "
                 f"{a.loglik_held:.1f}; fitted blocks NIS/dof: {nis(b.nis_per_dof)} -> "
                 f"{nis(a.nis_per_dof)}"]
        if self.outages:
            lines.append(
                f"drift through {len(self.outages)} simulated GNSS outages of "
                f"{self.outages[0][1] - self.outages[0][0]:.0f} s (horizontal distance from "
                f"the withheld fixes at the end; mean, max) before -> after: "
                f"{np.mean(self.drift_before):.2f} m, {np.max(self.drift_before):.2f} m -> "
                f"{np.mean(self.drift_after):.2f} m, {np.max(self.drift_after):.2f} m")
        if not self.accepted:
            lines.append("the tuned figures fit the held-back blocks worse than the untuned "
                         "ones: the untuned figures are kept")
        return lines


def white_noise(x: np.ndarray, dt: float) -> np.ndarray:
    """White-noise density [unit * sqrt(s)] of each column of samples ``x`` (N, k) taken
    every ``dt`` [s], from the robust scatter of their first differences."""
    d = np.diff(np.asarray(x, dtype=float), axis=0)
    mad = np.median(np.abs(d - np.median(d, axis=0)), axis=0)
    return 1.4826 * mad / np.sqrt(2.0) * np.sqrt(dt)


def scatter(x: np.ndarray, order: int) -> np.ndarray:
    """1-sigma of the white part of each column of ``x`` (N, k) from the robust scatter
    of its ``order``-th differences (which cancel a polynomial motion of degree
    ``order - 1``; white noise has variance ``C(2 order, order) sigma^2`` there)."""
    d = np.diff(np.asarray(x, dtype=float), order, axis=0)
    if len(d) < 3:
        return np.zeros(d.shape[1])
    mad = np.median(np.abs(d - np.median(d, axis=0)), axis=0)
    return 1.4826 * mad / np.sqrt(comb(2 * order, order))


def white_noise_floor(x: np.ndarray, dt: float, n_per: int) -> float:
    """The least white-noise density [unit * sqrt(s)] the samples ``x`` (N, 3) support:
    per axis the smaller of the density from the sample-to-sample scatter and that from
    the scatter of the means over ``n_per`` samples (the filter period; vibration above
    the filter's bandwidth averages out there), the largest axis (the figure is one for
    all axes)."""
    x = np.asarray(x, dtype=float)
    fast = white_noise(x, dt)
    m = len(x) // n_per * n_per
    if n_per > 1 and m // n_per > 10:
        means = x[:m].reshape(-1, n_per, x.shape[1]).mean(axis=1)
        slow = scatter(means, 2) * np.sqrt(n_per * dt)
        fast = np.minimum(fast, slow)
    return float(np.max(fast))


def _cap(dof: int) -> float:
    from ..core.stats import chi2_ppf

    return float(chi2_ppf(_CAP_P, dof))


def huber(q, cap: float):
    """A measurement's statistic ``q`` as the likelihood counts it: itself up to ``cap``,
    beyond it growing as its square root (Huber's loss on the normalized innovation's
    size, ``2 sqrt(cap q) - cap``), so that a few outliers do not set the figures and a
    filter whose innovations are all far larger than its covariance says is not scored
    as if each were at the cap (a flat penalty would reward a covariance too small)."""
    q = np.asarray(q, dtype=float)
    return np.where(q <= cap, q, 2.0 * np.sqrt(cap * np.maximum(q, cap)) - cap)


def innovation_statistics(inns: list[InnovationRecord],
                          blocks: Blocks | None = None) -> Evaluation:
    """Sum up one filter run's innovations, fitted blocks and held-back ones."""
    ll = ll_held = 0.0
    nis, nis_held, matched = {}, {}, {}
    for local in dict.fromkeys(i.local for i in inns):
        mine = [i for i in inns if i.local == local]
        sums = np.zeros(4)  # q and dof over the fitted, then the held-back measurements
        sizes = sorted({len(i.r) for i in mine})
        for d in sizes:  # (a raw GNSS epoch's rows vary with its satellites)
            same = [i for i in mine if len(i.r) == d]
            r = np.array([i.r for i in same])
            R = np.array([i.R for i in same])
            beta = np.array([i.beta for i in same])[:, None, None]
            Sc = centralized_S([i.S for i in same], R, beta)
            L = np.linalg.cholesky(Sc)
            w = np.linalg.solve(L, r[..., None])[..., 0]
            q = np.einsum("ij,ij->i", w, w)
            cap = _cap(d)
            logdet = 2.0 * np.log(np.diagonal(L, axis1=1, axis2=2)).sum(axis=1)
            each = -0.5 * (logdet + huber(q, cap) + d * np.log(2 * np.pi))
            held = (np.zeros(len(same), dtype=bool) if blocks is None
                    else blocks.held([i.t for i in same]))
            fit = ~held
            ll += float(np.sum(each[fit]))
            ll_held += float(np.sum(each[held]))
            sums += [q[fit].sum(), d * fit.sum(), q[held].sum(), d * held.sum()]
            use = np.array([i.accepted for i in same]) & (q <= cap) & fit
            if use.any() and len(sizes) == 1:
                hph = np.diagonal(Sc - R, axis1=1, axis2=2)
                matched[local] = np.mean(r[use] ** 2, axis=0) - np.mean(hph[use], axis=0)
        if sums[1]:
            nis[local] = float(sums[0] / sums[1])
        if sums[3]:
            nis_held[local] = float(sums[2] / sums[3])
    return Evaluation(ll, nis, matched, ll_held if blocks is not None else float("nan"),
                      nis_held)


def evaluate(imu: ImuData, sensors: dict, cfg: System,
             blocks: Blocks | None = None) -> Evaluation:
    """Run the forward filter with ``cfg`` on ``sensors`` (series by registered name) and
    sum up its innovations (all of them fitted without ``blocks``)."""
    inns: list[InnovationRecord] = []
    process(imu, sensors, as_given(cfg), innovations=inns,
            force=True)  # (candidates may fit badly)
    return innovation_statistics(inns, blocks)


def as_given(cfg: System) -> System:
    """``cfg`` flown with its figures as they are (tune's candidates are not identified
    again: :mod:`fednav.process.identify`)."""
    return cfg.model_copy(update={"noise": "as-given"})


def withheld(fixes: FixData, windows) -> FixData:
    """``fixes`` without those inside the ``windows`` ((start, end) s)."""
    out = np.zeros(len(fixes.t), dtype=bool)
    for a, b in windows:
        out |= (fixes.t >= a) & (fixes.t <= b)
    keep = ~out

    def sub(a):
        return None if a is None else a[keep]

    g = replace(fixes, t=fixes.t[keep], lla=sub(fixes.lla), vel=sub(fixes.vel),
                sigma_rows=sub(fixes.sigma_rows), t_arrival=sub(fixes.t_arrival), quality={})
    g.quality = dict(fixes.quality)
    return g


def outage_drift(imu: ImuData, sensors: dict, cfg: System, windows) -> list[float]:
    """Process ``sensors`` (series by registered name) with the fixes (the GNSS's:
    :func:`~fednav.sensors.registry.fix_sensor`) of ``windows`` withheld; the horizontal
    distance [m] of the solution (moved to the antenna) from the last withheld fix of
    each window."""
    fx = registry.fix_sensor(sensors)
    fixes = sensors[fx]
    res = process(imu, {**sensors, fx: withheld(fixes, windows)}, as_given(cfg), force=True)
    sol = res.forward
    fc = own_section(fx, cfg)
    lever = np.asarray(fc.lever_m if fc.lever_m is not None else fixes.lever, dtype=float)
    out = []
    for a, b in windows:
        inside = np.flatnonzero((fixes.t >= a) & (fixes.t <= b))
        j = inside[-1]
        i = int(np.clip(np.searchsorted(sol.t, fixes.t[j]), 0, len(sol.t) - 1))
        lla, _ = earth.lever_arm_point(sol.lla[i], sol.vel[i],
                                       attitude.euler_to_dcm(sol.euler[i]), sol.omega[i],
                                       lever)
        fix = fixes.lla[j]
        d = earth.llh_difference_enu(lla[0], lla[1], lla[2], fix[0], fix[1], fix[2])
        out.append(float(np.hypot(d[0], d[1])))
    return out


def flown_figures(imu: ImuData, system: System) -> dict[str, float | None]:
    """Every IMU figure ``process`` flies with ``system`` (SI keys: the description's,
    else the file's, else the grade preset's; None where none gives it), a per-sample
    white figure as the density it adds up to."""
    out = imu_figures(imu, system)
    dt = imu.period()
    if system.imu.gyro_white_deg_h is not None:  # a per-sample figure adds to the density
        out["gyro_arw_rad_sqrt_s"] = system.imu.arw(dt)
    if system.imu.accel_white_ug is not None:
        out["accel_vrw_mps_sqrt_s"] = system.imu.vrw(dt)
    return out


def with_figures(system: System, figures: dict[str, float]) -> System:
    """``system`` with these IMU figures (SI keys) in its ``imu:`` section, their
    engineering and per-sample spellings cleared."""
    eng = {si: e for e, _, si in FIGURES.values()}
    update = {}
    for k, v in figures.items():
        update.update({k: float(v), eng[k]: None})
        if k in WHITE_KEYS:  # (its per-sample spelling)
            update[WHITE_KEYS[k]] = None
    return system.model_copy(update={"imu": system.imu.model_copy(update=update)})


def _starting_imu(imu: ImuData, base: System, notes: list) -> dict[str, float]:
    """The untuned IMU figures: what ``process`` flies with ``base`` (its figures, else the
    file's, else the grade preset it assumes when neither gives any), the generic MEMS
    IMU's for the rest."""
    try:
        base, assumed = with_imu_figures(imu, base)
        notes.extend(assumed)
    except DataError:  # some figures given, not all: process would refuse; tune fills them
        pass
    out = flown_figures(imu, base)
    generic = [k for k, v in out.items() if v is None]
    if generic:
        out.update({k: MEMS_DEFAULTS[k] for k in generic})
        notes.append("not in the file or the config, started from a generic MEMS IMU: "
                     + ", ".join(f"{k} {MEMS_DEFAULTS[k]:g}" for k in generic))
    return out


def fixed_keys(names) -> set[str]:
    """The figures ``names`` marks as fixed, by their SI key (``imu:`` keys, in any of
    their spellings, with or without ``imu.``; ``imu`` for all of them) or sensor key
    (:func:`sensor_keys`, with or without ``sensors.``: ``sensors.gnss.sigma_pos_enu_m``,
    ``gnss.sigma_vel_mps``, ``velocity.sigma_mps``; a sensor's name for its every sigma;
    the old spellings of :func:`old_sensor_keys` with a ``FutureWarning``).  A
    :class:`ConfigError` names one that is none of these."""
    import warnings

    alias = {}
    for fig, (eng, _, si) in FIGURES.items():
        for a in (fig, eng, si):
            alias[a] = {si}
    alias["imu"] = {si for _, _, si in FIGURES.values()}
    for white, si in ((v, k) for k, v in WHITE_KEYS.items()):
        alias[white] = {si}
    keys, renamed = sensor_keys(), old_sensor_keys()
    whole = list(dict.fromkeys(key.split(".")[1] for key in keys))
    for key in keys:
        alias[key] = {key}
        alias[key.removeprefix("sensors.")] = {key}
        alias.setdefault(key.split(".")[1], set()).add(key)
    for old, new in renamed.items():
        alias[old] = alias[old.removeprefix("sensors.")] = {new}
    out: set[str] = set()
    for n in names or ():
        k = str(n).strip()
        k = k.removeprefix("imu.") if k != "imu." else k
        if k not in alias:
            raise ConfigError(f"--fix {n}: not a figure tune estimates; give an imu: key "
                              f"(e.g. gyro_arw_deg_sqrt_h, accel_markov_mps2; 'imu' for all), "
                              f"{', '.join(keys)}, or a sensor's name for all of its "
                              f"sigmas ({', '.join(map(repr, whole))})")
        old = "sensors." + k.removeprefix("sensors.")
        if old in renamed:
            warnings.warn(f"--fix {n}: the key is now {renamed[old]} (read for one "
                          f"more release)", FutureWarning, stacklevel=2)
        out |= alias[k]
    return out


def _split(fixes: FixData, velocity: VelocityData | None, block_s: float, n_out: int,
           outage_s: float) -> tuple[Blocks, list[tuple[float, float]]]:
    """The blocks (at least four over the aiding data) and the outage windows: one in
    the middle of each of ``n_out`` held-back blocks spread over the run, of at most half
    a block, where there are GNSS positions to withhold."""
    ts = [d.t for d in (fixes, velocity) if d is not None and len(d.t)]
    t0 = float(min(t[0] for t in ts))
    t1 = float(max(t[-1] for t in ts))
    length = float(min(block_s, (t1 - t0) / 4.0)) if t1 > t0 else block_s
    blocks = Blocks(t0, length)
    windows: list[tuple[float, float]] = []
    if fixes is not None and fixes.lla is not None and n_out > 0:
        odd = [k for k in range(1, int((t1 - t0) // length) + 1, 2)
               if t0 + (k + 1) * length <= t1 + 1e-9]
        pick = sorted({int(round(x)) for x in np.linspace(0, len(odd) - 1, min(n_out,
                                                                              len(odd)))})
        w = min(outage_s, 0.5 * length)
        for p in pick if odd else []:
            mid = t0 + (odd[p] + 0.5) * length
            a, b = mid - 0.5 * w, mid + 0.5 * w
            if np.count_nonzero((fixes.t >= a) & (fixes.t <= b)):
                windows.append((a, b))
    return blocks, windows


def _band_excess(nis: float) -> float:
    """How far (log) a NIS/dof lies outside :data:`NIS_BAND` (0 inside)."""
    if not np.isfinite(nis) or nis <= 0:
        return np.inf
    return max(0.0, float(np.log(nis / NIS_BAND[1])), float(np.log(NIS_BAND[0] / nis)))


def worse(after: Evaluation, before: Evaluation) -> str | None:
    """Why ``after`` fits the held-back blocks worse than ``before``, or None."""
    if after.loglik_held < before.loglik_held:
        return (f"held-back log-likelihood {before.loglik_held:.1f} -> "
                f"{after.loglik_held:.1f}, {after.loglik_held - before.loglik_held:+.2g}")
    for k, v in after.nis_held.items():
        b = before.nis_held.get(k, np.nan)
        if _band_excess(v) > _band_excess(b) + 1e-9:
            return (f"held-back NIS/dof of {k} {b:.2f} -> {v:.2f}, further out of "
                    f"{NIS_BAND[0]:g}..{NIS_BAND[1]:g}")
    return None


@old_layout("base", "matching_passes", "progress")
def tune(imu: ImuData, sensors: dict, base: System | None = None, matching_passes: int = 2,
         progress=None, *,
         fixed=(), tune_sensors: bool = False, sigma_from_file=(),
         block_s: float = 60.0, outages: int = 3, outage_s: float = 30.0) -> TuneResult:
    """Tune the noise figures of ``base`` (default :class:`System`) on the data (see the
    module docstring).

    ``fixed``: figures kept as they are (:func:`fixed_keys`); ``tune_sensors``: estimate
    the sensor sigmas the base config or the files give too (those that no one gives are
    always estimated); ``sigma_from_file``: the sensors whose files give their sigma
    (``"gnss"``: e.g. NaveGo's ``stdm``/``stdv``; a GNSS CSV's sigma columns and a
    velocity file's sigma are seen without it); ``block_s``: the length of the fitted
    and held-back blocks [s]; ``outages`` windows of ``outage_s`` [s] withheld to measure
    the drift.  ``progress(text)`` is called before each filter run.  ``sensors``: every
    sensor's series by registered name (the fixes of the sensor that starts a run
    needed, the GNSS's; the sigma of another sensor tune estimates, the velocity
    sensor's, is tuned too; the other sensors fly with their sections' figures)."""
    t_start = time.perf_counter()
    base = base or System()
    recs = recordings(sensors, base)
    fx = registry.fix_sensor(recs)
    vn = next((n for n in recs if registry.spec(n).tuned and not registry.spec(n).fixes),
              None)
    fixes, velocity = recs.get(fx), recs.get(vn)
    if fixes is None or fixes.lla is None:
        who = registry.fix_sensor()
        raise DataError(f"fednav tune: needs {registry.label(who)} positions "
                        f"(sensors['{who}']): the figures are fitted to their innovations")
    notes: list[str] = []
    warns: list[str] = []
    runs = 0
    dt = imu.period()
    fc, vc = own_section(fx, base), None if vn is None else own_section(vn, base)
    # the keys of the fix sensor's position and velocity sigma, the velocity sensor's
    k_pos, k_vel = (f"sensors.{fx}.{k}" for k in registry.spec(fx).tuned)
    k_v = None if vn is None else f"sensors.{vn}.{registry.spec(vn).tuned[0]}"
    fixed = fixed_keys(fixed)
    if fc.lever_m is None and not np.any(fixes.lever):
        warns.append(f"no {registry.label(fx)} antenna lever arm is set (sensors.{fx}.lever_m, "
                     f"nor in the file): the figures are estimated for an antenna at the "
                     f"IMU — a lever arm left out is absorbed into them; give it in the base "
                     f"config, and process with a config that has it")
    blocks, windows = _split(fixes, velocity, block_s, outages, outage_s)
    # -- the sensor sigmas: which are given (kept unless tune_sensors), which are free
    from_file = set(sigma_from_file or ())
    rows = fixes.sigma_rows is not None
    given = {k_pos: fc.sigma_pos_enu_m is not None or rows or fx in from_file,
             k_vel: fc.sigma_vel_mps is not None or rows or fx in from_file}
    if k_v is not None:
        given[k_v] = True
    free = {k: k not in fixed and (tune_sensors or not v) for k, v in given.items()}
    if rows and tune_sensors:
        free[k_pos] = free[k_vel] = False
        notes.append(f"{fixes.source} gives each fix's 1-sigma, which processing uses over "
                     f"the config's: the {registry.label(fx)} sigmas are kept")
    # Sensor noise variances in the order of the residuals: fixes [E, N, U] m, [E, N, U]
    # m/s (the components the file has); velocity sensor [E, N, U] m/s.
    v_adj = None if velocity is None else velocity.adjusted(vc)
    pos0 = np.broadcast_to(np.asarray(fixes.sigma_pos_enu if fc.sigma_pos_enu_m is None
                                      else fc.sigma_pos_enu_m, dtype=float), (3,))
    vel0 = np.broadcast_to(np.asarray(fixes.sigma_vel if fc.sigma_vel_mps is None
                                      else fc.sigma_vel_mps, dtype=float), (3,))
    r_fix = np.r_[pos0, vel0] ** 2
    has = np.r_[np.full(3, fixes.lla is not None and fc.measures != "velocity"),
                np.full(3, fixes.vel is not None and fc.measures != "position")]
    free_g = np.r_[np.full(3, free[k_pos]), np.full(3, free[k_vel])] & has
    r_vel = None
    if velocity is not None:
        r_vel = np.square(vc.sigma_mps) if vc.sigma_mps is not None \
            else np.median(np.diagonal(v_adj.cov, axis1=1, axis2=2), axis=0)
    start_r = (r_fix.copy(), None if r_vel is None else r_vel.copy())
    free_v = velocity is not None and free[k_v]
    # -- floors: what the data's own scatter supports
    floor_g = np.zeros(6)
    if fixes.lla is not None:
        ll = fixes.lla
        floor_g[:3] = scatter(earth.llh_difference_enu(ll[:, 0], ll[:, 1], ll[:, 2], ll[0, 0],
                                                       ll[0, 1], ll[0, 2]), 3)
    if fixes.vel is not None:
        floor_g[3:] = scatter(fixes.vel, 2)
    floor_v = None if velocity is None else scatter(v_adj.vel, 2)
    period = base.filter.period_s or (float(np.median(np.diff(fixes.t))) if len(fixes.t) > 1
                                      else dt)
    n_per = max(1, int(round(period / dt)))
    floor_imu = {"gyro_arw_rad_sqrt_s": white_noise_floor(imu.gyro, dt, n_per),
                 "accel_vrw_mps_sqrt_s": white_noise_floor(imu.accel, dt, n_per)}
    from_scatter = {"gyro_arw_rad_sqrt_s": float(np.max(white_noise(imu.gyro, dt))),
                    "accel_vrw_mps_sqrt_s": float(np.max(white_noise(imu.accel, dt)))}

    given_imu = imu_figures(imu, base)

    def config(fig_imu, rg, rv):
        """``base`` with these IMU figures and sensor variances (residual order)."""
        tuned = with_figures(base, {si: v for si, v in fig_imu.items()
                                    if not (si in fixed and given_imu[si] is not None)})
        sensors = {}
        if fx in base.sensors or np.any(free_g):
            sd = np.sqrt(rg)
            up = {}
            if free[k_pos] and has[0]:
                up["sigma_pos_enu_m"] = tuple(map(float, sd[:3]))
            if free[k_vel] and has[3]:
                up["sigma_vel_mps"] = tuple(map(float, sd[3:]))
            sensors[fx] = fc.model_copy(update=up)
        if free_v:
            sensors[vn] = vc.model_copy(update={
                "sigma_mps": tuple(map(float, np.sqrt(rv)))})
        return tuned.model_copy(update={
            "sensors": base.sensors.replace(**sensors) if sensors else base.sensors})

    def run(fig_imu, rg, rv, what):
        nonlocal runs
        runs += 1
        if progress is not None:
            progress(what)
        return evaluate(imu, recs, config(fig_imu, rg, rv), blocks)

    def match(rg, rv, ev):
        """Covariance matching of the free sensor variances on the fitted blocks, never
        below the floor (nor below 1e-3 of the current value: one pass cannot zero a
        variance)."""
        if fx in ev.matched and np.any(free_g):
            m = np.full(6, np.nan)
            m[has] = ev.matched[fx]
            rg = np.where(free_g, np.maximum.reduce([m, floor_g ** 2, 1e-3 * rg]), rg)
        if free_v and vn in ev.matched:
            rv = np.maximum.reduce([ev.matched[vn], floor_v ** 2, 1e-3 * rv])
        return rg, rv

    start_imu = _starting_imu(imu, base, notes)
    fig_imu = dict(start_imu)
    figures: list[Figure] = []
    # The untuned config: the base's figures as they are (the file's, else generic).
    before = run(start_imu, r_fix, r_vel, "untuned figures")
    # 1. The white noise: from the sample scatter where no one gave it; a figure given
    # below the floor starts at the floor.
    raised = {}
    for key, s in from_scatter.items():
        if key in fixed:
            continue
        if given_imu[key] is None and getattr(base.imu, WHITE_KEYS[key]) is None:
            fig_imu[key] = max(s, floor_imu[key])
        elif fig_imu[key] < floor_imu[key]:
            raised[key] = fig_imu[key]
            fig_imu[key] = floor_imu[key]
    # 2. Aiding-sensor noise by covariance matching (the first pass from the untuned run).
    ev = before
    if np.any(free_g) or free_v:
        for p in range(matching_passes):
            r_fix, r_vel = match(r_fix, r_vel, ev)
            ev = run(fig_imu, r_fix, r_vel, f"covariance matching {p + 1}")
    elif fig_imu != start_imu:
        ev = run(fig_imu, r_fix, r_vel, "white noise at its floor")
    # 3. IMU process noise by the likelihood, one figure at a time.
    for key in LIKELIHOOD_KEYS:
        floor = floor_imu.get(key)
        if key in fixed:
            how = "kept: marked fixed"
            if floor is not None and start_imu[key] < floor:
                how += f" (below the floor {floor:.3g} the sample scatter supports)"
            figures.append(Figure(f"imu.{key}", start_imu[key], start_imu[key], how, floor))
            continue
        origin = ("raised to the sample-scatter floor" if key in raised else
                  "sample scatter" if fig_imu[key] != start_imu[key] else "start")
        ev, figure = _search(key, fig_imu, ev, lambda f, what: run(f, r_fix, r_vel, what),
                             origin, floor)
        figure.start = start_imu[key]
        figure.floor = floor
        figures.append(figure)
    # 4. The sensor noise again, with the process noise found.
    if np.any(free_g) or free_v:
        r_fix, r_vel = match(r_fix, r_vel, ev)
        ev = run(fig_imu, r_fix, r_vel, "covariance matching, final")
    tuned = ev
    sd0, sd = np.sqrt(start_r[0]), np.sqrt(r_fix)
    fl = floor_g
    sensors = []
    if has[0]:
        sensors.append((k_pos, sd0[:3], sd[:3], fl[:3]))
    if has[3]:
        sensors.append((k_vel, sd0[3:], sd[3:], fl[3:]))
    if r_vel is not None:
        sensors.append((k_v, np.sqrt(start_r[1]), np.sqrt(r_vel),
                        floor_v))
    for key, s0, s1, f in sensors:
        _, name, k = key.split(".")
        who = "the base config" if getattr(own_section(name, base), k) is not None \
            else "the file"
        how = ("kept: marked fixed" if key in fixed else
               "innovation covariance matching on the fitted blocks, floored at the "
               "scatter of the data" if free[key] else
               f"kept: {who} gives it" + ("" if rows and name == fx
                                          else " (--tune-sensors estimates it)"))
        figures.append(Figure(key, [float(x) for x in s0], [float(x) for x in s1], how,
                              [float(x) for x in f]))
    for key in KEPT_KEYS:
        figures.append(Figure(f"imu.{key}", start_imu[key], fig_imu[key],
                              "kept: marked fixed" if key in fixed else
                              "kept: one data set holds one draw of it, not its spread"))
    # 5. Acceptance on the held-back blocks.
    tuned_cfg = config(fig_imu, r_fix, r_vel)
    start_cfg = config(start_imu, *start_r)
    why = worse(tuned, before)
    accepted = why is None
    if not accepted:
        notes.append(f"the tuned figures fit the held-back blocks worse ({why}): the untuned "
                     f"figures are kept")
        for f in figures:
            if f.value != f.start:
                f.how = f"not applied: {format_value(f.value)}, {f.how}"
                f.value = f.start
    after = tuned if accepted else before
    for k, v in after.nis_held.items():
        if _band_excess(v) > 0:
            warns.append(f"held-back NIS/dof of {k} is {v:.2f}, outside "
                         f"{NIS_BAND[0]:g}..{NIS_BAND[1]:g}: its noise model does not "
                         f"describe its errors (time-correlated errors? a sigma kept from "
                         f"the file or the config?)")
    # 6. Drift through simulated outages.
    drift_before = drift_after = []
    if windows:
        if progress is not None:
            progress("simulated GNSS outages, untuned")
        drift_before = outage_drift(imu, recs, start_cfg, windows)
        runs += 1
        if accepted:
            if progress is not None:
                progress("simulated GNSS outages, tuned")
            drift_after = outage_drift(imu, recs, tuned_cfg, windows)
            runs += 1
        else:
            drift_after = drift_before
        if np.mean(drift_after) > 1.25 * np.mean(drift_before):
            notes.append(
                f"the drift through the simulated outages grew with the tuned figures "
                f"({np.mean(drift_before):.2f} m -> {np.mean(drift_after):.2f} m, mean): over "
                f"a few outages partly chance (both runs integrate the same IMU samples; "
                f"only the state at each outage's start differs)"
                + ("; sensor sigmas matched to time-correlated errors make the filter "
                   "follow them (keep the given ones: no --tune-sensors)"
                   if np.any(free_g) or free_v else ""))
    lever = (tuple(map(float, fixes.lever)) if fc.lever_m is None and np.any(fixes.lever)
             else None)
    return TuneResult(tuned_cfg if accepted else start_cfg, figures, before, after, runs,
                      time.perf_counter() - t_start, notes, accepted, tuned, blocks,
                      windows, drift_before, drift_after, warns, fixed, lever, fx)


def _search(key: str, fig_imu: dict, ev: Evaluation, run, origin: str,
            floor: float | None = None):
    """Maximise the fitted blocks' likelihood over ``fig_imu[key]`` (log scale, never
    below ``floor``) from the evaluation ``ev`` of the current figures; ``fig_imu`` is
    updated in place when the best value beats the current one by more than
    :data:`LR_95` and the held-back blocks' likelihood does not fall with it.  Returns
    (evaluation of the figures kept, :class:`Figure`)."""
    x0 = float(np.log(fig_imu[key]))
    low = -np.inf if not floor else float(np.log(floor)) - x0
    tried = {0.0: ev}

    def at(u):
        u = max(u, low)
        if u not in tried:
            tried[u] = run({**fig_imu, key: float(np.exp(x0 + u))},
                           f"likelihood of imu.{key} x {np.exp(u):.3g}")
        return tried[u].loglik

    if low < -1e-9:
        at(-_STEP)
    at(_STEP)
    for _ in range(6):  # widen while an end of the bracket wins (by more than noise)
        us = sorted(tried)
        best = max(tried, key=at)
        if best not in (us[0], us[-1]) or at(best) - tried[0.0].loglik < _WIDEN:
            break
        if best == us[0] and best <= low + 1e-9:
            break  # at the floor
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
                best = max(vertex, low)
    gain = at(best) - tried[0.0].loglik
    lo, hi = float(np.exp(min(tried))), float(np.exp(max(tried)))
    if gain <= LR_95:
        return ev, Figure(f"imu.{key}", fig_imu[key], fig_imu[key],
                          f"kept ({origin}): likelihood at most {gain:+.1f} "
                          f"over x{lo:.2g}..x{hi:.2g}")
    held = tried[best].loglik_held - tried[0.0].loglik_held
    if held < 0:  # what the fitted blocks gained, the held-back ones lose: not moved
        return ev, Figure(f"imu.{key}", fig_imu[key], fig_imu[key],
                          f"kept ({origin}): x{np.exp(best):.2g} gains {gain:+.1f} on the "
                          f"fitted blocks but {held:+.1f} on the held-back ones")
    start = fig_imu[key]
    fig_imu[key] = float(np.exp(x0 + best))
    at_floor = " (at the floor)" if floor and best <= low + 1e-9 else ""
    return tried[best], Figure(f"imu.{key}", start, fig_imu[key],
                               f"innovation likelihood: {gain:+.1f} over the "
                               f"{origin} value{at_floor}")


def config_yaml(res: TuneResult, base: dict | None = None, header: str = "") -> str:
    """The tuned config as YAML for ``fednav process --config``: the ``base`` mapping
    (the user's config, kept key for key but for the figures tune changed, written by
    their SI key) with a comment per figure, the held-back scores and the warnings."""
    import warnings

    import yaml

    with warnings.catch_warnings():  # the user's old keys are written in today's places
        warnings.simplefilter("ignore", FutureWarning)
        data = _translate_legacy(dict(base or {}))
        old = data.get("sensors")
        if isinstance(old, dict):
            data["sensors"] = {n: registry.spec(n).config.renamed_keys(v, f"sensors.{n}")
                               if n in registry.SENSORS and isinstance(v, dict) else v
                               for n, v in old.items()}
    c = res.config
    imu = dict(data.get("imu") or {})
    changed = {f.key.removeprefix("imu.") for f in res.figures
               if f.key.startswith("imu.") and f.value != f.start}
    for fig, (eng, _, si) in FIGURES.items():
        spelled = [k for k in (eng, si, WHITE_KEYS.get(si)) if k and k in imu]
        if spelled and si not in changed:
            continue  # the user's own, unchanged or marked fixed: as given
        v = c.imu.si(fig)
        if v is None:
            continue
        for k in spelled:
            del imu[k]
        imu[si] = float(f"{v:.6g}")
    data["imu"] = imu
    sensors = {k: dict(v or {}) for k, v in (data.get("sensors") or {}).items()}
    written = {f.key for f in res.figures if f.how.startswith("innovation covariance")}
    for key in written:
        _, name, k = key.split(".")
        v = getattr(c.sensors.get(name), k)
        sensors.setdefault(name, {})[k] = [float(f"{x:.6g}") for x in v]
    fx = res.fix_sensor or registry.fix_sensor()
    fc = c.sensors[fx] if fx in c.sensors else None
    if (fc is None or fc.lever_m is None) and res.lever_from_file is not None:
        sensors.setdefault(fx, {})["lever_m"] = [float(f"{x:.6g}")
                                                 for x in res.lever_from_file]
    if sensors:
        data["sensors"] = sensors
    data["noise"] = "as-given"  # (the figures tune chose, flown as they are)
    lines = [f"# {line}" for line in header.splitlines()]
    lines += [f"# {line}" for line in res.summary()]
    for f in res.figures:
        lines.append(f"# {f.key}: {format_value(f.start)} -> {format_value(f.value)} "
                     f"({f.how})")
    for n in res.warnings:
        lines.append(f"# WARNING: {n}")
    for n in res.notes:
        lines.append(f"# note: {n}")
    return "\n".join(lines) + "\n" + yaml.safe_dump(data, sort_keys=False)


def format_value(v) -> str:
    """A figure (a number or a 3-list) to 3 significant digits."""
    if v is None:
        return "-"
    if isinstance(v, (list, tuple, np.ndarray)):
        return "[" + ", ".join(f"{x:.3g}" for x in v) + "]"
    return f"{v:.3g}"

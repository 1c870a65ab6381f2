"""The IMU's process noise identified from the recording itself (``fednav process``'s
default; ``--noise as-given`` keeps the figures as given).

A datasheet's white noise and bias instability are a quiet bench's; on a vehicle,
vibration makes a MEMS IMU's noise 10-70 times larger, and a filter flown with the
datasheet's figures is overconfident (its innovations many times their predicted size).
Offline, the whole recording is there before the final pass, so the figures of *this*
IMU on *this* vehicle are estimated from it, with the given figures as prior and floor:

1. **Only where the given figures fail.**  A first pass flies the given figures.  Unless
   some local filter's mean NIS/dof lies above the health band (``health.nis_band``,
   0.5..2: innovations larger than the figures allow), they are flown as given and the
   report says why: a description the recording does not contradict is not re-tuned,
   and one whose innovations are only *smaller* than predicted points at a sensor sigma
   larger than its data's (a conservative receiver), not at the IMU — the given figures
   are never lowered.  Where the filter's own uncertainty fills those innovations
   (:func:`own_share` above 1: a short recording, an uncertain start) the report says
   that instead: they then say little about the sensor's sigma.
2. **E-step.**  The forward filter and the RTS smoother over the recording give, for
   every filter interval, the expected outer product of the process noise given every
   measurement, ``W_k`` (:func:`fednav.filters.smoother.noise_moments`; Shumway &
   Stoffer 1982), over the states the figures drive (attitude, velocity, the
   Gauss–Markov biases), on the chain folded to the epochs that took a measurement
   (:func:`folded`: between them nothing is measured or fed back, so the intervals
   compose exactly, and a 20 Hz filter under 4 Hz fixes has a fifth of the epochs to
   smooth).
3. **M-step.**  The interval's noise is ``Q_k = sum_j s_j B_jk + rest_k``, each figure's
   part ``B_jk`` discretized as the filter does (:func:`noise_parts`); the variance
   factors ``s_j`` come from the expected likelihood's fixed point
   (:func:`variance_factors`; each interval's ``W_k`` shrunk at the 99.9 % chi-square
   point: a wrong fix does not set the figures).  Steps are taken in the logarithm,
   accelerated by secant steps in EM's direction (at most :data:`ACCELERATION` times
   EM's own step, :data:`MAX_STEP` per pass), until no figure's EM step exceeds
   :data:`TOLERANCE` or after :data:`MAX_PASSES` passes.
4. **Start and floor.**  A white noise starts at what the samples' own scatter supports
   where that is more than given (:func:`scatter_figures`: the data's direct measure of
   it), a bias instability at the given figure; no figure goes below the given one.
   Correlation times and turn-on biases are kept.
5. **Held back.**  The recording is cut into alternating 60 s blocks; only the even
   ones' intervals are fitted, the odd ones score: the identified figures replace the
   given ones only if the held-back innovations' log-likelihood does not fall by more
   than the likelihood-ratio test's 95 % point and no sensor's held-back NIS/dof moves
   further out of the band (:func:`fednav.process.tuning.worse`).

The sensors' sigmas are kept, except with ``noise: identify-all``: there the sigmas
that no file gives (the system description's, for a receiver that reports none) are
identified beside the IMU's figures (:func:`sigma_parts`), each row's expected noise
outer product given every measurement, ``(nu - H x)(nu - H x)' + H Ps H'`` with the
smoothed error ``x`` of the predicted solution, set against its R (:func:`sigma_factors`,
EM's M-step for R), the given sigmas their floor.  It is not the default: EM creeps
along the ridge where a measurement's white noise and the IMU's random walk explain
the same innovations (a GNSS velocity sigma and the VRW, on simulated data: the
likelihood is higher at the truth, but EM stops before it), and on the rover it made
the velocity columns worse than identifying the IMU alone (docs/real-data.md).  A
sigma the file gives (the receiver's own) is always kept.

What the navigator flies with is the identified figures; the report
(:class:`Identified`) gives prior -> identified, NIS/dof before -> after and the cost.
Units: SI keys of the ``imu:`` section (rad/sqrt(s), m/s/sqrt(s), rad/s, m/s^2); a
sensor's sigma, ``sensors.NAME.HEADER`` in the unit of its column's header.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..core.errors import FednavError
from ..filters.smoother import noise_moments, rts_smooth
from ..io.data import ImuData
from ..navigator.system import System
from .tuning import (
    Blocks,
    flown_figures,
    innovation_statistics,
    white_noise_floor,
    with_figures,
    worse,
)

#: Each identified figure (SI key of the ``imu:`` section) and the error-state block its
#: noise drives (the 18 states of :mod:`fednav.ins.error_model`).
BLOCKS = {"gyro_arw_rad_sqrt_s": slice(0, 3), "accel_vrw_mps_sqrt_s": slice(3, 6),
          "gyro_markov_radps": slice(12, 15), "accel_markov_mps2": slice(15, 18)}
#: the error states the identified figures drive (attitude, velocity, the Gauss–Markov
#: biases); the others (position, the constant gyro bias, optional states) are left out
DRIVEN = np.r_[0:6, 12:18]
#: converged when no figure moves by more than this fraction in an iteration
TOLERANCE = 0.03
#: at most this many filter + smoother passes
MAX_PASSES = 12
#: held-back blocks [s] (as fednav tune's)
BLOCK_S = 60.0
#: chi-square point at which an interval's noise ratio is capped
CAP_P = 0.999
#: the most a figure moves in one pass (a factor)
MAX_STEP = 10.0
#: a secant step is at most this many times EM's own
ACCELERATION = 4.0


@dataclass
class Identified:
    """What the identification found: the ``prior`` and ``identified`` figures and their
    ``floor`` (SI keys), whether the identified ones were ``accepted`` (else ``why``
    not), the filter + smoother ``passes``, NIS/dof of every local filter before and
    after (``nis_before``, ``nis_after``; all innovations) and the held-back
    log-likelihood before and after, and the cost [s]."""

    prior: dict[str, float]
    identified: dict[str, float]
    floor: dict[str, float]
    accepted: bool
    passes: int
    nis_before: dict[str, float]
    nis_after: dict[str, float]
    loglik_held_before: float
    loglik_held_after: float
    cost_s: float
    why: str = ""
    history: list = field(default_factory=list)
    #: whether the last pass's EM step moved no figure by more than TOLERANCE (False:
    #: stopped at MAX_PASSES)
    converged: bool = True
    #: the identified white noises above the samples' own scatter (SI keys: the scatter)
    above_scatter: dict = field(default_factory=dict)

    @property
    def flown(self) -> dict[str, float]:
        """The figures the final pass flies with."""
        return self.identified if self.accepted else self.prior

    def lines(self) -> list[str]:
        """The console's lines (:func:`noise_lines`)."""
        return noise_lines(self.summary())

    def summary(self) -> dict:
        """``summary.json``'s ``noise`` entry."""
        return {"method": "em", "accepted": self.accepted, "passes": self.passes,
                "converged": self.converged, "above_scatter": self.above_scatter,
                "cost_s": round(self.cost_s, 3), "prior": self.prior,
                "identified": self.identified, "floor": self.floor,
                "nis_per_dof_before": self.nis_before, "nis_per_dof_after": self.nis_after,
                "loglik_held_before": self.loglik_held_before,
                "loglik_held_after": self.loglik_held_after,
                **({"why_not": self.why} if not self.accepted else {})}


def noise_lines(s: dict) -> list[str]:
    """The console's lines of ``summary.json``'s ``noise`` entry: prior -> identified,
    NIS/dof before -> after, and why the identified figures were not taken."""
    figs = ", ".join(f"{label(k)} {s['prior'][k]:.3g} -> {v:.3g}"
                     f" (x{v / s['prior'][k]:.3g})" for k, v in s["identified"].items())
    nis = ", ".join(f"{k} {v:.2f} -> {s['nis_per_dof_after'].get(k, float('nan')):.2f}"
                    for k, v in s["nis_per_dof_before"].items())
    if not s["accepted"] and s["passes"] == 1:  # (consistent: nothing identified)
        nis = ", ".join(f"{k} {v:.2f}" for k, v in s["nis_per_dof_before"].items())
        return [f"IMU noise: the given figures flown ({s['why_not']}"
                + (f": {nis}" if nis else "") + "; noise: as-given skips this check)"]
    if s["accepted"]:
        head = "IMU noise identified from the recording"
    else:
        head = "IMU noise identification not taken (the given figures are flown)"
    out = [f"{head}, SI ({s['passes']} passes"
           + ("" if s.get("converged", True) else ", stopped before converging")
           + f", {s['cost_s']:.1f} s; noise: as-given skips this): {figs}",
           f"  NIS/dof before -> after: {nis}"]
    over = s.get("above_scatter") or {}
    if s["accepted"] and over:
        out.append("  above the samples' own scatter: " + ", ".join(
            f"{label(k)} {s['identified'][k]:.3g} > {v:.3g}"
            for k, v in over.items()) + " (filtered data, or errors that are not the "
            "IMU's: a sensor sigma too small, a lever arm, a time offset)")
    if not s["accepted"]:
        out.append(f"  why: {s['why_not']}")
    return out


def label(key: str) -> str:
    """A figure's short name on the console: ``gyro arw``, ``gnss sigma_north_m``."""
    if key.startswith(SENSOR):
        return key[len(SENSOR):].replace(".", " ", 1)
    return " ".join(key.split("_")[:2])


def given_figures(imu: ImuData, system: System) -> dict[str, float]:
    """The figures of :data:`BLOCKS` the navigator flies with ``system``
    (:func:`fednav.process.tuning.flown_figures`, SI keys); those that are zero or
    absent are left out (nothing to scale)."""
    f = flown_figures(imu, system)
    return {k: float(f[k]) for k in BLOCKS if f.get(k)}


def correlation_times(imu: ImuData, system: System) -> dict[str, float]:
    """The Gauss–Markov figures' correlation times [s] (inf: none), by figure."""
    f = flown_figures(imu, system)
    return {"gyro_markov_radps": float(f.get("gyro_tau_s") or np.inf),
            "accel_markov_mps2": float(f.get("accel_tau_s") or np.inf)}


def scatter_figures(imu: ImuData, n_per: int) -> dict[str, float]:
    """The white-noise figures the samples' own scatter supports
    (:func:`fednav.process.tuning.white_noise_floor`; SI keys)."""
    dt = imu.period()
    return {"gyro_arw_rad_sqrt_s": white_noise_floor(imu.gyro, dt, n_per),
            "accel_vrw_mps_sqrt_s": white_noise_floor(imu.accel, dt, n_per)}


#: the prefix of a sensor's 1-sigma among the figures (``sensors.NAME.HEADER``: the
#: header of its 1-sigma column, the value in the header's unit)
SENSOR = "sensors."


@dataclass(frozen=True)
class SigmaPart:
    """A sensor 1-sigma the identification may raise: the sensor ``name``, the component
    ``j`` of its series, the rows of its residual that component's noise enters
    (``rows``), the figure's SI factor of its column's unit (``to_si``)."""

    name: str
    j: int
    rows: tuple[int, ...]
    to_si: float


def sigma_parts(prep) -> dict[str, SigmaPart]:
    """The sensors' 1-sigmas the identification may raise, by figure key
    (``sensors.NAME.HEADER``): those of the aiding sensors whose series gives none of its
    own (no ``sigma`` or ``cov`` per row: the system description's figure, a receiver
    that reports none), and whose residual has a row for the component (found by
    raising it in the sensor's model: a row whose R changes).  A model whose R mixes
    components (a rotated mounting) gets one factor for all of them (the rows of all)."""
    from ..navigator.system import sensor_model
    from ..sensors import registry

    out = {}
    aiding = set(prep.system.aiding_sensors())
    for name, d in prep.series.items():
        if name not in aiding or d.sigma is not None or d.cov is not None:
            continue
        sig = prep.system.sensors[name].sigma()
        if sig is None:
            continue
        sig = np.asarray(sig, dtype=float)
        model = sensor_model(prep.system, name)
        R0 = np.atleast_2d(model.R(sig))
        cols = registry.spec(name).columns
        parts = {}
        for j in range(len(sig)):
            if not sig[j] > 0 or j in d.absent:
                continue
            up = sig.copy()
            up[j] *= 2.0
            dR = np.abs(np.atleast_2d(model.R(up)) - R0)
            rows = tuple(int(i) for i in np.flatnonzero(dR.max(axis=1) > 0))
            if rows:
                head, f = (cols[j].sigma_column if j < len(cols)
                           else (f"sigma_{j}", 1.0))
                parts[f"{SENSOR}{name}.{head}"] = SigmaPart(name, j, rows, f)
        if not np.allclose(R0, np.diag(np.diag(R0))) or any(
                len(p.rows) > 1 for p in parts.values()):
            every = tuple(sorted({i for p in parts.values() for i in p.rows}))
            parts = {k: replace(p, rows=every) for k, p in parts.items()}
        out.update(parts)
    return out


def with_sigmas(prep, figures: dict[str, float], parts: dict[str, SigmaPart]):
    """``prep`` whose series give every row the 1-sigmas of ``figures`` (keys of
    ``parts``, in their headers' units; the section's for the other components)."""
    series = dict(prep.series)
    for name in {parts[k].name for k in figures if k in parts}:
        sig = np.array(prep.system.sensors[name].sigma(), dtype=float)
        for k, v in figures.items():
            if k in parts and parts[k].name == name:
                sig[parts[k].j] = v * parts[k].to_si
        d = series[name]
        series[name] = d.with_sigma(np.broadcast_to(sig, np.shape(d.z)))
    return replace(prep, series=series)


def given_sigmas(prep, parts: dict[str, SigmaPart]) -> dict[str, float]:
    """The 1-sigmas of ``parts`` the system description gives (their headers' units)."""
    return {k: float(prep.system.sensors[p.name].sigma()[p.j]) / p.to_si
            for k, p in parts.items()}


def sigma_factors(res, smoothed, parts: dict[str, SigmaPart], fitted,
                  chain: Chain | None = None) -> dict[str, float]:
    """Each sensor 1-sigma's factor on its variance (EM's M-step for R; Shumway & Stoffer
    1982), over the fitted innovations (``fitted``: a function of the times [s] -> which
    are fitted).  A measurement taken at epoch k with rows ``H`` and innovation ``nu``
    (against the predicted solution, whose smoothed error is ``x = e_k + dx_k`` with
    covariance ``Ps_k``: ``smoothed``, :func:`~fednav.filters.smoother.rts_smooth` on
    the pass ``res``) has the expected noise outer product given every measurement::

        V = (nu - H x)(nu - H x)' + H Ps_k H'

    and a row's factor is the mean of ``V_ii / R_ii``; a component's, the mean of its
    rows'.  Each ``(nu - H x)(...)'`` is shrunk where its ``R``-normalized size passes
    the 99.9 % chi-square point's ratio to the median (a wrong fix does not set the
    figures, whatever the figures' scale).  Records without ``H`` are left out.
    ``chain``: the folded chain ``smoothed`` is of (:func:`folded`; None: the record's
    own epochs)."""
    from ..core.stats import chi2_ppf

    e, Ps, _ = smoothed
    dx = np.asarray(res.dx if chain is None else chain.dx, dtype=float)
    out = {}
    for name in {p.name for p in parts.values()}:
        recs = [r for r in res.innovations if r.local == name and r.H is not None
                and r.epoch >= 0]
        if not recs:
            continue
        d = max(len(r.r) for r in recs)
        recs = [r for r in recs if len(r.r) == d]
        recs = [r for r, f in zip(recs, fitted(np.array([r.t for r in recs])), strict=True)
                if f]
        if not recs:
            continue
        k = np.array([r.epoch for r in recs])
        if chain is not None:
            k = chain.at(k)
        H = np.array([r.H for r in recs])
        R = np.array([r.R for r in recs])
        v = (np.array([r.r for r in recs])
             - np.einsum("kij,kj->ki", H, e[k] + dx[k]))
        size = np.einsum("ki,ki->k", v, np.linalg.solve(R, v[..., None])[..., 0])
        cap = float(chi2_ppf(CAP_P, d) / chi2_ppf(0.5, d)) * float(np.median(size))
        shrink = np.minimum(1.0, cap / np.maximum(size, 1e-300))
        V = (shrink[:, None] * v**2
             + np.einsum("kij,kjl,kil->ki", H, Ps[k], H))
        row = np.mean(V / np.diagonal(R, axis1=1, axis2=2), axis=0)
        for key, p in parts.items():
            if p.name == name and max(p.rows) < d:
                out[key] = float(np.mean(row[list(p.rows)]))
    return out


@dataclass(frozen=True)
class Chain:
    """A pass's recorded chain folded to the epochs that took a measurement.

    Between two such epochs nothing is measured and nothing fed back, so the intervals
    compose exactly: the folded transition is their product and the folded noise the
    sum of each interval's carried to the end (:func:`fold`).  EM on the folded chain is
    EM on the same likelihood, over a fraction of the epochs (a 20 Hz filter under 4 Hz
    fixes: a fifth).  ``t`` [s], ``P``, ``Phi``, ``Qd``, ``dx`` as the record's (entry 0
    the start; ``Phi``, ``Qd`` entry 0 unused), ``epochs`` their indices in the record."""

    t: np.ndarray
    P: np.ndarray
    Phi: np.ndarray
    Qd: np.ndarray
    dx: np.ndarray
    epochs: np.ndarray

    def at(self, epochs) -> np.ndarray:
        """The folded index of each recorded epoch that took a measurement."""
        return np.searchsorted(self.epochs, np.asarray(epochs))


def fold(Phi, M, ends) -> tuple[np.ndarray, np.ndarray]:
    """The transitions ``Phi`` (N+1, n, n) and per-interval noises ``M`` (N+1, m, n, n:
    m of them; entry k the interval k-1 -> k) composed over the groups of intervals
    ending at the epochs ``ends`` (increasing, the last N; group g spans ``ends[g-1]``
    -> ``ends[g]``): ``Phi_g = Phi_e ... Phi_s+1`` and ``M_g = sum_i (Phi_e ...
    Phi_i+1) M_i (...)'``, (G+1, n, n) and (G+1, m, n, n) with entry 0 unused."""
    Phi, M = np.asarray(Phi, dtype=float), np.asarray(M, dtype=float)
    ends = np.asarray(ends)
    starts = np.r_[0, ends[:-1]]
    length = ends - starts
    G, n = len(ends), Phi.shape[1]
    if G == len(Phi) - 1 == len(M) - 1 and (length == 1).all():  # (each epoch its group)
        A, acc = Phi.copy(), M.copy()
        A[0], acc[0] = 0.0, 0.0
        return A, acc
    A = np.zeros((G + 1, n, n))
    A[1:] = np.eye(n)
    acc = np.zeros((G + 1, *M.shape[1:]))
    for j in range(int(length.max(initial=0))):  # (the j-th interval of every group)
        g = np.flatnonzero(length > j) + 1
        k = starts[g - 1] + 1 + j
        F = Phi[k]
        A[g] = F @ A[g]
        acc[g] = F[:, None] @ acc[g] @ np.swapaxes(F, 1, 2)[:, None] + M[k]
    return A, acc


#: a correction fed back at an epoch counts when some state's exceeds this (filter
#: units: arc-minutes, m/s, m, deg/h ...): the fusion leaves rounding (1e-17) elsewhere
FED_BACK = 1e-9


def folded(res) -> Chain:
    """``res``'s recorded chain (a pass with ``record_covariance`` and ``innovations``)
    folded to the epochs that took a measurement or fed a correction back
    (:class:`Chain`)."""
    dx = np.asarray(res.dx, dtype=float)
    N = len(dx) - 1
    took = {r.epoch for r in res.innovations if r.epoch > 0}
    took.update((np.flatnonzero(np.abs(dx[1:]).max(axis=1) > FED_BACK) + 1).tolist())
    ends = np.array(sorted(took | {N}), dtype=np.int64)
    Phi, Qd = fold(res.Phi, np.asarray(res.Qd)[:, None], ends)
    keep = np.r_[0, ends]
    return Chain(np.asarray(res.t, dtype=float)[keep], np.asarray(res.P)[keep], Phi,
                 Qd[:, 0], dx[keep], keep)


def noise_parts(res, chain: Chain, figures: dict[str, float],
                taus: dict[str, float]) -> np.ndarray:
    """Each figure's part of every folded interval's discrete process noise, over the
    driven states :data:`DRIVEN`: ``B`` (n_figures, G, d, d), filter units.  The
    continuous density of figure j is ``Qc_j`` (white noise: its square on its three
    states; a Gauss–Markov bias: ``2 sigma^2 / tau``), discretized as the filter does
    (:func:`fednav.ins.error_model`'s trapezoid, ``(Phi Qc Phi' + Qc) T / 2``) with each
    recorded transition ``Phi`` and interval ``T`` of ``res``, then folded as ``chain``
    (:func:`fold`; the part a folded interval puts on the position is left out with the
    position, as the recorded ``Qd``'s)."""
    from ..ins.error_model import SCALE

    Phi = np.asarray(res.Phi, dtype=float)
    T = np.r_[0.0, np.diff(np.asarray(res.t, dtype=float))]
    qcs = []
    for k, v in figures.items():
        qc = np.zeros(Phi.shape[1])
        tau = taus.get(k)
        qc[BLOCKS[k]] = (v**2 if tau is None else
                         (2.0 * v**2 / tau if np.isfinite(tau) else 0.0)) / SCALE[BLOCKS[k]]**2
        qcs.append(qc)
    # Carried to its group's end by Psi_i = Phi_e ... Phi_i+1, interval i's part is
    # T_i / 2 (Psi_i-1 Qc Psi_i-1' + Psi_i Qc Psi_i') with Psi_i-1 = Psi_i Phi_i: from
    # each group's end back, rank-3 terms (Qc is diagonal on three states), the driven
    # rows of Psi only
    ends = chain.epochs[1:]
    length = ends - np.r_[0, ends[:-1]]
    d = len(DRIVEN)
    Psi = np.broadcast_to(np.eye(Phi.shape[1])[DRIVEN], (len(ends), d, Phi.shape[1])).copy()
    out = np.zeros((len(qcs), len(ends), d, d))
    for r in range(int(length.max(initial=0))):
        g = np.flatnonzero(length > r)
        i = ends[g] - r
        after = Psi[g]
        before = after @ Phi[i]
        for j, qc in enumerate(qcs):
            on = qc > 0
            a, b = after[:, :, on], before[:, :, on]
            out[j, g] += (0.5 * T[i])[:, None, None] * (
                (b * qc[on]) @ np.swapaxes(b, 1, 2) + (a * qc[on]) @ np.swapaxes(a, 1, 2))
        Psi[g] = before
    return out


def variance_factors(chain: Chain, B: np.ndarray, names, fitted: np.ndarray,
                     smoothed=None) -> dict[str, float]:
    """One EM step's factor on each figure's variance (module docstring, 2), on the
    folded ``chain`` with each figure's parts ``B`` (:func:`noise_parts`; ``names``: the
    figures, in ``B``'s order).

    With ``Q_k = sum_j s_j B_jk + rest_k`` over the driven states (``rest``: what the
    recorded ``Qd`` holds beside them — a barometer loop, scale-factor states), the
    expected complete-data likelihood's fixed point for each ``s_j`` at ``s = 1`` is::

        s_j = sum_k tr(Q_k^-1 B_jk Q_k^-1 W_k) / sum_k tr(Q_k^-1 B_jk)

    over the fitted intervals (Shumway & Stoffer's M-step for a covariance linear in
    its parameters; each interval's ``W_k`` shrunk where ``tr(Q_k^-1 W_k) / d`` passes
    the 99.9 % point of chi-square over d: a wrong fix or a bump the smoother meets does
    not set the figures).  ``smoothed``: :func:`~fednav.filters.smoother.rts_smooth`'s
    result on the chain when it is at hand.
    """
    from ..core.stats import chi2_ppf

    W = noise_moments(chain.P, chain.Phi, chain.Qd, chain.dx, DRIVEN, smoothed)[fitted]
    Qd = chain.Qd[1:][:, DRIVEN][:, :, DRIVEN][fitted]
    B = B[:, fitted]
    live = np.diagonal(Qd, axis1=1, axis2=2).min(axis=0) > 0
    if not live.all():  # (a block without noise: a figure of zero)
        Qd, W, B = Qd[:, live][:, :, live], W[:, live][:, :, live], B[:, :, live][:, :, :, live]
    d = Qd.shape[1]
    Qi = np.linalg.inv(Qd)
    ratio = np.trace(Qi @ W, axis1=1, axis2=2) / d
    cap = float(chi2_ppf(CAP_P, d)) / d
    W = W * np.minimum(1.0, cap / np.maximum(ratio, 1e-300))[:, None, None]
    QiW = Qi @ W @ Qi
    out = {}
    for j, k in enumerate(names):
        den = float(np.sum(np.einsum("kij,kji->k", Qi, B[j])))
        if den > 0:
            out[k] = float(np.sum(np.einsum("kij,kji->k", QiW, B[j]))) / den
    return out


def identify(imu: ImuData, prep, progress=None, force: bool = False):
    """Identify the IMU's process noise on prepared data (module docstring).

    Parameters
    ----------
    imu : ImuData
        The IMU samples as processed (mounted), for the white noise's start.
    prep : Prepared
        :func:`fednav.process.run.prepare`'s result with the given figures.
    progress : callable, optional
        Called with a short text before each pass.
    force : bool
        Identify even when the given figures' innovations are above
        :data:`~fednav.navigator.health.NIS_REFUSE` (``process --force``; otherwise
        the data are more likely wrong than the figures, and ``process`` says so).

    Returns
    -------
    (Prepared, Identified, Navigator or None)
        ``prep`` with the figures to fly (the identified ones if accepted), the report,
        and the fed navigator of the pass that flew them — the first pass when the
        given figures are kept, the last when the identified ones are (the final pass:
        ``process`` takes it as it is); None with Q adaptation (the passes fly without
        it) or when a pass failed.
    """
    from ..core.stats import chi2_ppf
    from ..navigator.health import NIS_REFUSE

    t_start = time.perf_counter()
    parts = sigma_parts(prep) if prep.system.noise == "identify-all" else {}
    prior = {**given_figures(imu, prep.system), **given_sigmas(prep, parts)}
    seen = scatter_figures(imu, prep.n_per)
    # never below the given figures; a white noise starts at what the samples' scatter
    # supports (the data's direct measure of it) where that is more
    floor = dict(prior)
    start = {k: max(v, seen.get(k, v)) for k, v in prior.items()}
    blocks = Blocks(float(prep.t[0]), BLOCK_S)
    system = prep.system
    if system.filter.q_adaptation is not None:  # (the recorded Qd is not the model's)
        system = system.model_copy(update={"filter": system.filter.model_copy(
            update={"q_adaptation": None})})

    # every pass records the rows when the final pass could be one of them (no Q
    # adaptation, which the passes turn off): the last is then the final pass
    rows = prep.system.filter.q_adaptation is None

    def run(figures=None):
        """A pass with these figures (None: as given)."""
        p = replace(prep, system=system)
        if figures is not None:
            p = with_sigmas(replace(p, system=with_figures(system, imu_part(figures))),
                            figures, parts)
        nav = p.feed(p.navigator(record_rows=rows, record_covariance=True,
                                 innovations=True))
        return nav, nav.result()

    def kept(why, nis, ll, passes=1):
        return Identified(prior, dict(prior), floor, False, passes, nis, nis, ll, ll,
                          time.perf_counter() - t_start, why)

    odd = sorted(set(local_types(prep.system)) & NOT_KALMAN)
    if odd:
        return prep, kept(f"local filter type {', '.join(odd)}: its covariance is not a "
                          f"Kalman filter's (adapted or sampled), which the "
                          f"identification needs", {}, float("nan")), None
    nav0, out0 = run()
    before = innovation_statistics(out0.innovations, blocks)
    reuse = nav0 if rows else None
    nis0 = before_all(out0)
    hi = prep.system.health.nis_band[1]
    why = None
    if not nis0:
        why = "no innovations recorded (no aiding sensor, or a centralized filter)"
    elif not any(v > hi for v in nis0.values()):  # (nothing says the figures are small)
        why = kept_because(nis0, prep.system, own_share(out0))
    elif max(nis0.values()) > NIS_REFUSE and not force:
        why = (f"NIS/dof above {NIS_REFUSE:g}: the data are more likely wrong than the "
               f"figures (--force identifies)")
    elif not before.nis_held:
        why = f"too short to hold a {BLOCK_S:g} s block back (fitted and scored apart)"
    if why is not None:
        return prep, kept(why, nis0, before.loglik_held), reuse
    taus = correlation_times(imu, prep.system)

    def gaps(figures, out) -> dict[str, float]:
        """log of each figure's EM factor (half the log of its variance factor)."""
        chain = folded(out)
        fitted = ~blocks.held(chain.t[1:])
        smoothed = rts_smooth(chain.P, chain.Phi, chain.Qd, chain.dx)
        imu_figs = imu_part(figures)
        sc = variance_factors(chain, noise_parts(out, chain, imu_figs, taus), imu_figs,
                              fitted, smoothed)
        sc.update(sigma_factors(out, smoothed, parts, lambda t: ~blocks.held(t), chain))
        return {k: 0.5 * float(np.log(sc[k])) for k in sc if sc[k] > 0}

    # Each figure's EM factor g (log) against its log x: the fixed point g = 0 found by
    # secant steps (plain EM creeps where the data say much more noise than given),
    # the first step EM's own; every step at most MAX_STEP, never below the floor.
    figs = dict(start)
    nav, out, passes, history, converged = nav0, out0, 1, [], False
    try:
        if start != prior:
            nav, out = run(figs)
            passes += 1
        last: dict[str, tuple[float, float]] = {}
        while passes < MAX_PASSES:
            g = gaps(figs, out)
            new = {}
            for k, x in figs.items():
                if k not in g:
                    new[k] = x
                    continue
                lx, gk = np.log(x), g[k]
                step = gk
                if k in last and lx != last[k][0]:
                    slope = (gk - last[k][1]) / (lx - last[k][0])
                    if slope < 0:  # (the factor falls as the figure rises: a secant
                        # step, in EM's direction, at most ACCELERATION times EM's)
                        step = float(np.clip(-gk / slope, min(gk, ACCELERATION * gk),
                                             max(gk, ACCELERATION * gk)))
                step = float(np.clip(step, -np.log(MAX_STEP), np.log(MAX_STEP)))
                last[k] = (lx, gk)
                new[k] = max(float(np.exp(lx + step)), floor[k])
            converged = all(abs(v) < np.log1p(TOLERANCE) or (v < 0 and figs[k] <= floor[k])
                            for k, v in g.items())
            if converged:
                break
            if progress is not None:
                progress(f"noise identification, pass {passes + 1}")
            figs = new
            history.append(dict(figs))
            nav, out = run(figs)
            passes += 1
    except (np.linalg.LinAlgError, FednavError) as e:  # (a pass the smoother cannot take)
        return prep, kept(f"a pass failed ({e}): the given figures are flown", nis0,
                          before.loglik_held, passes), reuse
    after = innovation_statistics(out.innovations, blocks)
    # the held-back blocks decide (fednav tune's rule); a fall of their likelihood within
    # the likelihood-ratio test's 95 % point (as many degrees of freedom as figures) is
    # taken as no fall
    lr = 0.5 * float(chi2_ppf(0.95, len(prior)))
    why = worse(replace(after, loglik_held=after.loglik_held + lr), before)
    if why and after.loglik_held + lr < before.loglik_held:
        why = (f"held-back log-likelihood {before.loglik_held:.1f} -> "
               f"{after.loglik_held:.1f}, down by more than {lr:.3g}")
    accepted = why is None
    rep = Identified(prior, figs, floor, accepted, passes, nis0, before_all(out),
                     before.loglik_held, after.loglik_held,
                     time.perf_counter() - t_start, why or "", history, converged,
                     {k: v for k, v in seen.items() if figs[k] > v and k in figs})
    if not accepted:
        return prep, rep, reuse
    flown = replace(prep, system=with_figures(prep.system, imu_part(rep.flown)))
    raised = {k: v for k, v in rep.flown.items() if k in parts and v != prior[k]}
    return with_sigmas(flown, raised, parts), rep, nav if rows else None


def imu_part(figures: dict[str, float]) -> dict[str, float]:
    """The IMU's figures among ``figures`` (the sensors' 1-sigmas left out)."""
    return {k: v for k, v in figures.items() if not k.startswith(SENSOR)}


#: local filter types whose covariance the identification cannot take as a Kalman
#: filter's: adapted online (Sage–Husa, robust adaptive, adaptive sparse-grid) or carried
#: by samples (the particle filter)
NOT_KALMAN = frozenset({"aekf", "raukf", "aasghqf", "pf"})


def local_types(system: System) -> list[str]:
    """Every local filter's type of ``system`` (the default and each ``locals`` one)."""
    f = system.filter
    return [f.type, *(c.type for c in f.locals.values() if c.type)]


def kept_because(nis: dict[str, float], system: System,
                 own: dict[str, float] | None = None) -> str:
    """Why the given figures are flown when no local filter's NIS/dof is above the
    health band; ``own``: each local filter's :func:`own_share` (a NIS/dof below the
    band where the filter's own uncertainty fills its innovations says little about the
    sensor's sigma)."""
    lo, hi = system.health.nis_band
    low = [k for k, v in nis.items() if v < lo]
    if not low:
        return (f"every NIS/dof inside {lo:g}..{hi:g}: the given figures are consistent "
                f"with the recording")
    own = own or {}
    prior = [k for k in low if own.get(k, 0.0) > 1.0]
    said = (f"NIS/dof of {', '.join(low)} below {lo:g} and none above {hi:g}: the given "
            f"figures are never lowered")
    if len(prior) == len(low):
        return (f"{said} (the filter's own uncertainty fills those innovations — "
                f"{', '.join(f'{k} {own[k]:.3g}x its noise' for k in prior)} in the "
                f"median — so they say little about the sensors' sigmas: a recording too "
                f"short, or a start too uncertain, to judge them)")
    rest = [k for k in low if k not in prior]
    return (f"{said} (a sensor sigma larger than its data's is the likelier cause"
            + (f" for {', '.join(rest)}; the filter's own uncertainty fills the "
               f"innovations of {', '.join(prior)}" if prior else "") + ")")


def own_share(out) -> dict[str, float]:
    """Per local filter, the median over its innovations of ``tr(S - R) / tr(R)``: how
    large the filter's own uncertainty (``H P H'``) is against the measurement noise in
    the innovations' predicted covariance ``S = H P H' + R`` [-]."""
    groups: dict[tuple[str, int], list] = {}  # (stacked by local filter and rows)
    for r in out.innovations or ():
        groups.setdefault((r.local, len(r.r)), []).append(r)
    shares: dict[str, list] = {}
    for (local, _), recs in groups.items():
        tr = np.trace(np.array([r.R for r in recs], dtype=float), axis1=1, axis2=2)
        trs = np.trace(np.array([r.S for r in recs], dtype=float), axis1=1, axis2=2)
        ok = np.isfinite(tr) & (tr > 0.0)
        shares.setdefault(local, []).append(trs[ok] / tr[ok] - 1.0)
    return {k: float(np.median(np.concatenate(v))) for k, v in shares.items()
            if sum(map(len, v))}


def before_all(out) -> dict[str, float]:
    """Mean NIS/dof of every local filter over all its innovations."""
    ev = innovation_statistics(out.innovations)
    return {k: round(v, 3) for k, v in ev.nis_per_dof.items()}

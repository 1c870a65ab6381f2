"""Protection levels by solution separation: how large the error can be, with a stated
probability, when a sensor's fault has not (yet) been detected.

Beside the all-sensor solution ``x0`` stand the sub-solutions ``x_k`` that each leave one
aiding sensor ``k`` out (:func:`fednav.process.integrity.sensor_bank` runs them: the same
navigator, the same IMU, one sensor fewer).  A fault of sensor ``k`` moves ``x0`` and not
``x_k``, so per axis ``q`` (east, north, up, heading) the separation
``Δ_k = x_k − x0`` is tested against a threshold::

    T_k,q = K_fa,q σ_ss,k,q,   σ_ss² = σ_k² − σ0²   (x0 uses every measurement x_k uses)
    K_fa,q = Q⁻¹(P_FA,q / (2 N))   (N sensors; P_FA,q the axis's share of the false-alert
                                    budget; east and north share the horizontal one)

and the protection level ``PL_q`` is the root of ARAIM's integrity equation (Blanch et
al., "Baseline advanced RAIM user algorithm and possible improvements", IEEE TAES 2015,
with no nominal biases)::

    2 Q(PL / σ0) + Σ_k p_k Q((PL − T_k) / σ_k) = P_HMI,q

with ``p_k`` sensor ``k``'s prior fault probability and ``P_HMI,q`` the axis's share of the
integrity-risk budget; ``HPL = hypot(PL_east, PL_north)``, ``VPL = PL_up``, the heading's
``PL_heading``.  A test that trips is a detected fault (an alert).  Exclusion
(:func:`fednav.process.integrity.run_integrity`) tries the sensors in the order of their
test ratios: a candidate is excluded when the sub-solution without it passes its own
separation tests (against the sub-solutions that leave out one more sensor) from then on;
the output becomes that sub-solution — which never saw the sensor — with its own levels.
With two sensors no candidate can be checked: a fault is detected and alerted, not
excluded (two witnesses that disagree do not say which one lies).

What this does not protect against (said in every report): a fault of the IMU itself or of
the common INS (every sub-solution shares it), two sensors faulty at once, a fault that
entered before the sub-solutions split (none: they run from the start), and errors the
filter's covariance does not describe (levels are as good as the consistency
certificate of ``docs/certificate.md``).  Sigmas are each solution's per-axis 1-sigma
(:class:`~fednav.navigator.solution.Solution`), so the levels are per axis, as ARAIM's.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pydantic import Field

from ..core.attitude import wrap_pi
from ..core.config import _Model
from ..core.earth import llh_difference_enu


def q_function(x):
    """The standard normal tail ``Q(x) = P(X > x)``."""
    from scipy.special import ndtr  # (scipy.special: 0.1 s of every command's start)

    return ndtr(-np.asarray(x, dtype=float))


def q_inverse(p):
    """``Q⁻¹(p)``: the ``x`` with ``Q(x) = p``."""
    from scipy.special import ndtri

    return -ndtri(np.asarray(p, dtype=float))


class IntegrityConfig(_Model):
    """The integrity budget (all probabilities per epoch of exposure; defaults of the
    order aviation allocates to an approach, a generic starting point rather than a
    certified allocation).

    ``risk_horizontal``, ``risk_vertical``, ``risk_heading`` — the integrity risk
    (probability of an error above the level with no alert) of each: 1e-7 each (LPV-200
    allocates 2e-7 in total to an approach).  ``false_alert`` — the probability of a test
    tripping with no fault, split equally over horizontal, vertical and heading: 4e-6
    (ARAIM's continuity allocation to false alerts).  ``prior_fault`` — each sensor's
    probability of being faulty, by registered name, ``default`` for the others: 1e-4
    (ten times ARAIM's per-satellite 1e-5: a sensor here is a whole receiver, matcher or
    tracker, with its environment).  ``alert_limit_horizontal_m``,
    ``alert_limit_vertical_m``, ``alert_limit_heading_deg`` — a level above its limit
    raises an alert (None: no limit, no alert of that kind)."""

    risk_horizontal: float = Field(1e-7, gt=0.0, lt=0.5)
    risk_vertical: float = Field(1e-7, gt=0.0, lt=0.5)
    risk_heading: float = Field(1e-7, gt=0.0, lt=0.5)
    false_alert: float = Field(4e-6, gt=0.0, lt=0.5)
    prior_fault: dict[str, float] = {"default": 1e-4}
    alert_limit_horizontal_m: float | None = Field(None, gt=0.0)
    alert_limit_vertical_m: float | None = Field(None, gt=0.0)
    alert_limit_heading_deg: float | None = Field(None, gt=0.0)

    def prior(self, name: str) -> float:
        """Sensor ``name``'s prior fault probability."""
        return float(self.prior_fault.get(name, self.prior_fault.get("default", 1e-4)))


def tested_sensors(aiding) -> list[str]:
    """The aiding sensors whose faults solution separation tests, in ``aiding``'s order
    (constraints and detectors — NHC, ZUPT — are the vehicle's, not sensors that fail)."""
    from ..sensors import registry

    return [a for a in aiding if not registry.spec(a).pseudo
            and registry.spec(a).detector is None]


def exclusion(result: IntegrityResult, after_without) -> tuple[IntegrityResult, str | None]:
    """Fault exclusion after a detection: the first candidate (largest test ratio first)
    whose solution without it passes its own separation tests from the detection on —
    ``after_without(k)`` gives those tests (an :class:`IntegrityResult` row for row with
    ``result``), or None where nothing is left to check ``k`` with.  ``(result with the
    exclusion, the sensor)``; ``(result, None)`` when nothing tripped or no candidate
    passes (the fault stays detected and alerted)."""
    row = result.first_trip()
    if row is None:
        return result, None
    for k in result.candidates(row):
        after = after_without(k)
        if after is not None and not (after.test_ratio[row:] > 1.0).any():
            return result.excluding(row, k, after), k
    return result, None


#: the axes tested: east, north, up [m] and heading [rad]
AXES = ("east", "north", "up", "heading")


#: the separation's 1-sigma is at least this fraction of the sub-solution's: where a
#: sensor adds (almost) nothing on an axis, ``σ_k² − σ0²`` vanishes while the two
#: linearised, fed-back filters still differ a little (the heading in the first seconds
#: after a start: 0.1° apart where ``σ_k² − σ0²`` says 1e-11 rad)
SEPARATION_FLOOR = 0.1


def separation_threshold(sigma0, sigma_k, k_fa):
    """``(σ_ss, T)``: the separation's 1-sigma ``sqrt(σ_k² − σ0²)`` (at least
    :data:`SEPARATION_FLOOR` of σ_k) and its threshold ``k_fa σ_ss``."""
    s0, sk = np.asarray(sigma0, dtype=float), np.asarray(sigma_k, dtype=float)
    ss = np.sqrt(np.maximum(sk**2 - s0**2, (SEPARATION_FLOOR * sk) ** 2))
    return ss, k_fa * ss


def protection_level(sigma0, sigmas, thresholds, priors, p_hmi, iterations: int = 60):
    """The root ``PL`` of ``2 Q(PL/σ0) + Σ_k p_k Q((PL − T_k)/σ_k) = p_hmi`` per epoch.

    Parameters
    ----------
    sigma0 : ndarray (M,)
        The all-sensor solution's 1-sigma on the axis.
    sigmas, thresholds : ndarray (N, M)
        Each sub-solution's 1-sigma and its test threshold.
    priors : ndarray (N,)
        Each sensor's prior fault probability.
    p_hmi : float
        The axis's integrity risk.

    Returns
    -------
    ndarray (M,)
        The protection level, in the unit of the sigmas (bisection on a bracket the
        equation's left side crosses; inf where a sigma is inf).
    """
    s0 = np.asarray(sigma0, dtype=float)
    sk = np.atleast_2d(np.asarray(sigmas, dtype=float))
    tk = np.atleast_2d(np.asarray(thresholds, dtype=float))
    pk = np.asarray(priors, dtype=float)[:, None]

    def lhs(pl):
        return 2.0 * q_function(pl / s0) + np.sum(pk * q_function((pl - tk) / sk), axis=0)

    # bracket: each term alone below p_hmi / (N + 1) at hi
    n = len(pk) + 1
    k = q_inverse(p_hmi / (2.0 * n))
    share = np.divide(p_hmi, n * pk, out=np.full_like(pk, 0.5), where=pk > 0)
    hi = np.maximum(k * s0, np.max(tk + q_inverse(np.minimum(share, 0.5)) * sk, axis=0))
    lo = np.zeros_like(hi)
    finite = np.isfinite(hi)
    hi = np.where(finite, hi, 1.0)
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        above = lhs(mid) > p_hmi
        lo = np.where(above, mid, lo)
        hi = np.where(above, hi, mid)
    return np.where(finite, hi, np.inf)


@dataclass
class IntegrityResult:
    """Per solution row: ``hpl`` [m], ``vpl`` [m], ``heading_pl`` [rad], the largest test
    statistic ``test_ratio`` (separation / threshold over sensors and axes: above 1 a
    test trips), ``alert`` (a level above its alert limit, or a fault detected),
    ``excluded`` (index into ``sensors`` of the sensor excluded at that row, −1 none);
    ``sensors`` the sensors tested, ``exclusions`` [(time [s], sensor)], and the
    budget used."""

    t: np.ndarray
    hpl: np.ndarray
    vpl: np.ndarray
    heading_pl: np.ndarray
    test_ratio: np.ndarray
    alert: np.ndarray
    excluded: np.ndarray
    sensors: list[str]
    exclusions: list = field(default_factory=list)
    config: IntegrityConfig | None = None
    #: each sensor's test ratio per row (N, M): above 1 its separation test trips
    ratios: np.ndarray | None = None
    #: per row, a fault detected and not excluded (the part of ``alert`` that is not a
    #: level above its limit)
    detected: np.ndarray | None = None

    def rows_at(self, t) -> np.ndarray:
        """The row in force at each time ``t`` [s]: the last at or before it."""
        return np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, len(self.t) - 1)

    def first_trip(self) -> int | None:
        """The first row whose tests trip (a fault detected), else None."""
        hit = self.test_ratio > 1.0
        return int(np.argmax(hit)) if hit.any() else None

    def candidates(self, row: int) -> list[str]:
        """The sensors to try excluding at ``row``, the largest test ratio first."""
        return [self.sensors[k] for k in np.argsort(-self.ratios[:, row], kind="stable")]

    def above_limits(self) -> np.ndarray:
        """Per row: a level above its alert limit."""
        cfg = self.config or IntegrityConfig()
        out = np.zeros(len(self.t), dtype=bool)
        for lvl, lim in ((self.hpl, cfg.alert_limit_horizontal_m),
                         (self.vpl, cfg.alert_limit_vertical_m),
                         (self.heading_pl, None if cfg.alert_limit_heading_deg is None
                          else np.radians(cfg.alert_limit_heading_deg))):
            if lim is not None:
                out |= lvl > lim
        return out

    def excluding(self, row: int, name: str, after: IntegrityResult) -> IntegrityResult:
        """This result up to ``row``, then ``after`` (the levels and tests of the solution
        without sensor ``name``, row for row with this one), with ``name`` excluded."""
        out = IntegrityResult(self.t, self.hpl.copy(), self.vpl.copy(),
                              self.heading_pl.copy(), self.test_ratio.copy(),
                              self.alert.copy(), self.excluded.copy(), list(self.sensors),
                              [*self.exclusions, (float(self.t[row]), name)], self.config,
                              self.ratios, self.detected.copy())
        for f in ("hpl", "vpl", "heading_pl", "test_ratio", "alert", "detected"):
            getattr(out, f)[row:] = getattr(after, f)[row:]
        out.excluded[row:] = self.sensors.index(name)
        return out

    def summary(self, errors: dict | None = None) -> dict:
        """``summary.json``'s ``integrity`` block: levels' medians and maxima,
        availability against the alert limits, alerts, exclusions; with ``errors``
        (``{"t": ..., "horizontal": ..., "vertical": ..., "heading": ...}``: the
        errors against a reference at its times ``t`` [s]; m, m, rad) the fraction of
        those times whose error exceeds the level (interpolated to them), and of those
        with no alert (``*_misleading``: misleading information)."""
        cfg = self.config or IntegrityConfig()
        finite = np.isfinite(self.hpl)
        out = {
            "sensors": list(self.sensors),
            "hpl_m": {"median": _stat(np.median, self.hpl), "max": _stat(np.max, self.hpl)},
            "vpl_m": {"median": _stat(np.median, self.vpl), "max": _stat(np.max, self.vpl)},
            "heading_pl_deg": {"median": _stat(np.median, np.degrees(self.heading_pl)),
                               "max": _stat(np.max, np.degrees(self.heading_pl))},
            "rows": int(len(self.t)), "rows_with_finite_levels": int(finite.sum()),
            "alert_fraction": float(np.mean(self.alert)) if len(self.alert) else 0.0,
            "exclusions": [{"t_s": float(t), "sensor": s} for t, s in self.exclusions],
            "budget": cfg.model_dump(mode="json"),
            "not_protected": NOT_PROTECTED,
        }
        limits = {"hpl": cfg.alert_limit_horizontal_m, "vpl": cfg.alert_limit_vertical_m,
                  "heading_pl": None if cfg.alert_limit_heading_deg is None
                  else np.radians(cfg.alert_limit_heading_deg)}
        ok = np.ones(len(self.t), dtype=bool)
        for k, lim in limits.items():
            if lim is not None:
                ok &= getattr(self, k) <= lim
        if any(v is not None for v in limits.values()):
            out["availability"] = float(np.mean(ok)) if len(ok) else 0.0
        if errors is not None:
            for axis, pl in (("horizontal", self.hpl), ("vertical", self.vpl),
                             ("heading", self.heading_pl)):
                e = errors.get(axis)
                if e is not None:
                    pl = np.interp(errors["t"], self.t, pl)
                    over = np.abs(e) > pl
                    # (an alert in force then: the user was warned)
                    alerted = self.alert[self.rows_at(errors["t"])]
                    out[f"{axis}_error_above_level"] = float(np.mean(over))
                    out[f"{axis}_misleading"] = float(np.mean(over & ~alerted))
                    out[f"{axis}_error_median"] = float(np.median(np.abs(e)))
        return out


#: what solution separation here does not protect against (the docs and every report)
NOT_PROTECTED = ("a fault of the IMU or of the common INS (every sub-solution shares it); "
                 "two sensors faulty at once; errors the filter's covariance does not "
                 "describe (see the consistency certificate)")


def _stat(fn, a) -> float | None:
    a = np.asarray(a, dtype=float)
    a = a[np.isfinite(a)]
    return float(fn(a)) if len(a) else None


def solution_separation(full, subs: dict, cfg: IntegrityConfig | None = None
                        ) -> IntegrityResult:
    """Tests and protection levels of ``full`` (the all-sensor
    :class:`~fednav.navigator.solution.Solution`) from ``subs``, the sub-solutions by the
    sensor each leaves out, row for row with ``full`` (module docstring)."""
    names = list(subs)
    if not names:
        raise ValueError("solution separation needs at least one sub-solution (a system "
                         "with two or more aiding sensors)")
    m = len(full.t)
    for k in names:
        if len(subs[k].t) != m or np.max(np.abs(subs[k].t - full.t)) > 1e-6:
            raise ValueError(f"the sub-solution without '{k}' is not row for row with the "
                             f"full solution")
    # separations and sigmas per axis: east, north, up [m], heading [rad]
    s0 = np.column_stack([full.sigma[:, 6:9], full.sigma_euler[:, 2]])
    sk = np.stack([np.column_stack([subs[k].sigma[:, 6:9], subs[k].sigma_euler[:, 2]])
                   for k in names])
    d = np.stack([separations(subs[k].lla, subs[k].euler[:, 2], full.lla, full.euler[:, 2])
                  for k in names])
    return separation(full.t, d, s0, sk, names, cfg)


def separations(sub_lla, sub_heading, lla, heading) -> np.ndarray:
    """A sub-solution minus the all-sensor solution (N, 4): east, north, up [m] and heading
    [rad], from positions (N, 3) (latitude, longitude [rad], height [m]) and headings (N,)
    [rad]."""
    return np.column_stack([llh_difference_enu(*np.asarray(sub_lla).T, *np.asarray(lla).T),
                            wrap_pi(np.asarray(sub_heading) - np.asarray(heading))])


def separation(t, d, s0, sk, names: list[str], cfg: IntegrityConfig | None = None
               ) -> IntegrityResult:
    """Tests and protection levels from the separations ``d`` (M, N, 4) of the M
    sub-solutions (each leaving out sensor ``names[k]``) from the all-sensor solution at
    the N epochs ``t`` [s] — east, north, up [m] and heading [rad], sub minus full — the
    all-sensor solution's 1-sigma ``s0`` (N, 4) and the sub-solutions' ``sk`` (M, N, 4)
    on the same axes: :func:`solution_separation` for any source of the solutions (a
    processed recording's bank, a design's Monte Carlo runs)."""
    cfg = cfg or IntegrityConfig()
    n, m = len(names), len(t)
    p_fa = cfg.false_alert / 3.0
    k_fa = q_inverse(np.array([p_fa / (4 * n), p_fa / (4 * n), p_fa / (2 * n),
                               p_fa / (2 * n)]))
    ss, T = separation_threshold(s0[None], sk, k_fa[None, None, :])
    ratio = np.abs(d) / T  # (N, M, 4)
    priors = np.array([cfg.prior(k) for k in names])
    risk = (cfg.risk_horizontal / 2.0, cfg.risk_horizontal / 2.0, cfg.risk_vertical,
            cfg.risk_heading)
    pl = np.column_stack([protection_level(s0[:, q], sk[:, :, q], T[:, :, q], priors,
                                           risk[q]) for q in range(4)])
    worst = ratio.max(axis=2)  # (N, M)
    tripped = worst.max(axis=0) > 1.0
    hpl, vpl, hdg = np.hypot(pl[:, 0], pl[:, 1]), pl[:, 2], pl[:, 3]
    out = IntegrityResult(np.asarray(t), hpl, vpl, hdg, worst.max(axis=0), tripped.copy(),
                          np.full(m, -1), list(names), [], cfg, worst, tripped.copy())
    out.alert |= out.above_limits()
    return out

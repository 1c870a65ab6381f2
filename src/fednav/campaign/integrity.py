"""Integrity of a design's Monte Carlo runs: protection levels proven against the truth.

A design with an ``integrity:`` section (:class:`~fednav.navigator.integrity.IntegrityConfig`)
flies, in every run, each mode that has two or more tested aiding sensors once more per
sensor without it (the same run's data: noise, initial errors and drawn faults), and
takes the solution-separation tests and protection levels
(:func:`fednav.navigator.integrity.separation`) from the errors' differences — the truth
cancels — and the filters' 1-sigma.  Cost: (tested sensors + 1) runs of the navigator
per mode.  Against the truth each run's epochs then fall in the Stanford diagram's
regions (:func:`fednav.process.stanford.regions`: bounded, misleading, hazardously
misleading, unavailable; alerted apart), counted per run and in a two-dimensional
histogram of error against level on fixed logarithmic bins (:data:`EDGES`), so that any
number of runs add up; with the drawn faults, whether and when a test tripped and which
sensor its largest separation named.

The campaign's figures (:func:`summarize`) are rates over all epochs and over runs with
their 95 % upper confidence bounds (Clopper–Pearson).  Epochs of one run are
correlated (a level that fails to bound an error usually does so for a stretch), so the
per-run rate — runs with one or more misleading epochs — is the conservative figure;
with no misleading run in ``n`` runs the bound is ``1 − 0.05^(1/n) ≈ 3/n``: the
resolution the run count allows.

Not protected (stated in :func:`summarize`'s output as in ``docs/integrity.md``): a
fault of the IMU or of the common INS (every sub-solution shares it), two simultaneous
sensor faults, and data that act outside the filter's covariance.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..core.attitude import wrap_pi
from ..ins.error_model import DP
from ..navigator.integrity import (
    NOT_PROTECTED,
    IntegrityResult,
    exclusion,
    separation,
    tested_sensors,
)
from ..process.stanford import regions

#: The Stanford histogram's bins (error and level on the same edges): horizontal and
#: vertical [m], heading [deg]; ten per decade; values outside fall in the end bins.
EDGES = {"horizontal": np.logspace(-3, 4, 71), "vertical": np.logspace(-3, 4, 71),
         "heading": np.logspace(-4, 2, 61)}
#: Each axis's integrity-risk budget (per epoch) in the configuration.
RISK = {"horizontal": "risk_horizontal", "vertical": "risk_vertical",
        "heading": "risk_heading"}
#: The axes: name, unit, the configuration's alert-limit key.
AXES = (("horizontal", "m", "alert_limit_horizontal_m"),
        ("vertical", "m", "alert_limit_vertical_m"),
        ("heading", "deg", "alert_limit_heading_deg"))


@dataclass
class StanfordCounts:
    """One run's (or a campaign's) epochs in the Stanford histogram: per axis, counts
    (error bin, level bin) on :data:`EDGES`."""

    horizontal: np.ndarray
    vertical: np.ndarray
    heading: np.ndarray


def _separation(full, subs: dict, cfg) -> IntegrityResult:
    """:func:`~fednav.navigator.integrity.separation` of run results
    (:class:`~fednav.sim.runs.RunResult`: errors against the same truth, whose
    differences are the solutions')."""
    names = list(subs)
    d = np.stack([np.column_stack([subs[k].pos - full.pos,
                                   wrap_pi(subs[k].euler[:, 2] - full.euler[:, 2])])
                  for k in names])
    s0 = np.column_stack([full.sigma[:, DP], full.sigma[:, 2]])
    sk = np.stack([np.column_stack([subs[k].sigma[:, DP], subs[k].sigma[:, 2]])
                   for k in names])
    return separation(full.t, d, s0, sk, names, cfg)


def mode_levels(scn, mode, data, full, max_time=None):
    """``(levels, output)`` of one mode's run ``full`` (:class:`~fednav.sim.runs.RunResult`):
    the separation tests and levels from the same run flown without each tested sensor
    and, after a test trips, fault exclusion as :func:`fednav.process.integrity.exclude`
    does — the first candidate (largest test ratio first) whose own sub-solutions
    (flown without it and one more) pass their tests from the detection on is excluded,
    and the output is the run without it from then on; None with fewer than two tested
    sensors."""
    from ..sim.runs import run_mode

    def fly(aiding):
        return run_mode(scn, aiding, data, mode.name, max_time, mode.filter,
                        mode.delay_compensation, mode.constraint)

    def less(aiding, k):
        return [a for a in aiding if a != k]

    names = tested_sensors(mode.aiding)
    if len(names) < 2:
        return None
    subs = {k: fly(less(mode.aiding, k)) for k in names}
    res = _separation(full, subs, scn.integrity)
    row = res.first_trip()

    def after_without(k):
        rest = tested_sensors(less(mode.aiding, k))
        if len(rest) < 2:
            return None  # (nothing left to check the candidate with)
        return _separation(subs[k], {j: fly(less(less(mode.aiding, k), j)) for j in rest},
                           scn.integrity)

    res, k = exclusion(res, after_without)
    if k is None:
        return res, full
    return res, replace(full, **{f: np.concatenate([getattr(full, f)[:row],
                                                    getattr(subs[k], f)[row:]])
                                 for f in ("pos", "vel", "att", "sigma", "euler")})


def _errors_and_levels(full, res: IntegrityResult) -> dict[str, tuple]:
    """Per axis (error, level) in its unit: horizontal and vertical [m], heading [deg]."""
    return {"horizontal": (np.hypot(full.pos[:, 0], full.pos[:, 1]), res.hpl),
            "vertical": (np.abs(full.pos[:, 2]), res.vpl),
            "heading": (np.degrees(np.abs(full.euler[:, 2])), np.degrees(res.heading_pl))}


def run_row(full, res: IntegrityResult, faults=()) -> tuple[dict, StanfordCounts]:
    """One mode's run: ``integrity.<axis>.<region>`` epoch counts, median level and
    error, the largest error/level; the first detection's time and its candidate; with
    the run's drawn ``faults`` (:class:`~fednav.sensors.faults.Fault`), for the one that
    began first: its sensor, kind, size [sigma] and start, whether a test tripped after it
    started, how long after, whether the candidate was that sensor and whether it was
    excluded; and how many faults the run drew (two at once are not protected against,
    :data:`NOT_PROTECTED`).  And the run's :class:`StanfordCounts`."""
    cfg = res.config
    row: dict = {}
    counts = {}
    both = _errors_and_levels(full, res)
    for axis, _, key in AXES:
        err, pl = both[axis]
        limit = getattr(cfg, key)
        for k, v in regions(err, pl, res.detected, limit).items():
            row[f"integrity.{axis}.{k}"] = v
        row[f"integrity.{axis}.median_level"] = float(np.median(pl))
        row[f"integrity.{axis}.median_error"] = float(np.median(err))
        row[f"integrity.{axis}.max_error_over_level"] = float(np.max(err / pl))
        e = EDGES[axis]
        clip = (e[0] * 1.0001, e[-1] * 0.9999)
        counts[axis] = np.histogram2d(np.clip(err, *clip), np.clip(pl, *clip),
                                      bins=[e, e])[0].astype(np.int64)
    # (detections from the tests as first run: an exclusion replaces the later rows'
    # tests by those of the solution without the excluded sensor)
    hit = res.ratios.max(axis=0) > 1.0
    trip = int(np.argmax(hit)) if hit.any() else None
    ex = res.exclusions[0] if res.exclusions else None
    row["integrity.detected"] = int(trip is not None)
    row["integrity.detected_s"] = float(res.t[trip]) if trip is not None else float("nan")
    row["integrity.candidate"] = res.candidates(trip)[0] if trip is not None else ""
    row["integrity.excluded"] = ex[1] if ex else ""
    row["integrity.excluded_s"] = ex[0] if ex else float("nan")
    row["integrity.faults_drawn"] = len(faults)
    if faults:
        f = min(faults, key=lambda x: x.start)
        after = np.flatnonzero(hit & (res.t >= f.start))
        row["integrity.fault_sensor"] = f.sensor
        row["integrity.fault_kind"] = f.kind
        row["integrity.fault_size_sigma"] = float(np.max(np.abs(f.size_sigma)))
        row["integrity.fault_start_s"] = float(f.start)
        row["integrity.fault_detected"] = int(len(after) > 0)
        row["integrity.time_to_detect_s"] = (float(res.t[after[0]] - f.start) if len(after)
                                             else float("nan"))
        row["integrity.fault_identified"] = int(
            len(after) > 0 and res.candidates(int(after[0]))[0] == f.sensor)
        row["integrity.fault_excluded"] = int(ex is not None and ex[1] == f.sensor)
    return row, StanfordCounts(**counts)


def upper_bound(k: int, n: int, confidence: float = 0.95) -> float:
    """The one-sided Clopper–Pearson upper confidence bound of a rate seen ``k`` times in
    ``n`` trials (``1 − (1 − confidence)^(1/n)`` for ``k`` = 0); NaN for ``n`` = 0."""
    from scipy.special import betaincinv

    if n <= 0:
        return float("nan")
    if k >= n:
        return 1.0
    return float(betaincinv(k + 1, n - k, confidence))


def summarize(rows: list[dict], counts: list[dict], modes: list[str], cfg) -> dict:
    """The campaign's integrity per mode (module docstring): per axis the epochs in each
    region, the misleading (MI) and hazardously misleading (HMI) rates per epoch and per
    run with their 95 % upper bounds, availability (levels below the alert limit), the
    median level against the median error; detections and, with faults, detection and
    identification rates and time to detect; the summed Stanford histograms under
    ``_counts`` (for the plot)."""
    out = {}
    for m in modes:
        mr = [r for r in rows if r.get("mode") == m and "integrity.detected" in r]
        if not mr:
            continue
        n_runs = len(mr)
        s: dict = {"runs": n_runs, "axes": {}}
        for axis, unit, key in AXES:
            def total(name, rs=mr, a=axis):
                return int(sum(r.get(f"integrity.{a}.{name}", 0) or 0 for r in rs))
            epochs = total("epochs")
            # misleading information: an error above its level with no alert (in any
            # region: hazardously misleading and unavailable ones included)
            over = ("misleading", "hazardously_misleading", "unavailable_misleading")
            mi = sum(total(k) for k in over)
            hmi = total("hazardously_misleading")
            runs_mi = sum(1 for r in mr
                          if sum(r.get(f"integrity.{axis}.{k}", 0) or 0 for k in over) > 0)
            runs_hmi = sum(1 for r in mr
                           if (r.get(f"integrity.{axis}.hazardously_misleading", 0) or 0) > 0)
            limit = getattr(cfg, key)
            keys = dict.fromkeys(k.split(".")[2] for r in mr for k in r
                                 if k.startswith(f"integrity.{axis}.") and isinstance(
                                     r[k], int))
            a = {"unit": unit, "alert_limit": limit, "epochs": epochs,
                 "regions": {k: total(k) for k in keys},
                 "alerted_epochs": total("alerted"),
                 "misleading_epochs": mi, "mi_rate": mi / epochs if epochs else None,
                 "mi_rate_upper95": upper_bound(mi, epochs),
                 "runs_misleading": runs_mi, "mi_run_rate_upper95": upper_bound(runs_mi, n_runs),
                 "median_level": float(np.median([r[f"integrity.{axis}.median_level"]
                                                  for r in mr])),
                 "median_error": float(np.median([r[f"integrity.{axis}.median_error"]
                                                  for r in mr])),
                 "max_error_over_level": float(np.max([r[f"integrity.{axis}.max_error_over_level"]
                                                       for r in mr]))}
            if limit is not None:
                unavailable = total("unavailable") + total("unavailable_misleading")
                a.update({"hazardously_misleading_epochs": hmi,
                          "hmi_rate_upper95": upper_bound(hmi, epochs),
                          "runs_hazardously_misleading": runs_hmi,
                          "hmi_run_rate_upper95": upper_bound(runs_hmi, n_runs),
                          "availability": 1.0 - (unavailable + total("alerted")) / epochs
                          if epochs else None})
            a["level_over_error"] = (a["median_level"] / a["median_error"]
                                     if a["median_error"] > 0 else None)
            # the integrity risk claimed per epoch, and whether the runs showed it
            a["risk_budget"] = getattr(cfg, RISK[axis])
            a["risk_shown"] = bool(a["mi_rate_upper95"] <= a["risk_budget"])
            s["axes"][axis] = a
        s["runs_detected"] = int(sum(r["integrity.detected"] for r in mr))
        faulty = [r for r in mr if r.get("integrity.fault_sensor")]
        free = [r for r in mr if not r.get("integrity.fault_sensor")]
        if faulty and free:  # (alternative faults with shares below 1: false-alert runs)
            s["fault_free"] = {"runs": len(free), "tripped": int(sum(
                r["integrity.detected"] for r in free))}
        if faulty:
            s["faults"] = {**_fault_stats(faulty),
                           "sensors": sorted({r["integrity.fault_sensor"] for r in faulty}),
                           "runs_with_two_or_more": int(sum(
                               (r.get("integrity.faults_drawn") or 1) > 1 for r in faulty)),
                           "by_type": _by_type(faulty)}
        c = [x[m] for x in counts if m in x]
        s["_counts"] = {axis: np.sum([getattr(x, axis) for x in c], axis=0)
                        for axis, _, _ in AXES} if c else None
        s["not_protected"] = NOT_PROTECTED
        out[m] = s
    return out


def _fault_stats(rows: list[dict]) -> dict:
    """Detection, identification (the faulty sensor named first) and exclusion of the
    faults of ``rows`` (runs), with the median time to detect [s]."""
    n = len(rows)
    det = [r for r in rows if r["integrity.fault_detected"]]
    ident = int(sum(r["integrity.fault_identified"] for r in rows))
    excl = int(sum(r.get("integrity.fault_excluded", 0) for r in rows))
    return {"runs": n, "detected": len(det), "detection_rate": len(det) / n,
            "identified": ident, "identification_rate": ident / n,
            "excluded": excl, "exclusion_rate": excl / n,
            "median_time_to_detect_s": (float(np.median(
                [r["integrity.time_to_detect_s"] for r in det])) if det else None)}


def _by_type(rows: list[dict]) -> dict:
    """:func:`_fault_stats` per fault type (``sensor kind``) and, within each, per size
    (up to four bins of the drawn sizes [sigma], split at their quartiles)."""
    def kind(r):
        return f"{r['integrity.fault_sensor']} {r.get('integrity.fault_kind', '')}".strip()

    out = {}
    for key in sorted({kind(r) for r in rows}):
        rs = [r for r in rows if kind(r) == key]
        size = np.array([r.get("integrity.fault_size_sigma", np.nan) for r in rs], float)
        t = {**_fault_stats(rs), "by_size": []}
        if np.isfinite(size).all():
            edges = np.unique(np.quantile(size, [0.0, 0.25, 0.5, 0.75, 1.0]))
            if len(edges) == 1:
                edges = np.r_[edges, edges]
            for i, (lo, hi) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
                inside = (size >= lo) & ((size <= hi) if i == len(edges) - 2 else (size < hi))
                b = [r for r, k in zip(rs, inside, strict=True) if k]
                if b:
                    t["by_size"].append({"size_sigma": [float(lo), float(hi)],
                                         **_fault_stats(b)})
        out[key] = t
    return out


def stanford_figure(integrity: dict, title: str = ""):
    """The campaign's Stanford diagram: a row per mode of :func:`summarize`'s output, a
    panel per axis (the summed histograms; the regions' epoch counts written in)."""
    from ..core import plots
    from ..process.stanford import counts_panel

    modes = [m for m, s in integrity.items() if s.get("_counts") is not None]
    fig, axes = plots.new_figure(len(modes), len(AXES),
                                 figsize=(6.0 * len(AXES), 5.2 * len(modes)))
    axes = np.atleast_2d(axes)
    for row, m in zip(axes, modes, strict=True):
        s = integrity[m]
        for ax, (axis, unit, _) in zip(row, AXES, strict=True):
            a = s["axes"][axis]
            counts_panel(ax, s["_counts"][axis], EDGES[axis], a["regions"],
                         a["alert_limit"], axis, unit, title=f"{m}: {axis}")
    fig.suptitle(f"Stanford diagram over {integrity[modes[0]]['runs']} Monte Carlo runs"
                 + (f" ({title})" if title else "") + ": error against protection level",
                 fontsize=11)
    fig.tight_layout()
    return fig


def integrity_lines(integrity: dict) -> list[str]:
    """The campaign's integrity as text lines (console and tables.md)."""
    lines = []
    for m, s in integrity.items():
        lines.append(f"{m}: integrity over {s['runs']} runs")
        for axis, a in s["axes"].items():
            u = a["unit"]
            text = (f"  {axis}: median level {a['median_level']:.3g} {u} against median "
                    f"error {a['median_error']:.3g} {u}; misleading epochs "
                    f"{a['misleading_epochs']} of {a['epochs']} (rate <= "
                    f"{a['mi_rate_upper95']:.2g} at 95 %), runs with one "
                    f"{a['runs_misleading']} of {s['runs']} (<= "
                    f"{a['mi_run_rate_upper95']:.2g})")
            text += (f"; the budget {a['risk_budget']:.0e} per epoch "
                     + ("shown" if a["risk_shown"] else "not shown at this run count"))
            if a["alert_limit"] is not None:
                text += (f"; alert limit {a['alert_limit']:g} {u}: hazardously misleading "
                         f"epochs {a['hazardously_misleading_epochs']} (<= "
                         f"{a['hmi_rate_upper95']:.2g}), availability "
                         f"{100 * a['availability']:.1f} %")
            lines.append(text)
        f = s.get("faults")
        if f:
            for key, t in f["by_type"].items():
                ttd = t["median_time_to_detect_s"]
                lines.append(f"  faults ({key}): detected in {t['detected']} of {t['runs']} "
                             f"runs, the faulty sensor named first in {t['identified']} and "
                             f"excluded in {t['excluded']}"
                             + (f", median {ttd:.1f} s after the fault began"
                                if ttd is not None else ""))
                for b in t["by_size"] if len(t["by_size"]) > 1 else []:
                    lo, hi = b["size_sigma"]
                    lines.append(f"    size {lo:.3g}-{hi:.3g} sigma: detected "
                                 f"{b['detected']}/{b['runs']}, excluded {b['excluded']}")
            if f.get("runs_with_two_or_more"):
                lines.append(f"  {f['runs_with_two_or_more']} runs drew two or more faults "
                             f"(not protected against; counted by the first to begin)")
            if s.get("fault_free"):
                ff = s["fault_free"]
                lines.append(f"  fault-free runs: tests tripped in {ff['tripped']} of "
                             f"{ff['runs']} (false alerts)")
        else:
            lines.append(f"  tests tripped in {s['runs_detected']} of {s['runs']} runs "
                         f"(no fault drawn: false alerts)")
    if lines:
        lines.append(f"  not protected: {NOT_PROTECTED}")
    return lines

"""The navigator's health after a run, from its fault-detection log (one entry per local
measurement: t, local filter, NIS, dof, threshold, isolated): innovations far beyond
their sigma, and local filters isolated for long stretches.  ``fednav process`` turns
them into warnings (and ends a run whose innovations say its data are wrong, unless
forced); streaming users have them as :meth:`fednav.NavResult.health`.  Thresholds and
what they caught: docs/reliability.md.
"""

from __future__ import annotations

import numpy as np

from ..io.data import DataError

#: Mean NIS/dof of a local filter over the run above which ``process`` warns (a
#: consistent filter gives about 1: the figures or the data are wrong) ...
NIS_WARN = 3.0
#: ... and above which the run ends with one line unless forced: data in a wrong unit,
#: time base or axis order give 1e2 .. 1e12.
NIS_REFUSE = 100.0


def nis_check(fdi: list | dict, force: bool = False, seen: list | None = None,
              blame: str | None = None) -> list[str]:
    """Warnings for local filters whose mean NIS/dof over the run's accepted measurements
    exceeds :data:`NIS_WARN`, naming the likely causes; a one-line :class:`DataError`
    beyond :data:`NIS_REFUSE` unless ``force`` (with the first of the input checks'
    warnings ``seen``, the likeliest cause, in it — or ``blame``, the leave-one-out
    culprit, :mod:`fednav.process.culprit`).  Measurements fault detection isolated
    did not touch the solution (a long isolation has its own warning).  ``fdi``: the FDI
    log, or it split per local filter (:func:`by_local`)."""
    out = []
    log = _split(fdi)
    for local in sorted(log):  # (by name, as solution.consistency lists them)
        _, nis, dof, iso = log[local]
        if iso.all():
            continue
        n = float((nis[~iso] / dof[~iso]).mean())  # (consistency()'s nis_per_dof)
        if not n > NIS_WARN:
            continue
        why = (f"the '{local}' local filter's innovations are {n:.3g} times their expected "
               f"size (mean NIS/dof; a consistent filter gives 1)")
        if n > NIS_REFUSE and not force:
            hint = (f"; {blame}" if blame else
                    f"; the input checks said: {seen[0]}" if seen else "")
            raise DataError(f"{why}: the data are likely wrong — a unit (deg/s, g, mg, ms), "
                            f"a time base (GPS vs UTC, Unix time), the axis order or a stuck "
                            f"axis; or the noise figures are far too small (--force to "
                            f"write the solution anyway){hint}")
        out.append(f"{why}: noise figures too optimistic (a vibrating vehicle: fednav "
                   f"tune), or data in a wrong unit, time base or axis order")
    return out


#: A local filter isolated by fault detection for longer than this [s] in one stretch
#: gets a warning (an overconfident filter isolates a sound sensor and may never re-admit
#: it: the solution then drifts with the IMU alone, silently).
ISOLATION_WARN_S = 30.0


def by_local(fdi: list) -> dict[str, tuple[np.ndarray, ...]]:
    """The FDI log (t, local, NIS, dof, threshold, isolated) split per local filter, in
    order of first appearance: local -> (t [s], NIS, dof, isolated) arrays (what the
    checks below take; parsed once per run)."""
    if not fdi:
        return {}
    t, local, nis, dof, _, iso = zip(*fdi, strict=True)
    t, nis, dof = (np.array(a, dtype=float) for a in (t, nis, dof))
    iso = np.array(iso, dtype=bool)
    names = dict.fromkeys(local)
    if len(names) == 1:
        return {str(next(iter(names))): (t, nis, dof, iso)}
    local = np.asarray(local)
    out = {}
    for name in names:
        m = local == name
        out[str(name)] = (t[m], nis[m], dof[m], iso[m])
    return out


def _split(fdi: list | dict) -> dict:
    """The FDI log split per local filter (:func:`by_local`), or ``fdi`` when it is."""
    return by_local(fdi) if isinstance(fdi, list) else fdi


def isolation_warnings(fdi: list | dict) -> list[str]:
    """Warnings for local filters that fault detection isolated for more than
    :data:`ISOLATION_WARN_S` in one stretch, naming the span and the NIS/dof there (from the
    FDI log: t, local, statistic, dof, threshold, isolated; or it split by
    :func:`by_local`)."""
    out = []
    for local, (t, nis, dof, iso) in _split(fdi).items():
        if not iso.any():
            continue
        edges = np.flatnonzero(np.diff(np.r_[0, iso.astype(np.int8), 0]))
        starts, ends = edges[::2], edges[1::2] - 1
        k = int(np.argmax(t[ends] - t[starts]))
        a, b = int(starts[k]), int(ends[k])
        if t[b] - t[a] <= ISOLATION_WARN_S:
            continue
        r = float(np.mean(nis[a:b + 1] / np.maximum(dof[a:b + 1], 1)))
        out.append(f"fault detection isolated the '{local}' local filter from {t[a]:.1f} s "
                   f"to {t[b]:.1f} s ({100 * iso.mean():.0f} % of its measurements; NIS/dof "
                   f"{r:.1f} there): a sensor fault — or a filter too confident of its IMU "
                   f"figures (fednav tune), in which case the solution drifts on the IMU "
                   f"alone; filter.fdi_recovery re-admits after passes in a row, and "
                   f"filter.fdi_readmit_s (default 5 s) bounds how long every position "
                   f"source may stay isolated")
    return out


#: Sliding window [s] of the running NIS/dof, and the mean NIS/dof over one window above
#: which a local filter is warned about (a fault for part of the run: the run's mean
#: dilutes it).
NIS_WINDOW_S = 10.0
NIS_WINDOW_WARN = 10.0


def window_nis(fdi: list | dict) -> list[str]:
    """Warnings for local filters whose NIS/dof over a sliding :data:`NIS_WINDOW_S`
    window of accepted measurements exceeds :data:`NIS_WINDOW_WARN` somewhere (the
    worst window named), unless the run's mean is itself beyond :data:`NIS_WARN` and
    the window no worse than 3 times it (the run's warning says it all then).  ``fdi``:
    the FDI log, or it split by :func:`by_local`."""
    out = []
    for local, (t, nis, dof, iso) in _split(fdi).items():
        t, r = t[~iso], nis[~iso] / np.maximum(dof[~iso], 1)
        if len(t) == 0:
            continue
        mean = float(np.mean(r))
        # mean over the window (t - W, t] of each measurement, by cumulative sums
        c = np.r_[0.0, np.cumsum(r)]
        i = np.arange(len(t))
        lo = np.searchsorted(t, t - NIS_WINDOW_S, side="right")
        roll = (c[i + 1] - c[lo]) / (i + 1 - lo)
        full = t - t[0] >= NIS_WINDOW_S  # whole windows only
        if not full.any():
            continue
        vals = roll[full]
        k = int(np.argmax(vals))
        if vals[k] > NIS_WINDOW_WARN and (mean <= NIS_WARN or vals[k] > 3.0 * mean):
            tk = float(t[full][k])
            out.append(f"the '{local}' local filter's innovations are {vals[k]:.3g} times "
                       f"their expected size over {tk - NIS_WINDOW_S:.1f}..{tk:.1f} s (NIS/dof "
                       f"over {NIS_WINDOW_S:g} s): a sensor fault there, a jump, or a "
                       f"manoeuvre the noise figures do not cover")
    return out


#: Row kinds by what they measure (:mod:`fednav.sensors.measurement`): a sensor's NIS is
#: judged per group too, so that one group near zero is not hidden by another.
ROW_GROUPS = {"position": (0, 1, 2), "velocity": (3, 4, 5), "attitude": (6, 7, 8),
              "body velocity": (9, 10, 11), "angular rate": (12, 13, 14)}
#: The fewest measurements a band is judged on (a mean of fewer is too noisy).
BAND_MIN = 30


def centralized_S(S, R, beta):
    """The innovation covariance of the equivalent centralized filter, ``beta (S - R) +
    R``: a local filter of a federation holds ``P / beta``, so its own ``S`` is too large
    by the prediction's part, and its NIS too small (a precise sensor among eight local
    filters: 0.5 in a consistent filter, ``fednav certify``).  ``S``, ``R`` one
    measurement's (d, d) or a stack (N, d, d), with ``beta`` a number or (N, 1, 1)."""
    S, R = np.asarray(S, dtype=float), np.asarray(R, dtype=float)
    return beta * (S - R) + R


def _stacks(innovations: list, every: bool = False):
    """The accepted records (``every``: all of them, those fault detection rejected too)
    by local filter and dimension, stacked: ``(local, r (N, d), S (N, d, d) of the
    centralized filter)``."""
    groups: dict[tuple[str, int], list] = {}
    for rec in innovations:
        if rec.accepted or every:
            groups.setdefault((rec.local, len(rec.r)), []).append(rec)
    for (local, _), recs in groups.items():
        r = np.array([rec.r for rec in recs], dtype=float)
        beta = np.array([rec.beta for rec in recs], dtype=float)[:, None, None]
        yield local, r, centralized_S([rec.S for rec in recs], [rec.R for rec in recs], beta)


def local_nis(innovations: list, every: bool = False) -> dict[str, tuple[float, int]]:
    """Per local filter: the mean NIS per degree of freedom of its accepted measurements
    (``every``: of all, those fault detection rejected too) against
    :func:`centralized_S` (1 for a consistent filter) and how many."""
    acc: dict[str, list] = {}
    for local, r, S in _stacks(innovations, every):
        a = acc.setdefault(local, [0.0, 0, 0])
        whole = np.isfinite(r).all(axis=1)
        try:  # (every measurement at once; one by one below if a covariance is singular)
            L = np.linalg.cholesky(S[whole])
        except np.linalg.LinAlgError:
            whole[:] = False
        if whole.any():
            w = np.linalg.solve(L, r[whole][..., None])[..., 0]
            a[0] += float(np.einsum("ij,ij->", w, w))
            a[1] += int(whole.sum()) * r.shape[1]
            a[2] += int(whole.sum())
        for i in np.flatnonzero(~whole):  # (a row without a value: the others alone)
            ok = np.isfinite(r[i])
            if not ok.any():
                continue
            try:
                x = float(r[i, ok] @ np.linalg.solve(S[i][np.ix_(ok, ok)], r[i, ok]))
            except np.linalg.LinAlgError:
                continue
            a[0] += x
            a[1] += int(ok.sum())
            a[2] += 1
    return {k: (t / d, n) for k, (t, d, n) in acc.items() if d}


def centralized_consistency(fdi: list, innovations: list) -> dict[str, dict[str, float]]:
    """Per local filter, the fault log's consistency
    (:func:`~fednav.navigator.solution.consistency`) with ``nis_per_dof`` over every
    measurement, isolated ones included, against the equivalent centralized filter's
    innovation covariance (:func:`local_nis`) and the local filter's own as
    ``gate_nis_per_dof`` (equal with one local filter, or without reset)."""
    from .solution import consistency

    out = consistency(fdi)
    for k, (v, _) in local_nis(innovations, every=True).items():
        if k in out:
            out[k] = {"nis_per_dof": v, "gate_nis_per_dof": out[k]["nis_per_dof"],
                      **{a: b for a, b in out[k].items() if a != "nis_per_dof"}}
    return out


def row_nis(innovations: list, kinds: dict) -> dict[str, dict[str, tuple[float, int]]]:
    """Per local filter and row group (:data:`ROW_GROUPS`): the mean over its accepted
    measurements of ``r_i^2 / S_ii`` (each row's squared innovation over its predicted
    variance, :func:`centralized_S`'s: 1 for a consistent filter) and how many.
    ``innovations``: the run's :class:`~fednav.navigator.record.InnovationRecord` s;
    ``kinds``: local filter -> its model's row kinds (``RowModel.kinds``; a local
    without rows is left out)."""
    by: dict[str, list] = {}
    for rec in innovations:
        if rec.accepted and rec.local in kinds:
            by.setdefault(rec.local, []).append(rec)
    out = {}
    for local, recs in by.items():
        k = np.asarray(kinds[local])
        d = len(k)
        recs = [rec for rec in recs if len(rec.r) >= d]
        if not recs:
            continue
        r = np.array([rec.r[:d] for rec in recs], dtype=float)
        beta = np.array([rec.beta for rec in recs], dtype=float)[:, None]
        sd = centralized_S(np.array([np.diagonal(rec.S)[:d] for rec in recs]),
                           np.array([np.diagonal(rec.R)[:d] for rec in recs]), beta)
        q = r**2 / np.where(sd > 0, sd, np.nan)
        groups = {}
        for name, members in ROW_GROUPS.items():
            cols = np.flatnonzero(np.isin(k, members))
            if len(cols):
                v = q[:, cols]
                v = v[np.isfinite(v)]
                if len(v):
                    groups[name] = (float(v.mean()), int(len(v)))
        out[local] = groups
    return out


def band_warnings(fdi: list | dict, band=(0.5, 2.0), rows: dict | None = None,
                  constraints=(), imu_preset: bool = True,
                  means: dict | None = None) -> list[str]:
    """Warnings for local filters whose run-mean NIS/dof lies outside ``band`` ([low,
    high]), each with the likely causes ranked and the key that fixes each, and for a row
    group of a local filter (``rows``: :func:`row_nis`) outside it while the filter's
    mean is inside (one group near zero hidden by another).  ``constraints``: locals
    whose sigma is a softness, not a noise (ZUPT, NHC, ZARU: their NIS sits well below 1
    by design) — judged on the high side only.  Every sensor below the band ranks the
    IMU figures first when they are a preset (``imu_preset``: a grade's, not the IMU's
    own).  ``means``: per local filter the run's NIS/dof and its count from the
    innovations (:func:`local_nis`: against the centralized filter's innovation
    covariance), which replace the fault-detection log's local statistics where given.
    (With a band, :func:`run_health` gives
    these warnings instead of :func:`nis_check`'s.)"""
    lo, hi = band
    log = _split(fdi)
    run = {}
    for local, (_, nis, dof, iso) in log.items():
        keep = ~iso
        if keep.sum() >= BAND_MIN:
            run[local] = float((nis[keep] / dof[keep]).mean())
    run.update({k: v for k, (v, n) in (means or {}).items() if n >= BAND_MIN and k in run})
    means = run
    sensors = [n for n in means if n not in constraints]
    high_all = len(sensors) > 1 and all(means[n] > hi for n in sensors)
    low_all = len(sensors) > 1 and all(means[n] < lo for n in sensors)
    out = []
    for local, n in means.items():
        if lo <= n <= hi or (n < lo and local in constraints):
            continue
        if n > hi:
            causes = [f"sensors.{local}'s sigma too small for its data (sensors.{local}."
                      f"sigma_*, or fednav tune)",
                      "the IMU figures too optimistic for this vehicle (fednav tune, or "
                      "imu.grade)",
                      f"its lever arm or mounting wrong (sensors.{local}.lever_m, "
                      f"mounting)",
                      f"a latency not compensated (sensors.{local}.time_offset_s, "
                      f"timing.delay_compensation)"]
            if high_all:  # every sensor: the common part, the IMU, first
                causes.insert(0, causes.pop(1))
            side = "larger"
        else:
            causes = [f"sensors.{local}'s sigma too large for its data (a sigma in the "
                      f"wrong unit — millimetres as metres? — or the sensor's own "
                      f"pessimistic accuracy; sensors.{local}.sigma_*, or fednav tune)",
                      "the IMU figures too pessimistic (imu.grade too noisy a class, a "
                      "preset assumed for a better IMU; fednav tune)"]
            if low_all and imu_preset:  # every sensor, a preset: the IMU first
                causes.reverse()
            side = "smaller"
        out.append(f"the '{local}' local filter's innovations are {n:.3g} times their "
                   f"expected size (mean NIS/dof over the run, outside the band "
                   f"[{lo:g}, {hi:g}]: {side} than its covariance says); likely causes, "
                   f"most likely first: " + "; ".join(
                       f"{i + 1}) {c}" for i, c in enumerate(causes)))
    for local, groups in (rows or {}).items():
        if local not in means or not lo <= means[local] <= hi or len(groups) < 2:
            continue
        for name, (v, m) in groups.items():
            if m < BAND_MIN or lo <= v <= hi or (v < lo and local in constraints):
                continue
            others = ", ".join(f"{g} {w:.3g}" for g, (w, _) in groups.items() if g != name)
            fix = (f"its {name} sigma too large (a wrong unit: millimetres as metres?)"
                   if v < lo else f"its {name} sigma too small, or a lever arm / latency "
                   f"that moves its {name} rows")
            out.append(f"the '{local}' local filter's {name} rows have NIS/dof {v:.3g} "
                       f"(outside [{lo:g}, {hi:g}]) while its other rows give {others}: "
                       f"{fix} (sensors.{local}.sigma_*)")
    return out


def run_health(fdi: list, imu=None, fixes=None, solution=None, figures: dict | None = None,
               force: bool = True, seen: list | None = None, band=None,
               rows: dict | None = None, constraints=(),
               blame: str | None = None, imu_preset: bool = True,
               means: dict | None = None) -> list[str]:
    """Every check of the health monitor, as warnings: the run's and the sliding
    windows' NIS/dof per local filter, long isolations (from the FDI log ``fdi``), the
    NIS/dof band per local filter and row group (``band``, ``rows``, ``constraints``,
    ``means``: :func:`band_warnings`, ``imu_preset``: the IMU figures a grade's; ``blame``: the
    leave-one-out culprit, named in a refusal), and, with the data, the plausibility
    checks of :mod:`fednav.navigator.plausibility` — stuck axes, gravity and Earth rate
    at rest and the solution's levelling there (needs ``imu``
    (:class:`~fednav.io.data.ImuData`), ``fixes`` (the recording of the sensor whose
    fixes start a run, the GNSS's) with velocities and the IMU's SI ``figures``), the
    fixes' residuals' bias per axis and time offset (needs the forward ``solution`` at
    the IMU rate).  ``force=False`` makes a run NIS/dof beyond
    :data:`NIS_REFUSE` a :class:`DataError` (``seen``: the input checks' warnings, the
    first named in it)."""
    from ..ins import stops
    from . import plausibility as pl

    log = by_local(fdi)
    run = nis_check(log, force, seen, blame)  # (the refusal; its warnings without a band)
    out = isolation_warnings(log) + (run if band is None else band_warnings(
        log, band, rows, constraints, imu_preset, means)) + window_nis(log)
    if imu is None or fixes is None:
        return out
    t = imu.t
    dt = float(pl.median_step(t)) if len(t) > 1 else 1.0
    out += pl.fix_scale_check(fixes)
    if fixes.vel is not None:
        runs, scatter = pl.imu_pass(t, imu.gyro, imu.accel, max(2, int(round(
            stops.WINDOW_S / dt))), pl.STUCK_S)
        out += pl.stuck_axes(t, imu.gyro, imu.accel, runs, fixes.t, fixes.vel)
        if figures:
            spans = pl.rest_spans(t, scatter, dt, float(figures.get(
                "accel_vrw_mps_sqrt_s") or 1e-3), fixes.t, fixes.vel, fixes.sigma_vel)
            lla = fixes.lla[0] if fixes.lla is not None else np.zeros(3)
            out += pl.at_rest(t, imu.gyro, imu.accel, spans, lla, figures, solution)
    if solution is not None:
        out += pl.residual_checks(pl.fix_residuals(solution, fixes), fixes.source)
        if not any("time offset" in w for w in (seen or [])):  # the course check's
            out += pl.offset_check(solution, imu, fixes)
    return out


def readmission_warnings(episodes: list[dict]) -> list[str]:
    """One warning per local filter that fault detection had locked out with every other
    position source and that was re-admitted (``filter.fdi_readmit_s``; ``episodes``:
    :attr:`fednav.NavResult.readmissions`), naming each episode's span [s], NIS/dof and
    the covariance inflation (the first five; then how many more)."""
    out = []
    by: dict[str, list[dict]] = {}
    for e in episodes:
        by.setdefault(e["local"], []).append(e)
    for local, es in by.items():
        spans = "; ".join(f"{e['t_start_s']:.1f}..{e['t_s']:.1f} s (NIS/dof "
                          f"{e['nis_per_dof']:.3g}, covariance x{e['inflation']:.3g})"
                          for e in es[:5])
        more = f" and {len(es) - 5} more" if len(es) > 5 else ""
        out.append(f"fault detection isolated every position source and re-admitted the "
                   f"'{local}' local filter {len(es)} time(s), its innovations having "
                   f"drifted beyond the filter's covariance: {spans}{more} — the filter is "
                   f"too confident of its IMU figures (fednav tune, filter.q_adaptation); "
                   f"the solution drifted on the IMU alone in between")
    return out

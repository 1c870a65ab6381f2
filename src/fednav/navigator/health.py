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


def nis_check(fdi: list, force: bool = False, seen: list | None = None) -> list[str]:
    """Warnings for local filters whose mean NIS/dof over the run's accepted measurements
    exceeds :data:`NIS_WARN`, naming the likely causes; a one-line :class:`DataError`
    beyond :data:`NIS_REFUSE` unless ``force`` (with the first of the input checks'
    warnings ``seen``, the likeliest cause, in it).  Measurements fault detection isolated
    did not touch the solution (a long isolation has its own warning)."""
    from .solution import consistency

    out = []
    for local, c in consistency([e for e in fdi if not e[5]]).items():
        n = c["nis_per_dof"]
        if not n > NIS_WARN:
            continue
        why = (f"the '{local}' local filter's innovations are {n:.3g} times their expected "
               f"size (mean NIS/dof; a consistent filter gives 1)")
        if n > NIS_REFUSE and not force:
            hint = f"; the input checks said: {seen[0]}" if seen else ""
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


def isolation_warnings(fdi: list) -> list[str]:
    """Warnings for local filters that fault detection isolated for more than
    :data:`ISOLATION_WARN_S` in one stretch, naming the span and the NIS/dof there (from the
    FDI log: t, local, statistic, dof, threshold, isolated)."""
    import pandas as pd

    out = []
    if not fdi:
        return out
    log = pd.DataFrame(fdi, columns=["t", "local", "nis", "dof", "thr", "isolated"])
    for local, g in log.groupby("local", sort=False):
        t = g.t.to_numpy()
        iso = g.isolated.to_numpy(dtype=bool)
        if not iso.any():
            continue
        edges = np.flatnonzero(np.diff(np.r_[0, iso.astype(np.int8), 0]))
        starts, ends = edges[::2], edges[1::2] - 1
        k = int(np.argmax(t[ends] - t[starts]))
        a, b = int(starts[k]), int(ends[k])
        if t[b] - t[a] <= ISOLATION_WARN_S:
            continue
        nis = float(np.mean(g.nis.to_numpy()[a:b + 1] / np.maximum(g.dof.to_numpy()[a:b + 1],
                                                                    1)))
        out.append(f"fault detection isolated the '{local}' local filter from {t[a]:.1f} s "
                   f"to {t[b]:.1f} s ({100 * iso.mean():.0f} % of its measurements; NIS/dof "
                   f"{nis:.1f} there): a sensor fault — or a filter too confident of its IMU "
                   f"figures (fednav tune), in which case the solution drifts on the IMU "
                   f"alone; filter.fdi_recovery re-admits after passes in a row")
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

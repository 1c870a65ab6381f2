"""Which sensor's data are wrong: leave-one-out consistency.

In a federated filter with fusion-reset every local filter shares the fused solution, so
one sensor whose file is in a wrong unit, axis order or time base pulls that solution
away and the *other* sensors' innovations show it first — a check that named the local
filter with the largest NIS sent the user to fix the wrong file.  Here the system is run
again without each aiding sensor in turn: the culprit is the one without which every
remaining sensor is consistent (mean NIS/dof inside the band) — the same machinery the
integrity monitor's solution separation needs.
"""

from __future__ import annotations

import numpy as np

from ..navigator.health import local_nis
from ..navigator.solution import consistency


def leave_one_out(prep, band) -> dict[str, dict[str, float]]:
    """Per aiding sensor ``s`` of ``prep`` (a :class:`~fednav.process.run.Prepared`):
    each remaining local filter's mean NIS/dof (against the centralized filter's
    innovation covariance, :func:`~fednav.navigator.health.local_nis`) with ``s`` left
    out (the system without it in ``aiding``, the same data and start)."""
    out = {}
    aiding = list(prep.system.aiding)
    for s in aiding:
        rest = [a for a in aiding if a != s]
        if not rest:
            continue
        sub = type(prep).__new__(type(prep))
        sub.__dict__.update(prep.__dict__)
        sub.system = prep.system.model_copy(update={"aiding": rest})
        res = sub.feed(sub.navigator(record_rows=False, record_covariance=False,
                                     innovations=True)).result()
        central = local_nis(res.innovations, every=True)  # (the centralized filter's)
        out[s] = {k: central[k][0] if k in central else v["nis_per_dof"]
                  for k, v in consistency(res.fdi).items()}
    return out


def culprit(prep, means: dict[str, float], band, constraints=()) -> str | None:
    """One line naming the sensor whose data most likely make the run inconsistent, or
    None: when some local filter's mean NIS/dof (``means``) is above ``band``'s high end
    and the system has at least two aiding sensors, the sensor without which every
    remaining one lies inside the band (or comes closest to it, if that halves the
    excess at least).  ``constraints``
    (ZUPT, NHC ...) are not blamed: they hold only with the others."""
    lo, hi = band
    aiding = [a for a in prep.system.aiding if a in means]
    if len(aiding) < 2 or not any(means[a] > hi for a in aiding):
        return None
    loo = leave_one_out(prep, band)

    def excess(nis: dict) -> float:  # how far the worst remaining sensor is outside
        vals = [v for k, v in nis.items() if k not in constraints and np.isfinite(v)]
        return max((max(v / hi, lo / v) for v in vals), default=np.inf)

    scores = {s: excess(v) for s, v in loo.items() if s not in constraints}
    if not scores:
        return None
    best = min(scores, key=scores.get)
    if scores[best] > 0.5 * excess(means) and scores[best] > 1.0:
        return None  # (no one sensor's removal explains it: the IMU, or two sensors)
    others = ", ".join(f"'{k}' {v:.3g}" for k, v in loo[best].items())
    worst = max(means, key=means.get)
    return (f"leaving each sensor out in turn, the others are consistent only without "
            f"'{best}' (NIS/dof {others}; with it {means[worst]:.3g} for '{worst}'): the "
            f"{best} data are the likely culprit — check that file's units, axis order, "
            f"time stamps and sensors.{best} settings first")

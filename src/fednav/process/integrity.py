"""Integrity of a processed recording: the bank of sub-solutions that each leave one
aiding sensor out, run by the same navigator from the same start, and the protection
levels, tests and exclusion of :mod:`fednav.navigator.integrity` from them.

Each sub-solution is the prepared recording (:class:`~fednav.process.run.Prepared`:
the same initial state, IMU samples, epochs and settings) without one sensor's series
and local filter, so that it uses a subset of the all-sensor solution's measurements
(what the separation's variance ``σ_k² − σ0²`` assumes).  Cost: one navigator run per
recorded aiding sensor besides the all-sensor one.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..core.errors import DataError
from ..navigator import integrity
from ..navigator.integrity import IntegrityResult, solution_separation
from ..navigator.solution import Solution


def tested_sensors(prep) -> list[str]:
    """The recorded aiding sensors whose faults the bank tests
    (:func:`fednav.navigator.integrity.tested_sensors` of those with data)."""
    return [n for n in integrity.tested_sensors(prep.system.aiding) if n in prep.series]


def without(prep, name: str):
    """``prep`` without sensor ``name``'s series and local filter."""
    system = prep.system.model_copy(update={"aiding": [a for a in prep.system.aiding
                                                       if a != name]})
    return replace(prep, system=system,
                   series={n: s for n, s in prep.series.items() if n != name})


def forward(prep) -> Solution:
    """The forward solution of a prepared recording (the navigator run once)."""
    from .run import solution

    return solution(prep.feed(prep.navigator(record_rows=True, record_covariance=True))
                    .result(), prep).forward


def sensor_bank(prep) -> dict[str, Solution]:
    """The forward solution of ``prep`` without each tested sensor, by that sensor."""
    names = tested_sensors(prep)
    if len(names) < 2:
        raise DataError(f"integrity: solution separation needs two or more recorded aiding "
                        f"sensors (this system has {', '.join(names) or 'none'}): each "
                        f"sub-solution that leaves one out must still be aided")
    return {k: forward(without(prep, k)) for k in names}


def exclude(prep, result: IntegrityResult, subs: dict[str, Solution]):
    """After a detection, :func:`fednav.navigator.integrity.exclusion` with each
    candidate's own bank (its sub-solution against those leaving out one more):
    ``(result with the exclusion, the sensor)``, or ``(result, None)``."""
    def after_without(k):
        p = without(prep, k)
        if len(tested_sensors(p)) < 2:
            return None  # (nothing left to check the candidate with)
        return solution_separation(subs[k], sensor_bank(p), result.config)

    return integrity.exclusion(result, after_without)


def apply(forward: Solution, result: IntegrityResult, subs: dict[str, Solution]
          ) -> tuple[Solution, list[str]]:
    """The output solution with its levels: from an exclusion on, the excluded sensor's
    sub-solution (which never saw it); and the warnings saying what happened."""
    out = forward
    warnings = []
    ex = result.excluded
    if (ex >= 0).any():
        i = int(np.argmax(ex >= 0))
        name = result.sensors[int(ex[i])]
        sub = subs[name]
        out = replace(forward, lla=forward.lla.copy(), vel=forward.vel.copy(),
                      euler=forward.euler.copy(), sigma=forward.sigma.copy(),
                      sigma_euler=forward.sigma_euler.copy())
        for f in ("lla", "vel", "euler", "sigma", "sigma_euler"):
            getattr(out, f)[i:] = getattr(sub, f)[i:]
        warnings.append(f"integrity: '{name}' excluded at {forward.t[i]:.3f} s (its solution "
                        f"separation passed the threshold and the solution without it "
                        f"passes its own tests); from then on the solution is the one "
                        f"without it")
    elif (row := result.first_trip()) is not None:
        warnings.append(f"integrity: a fault detected at {forward.t[row]:.3f} s (solution "
                        f"separation {result.test_ratio[row]:.1f} x its threshold, largest "
                        f"for '{result.candidates(row)[0]}') and not excluded: "
                        + ("two sensors cannot say which one is faulty"
                           if len(result.sensors) < 3 else
                           "no sub-solution passes its own tests"))
    n_alert = int(result.alert.sum())
    if n_alert:
        warnings.append(f"integrity: {n_alert} of {len(result.alert)} rows with an alert "
                        f"(a protection level above its alert limit, or a fault detected "
                        f"and not excluded)")
    out.levels = {"hpl_m": result.hpl, "vpl_m": result.vpl,
                  "heading_pl_deg": np.degrees(result.heading_pl),
                  "integrity_alert": result.alert.astype(float),
                  "excluded": result.excluded.astype(float)}
    return out, warnings


def run_integrity(prep, full: Solution, cfg) -> tuple[Solution, IntegrityResult,
                                                      list[str]]:
    """The bank, the separation, the exclusion and the output of one processed recording
    (``cfg``: the system's ``integrity`` section)."""
    subs = sensor_bank(prep)
    result, _ = exclude(prep, solution_separation(full, subs, cfg), subs)
    out, warnings = apply(full, result, subs)
    for name in result.sensors:  # (data that act outside the filter's covariance)
        for role, key in prep.system.sensors[name].roles(prep.system).items():
            warnings.append(f"integrity: {key} feeds the {name} data outside the filter's "
                            f"covariance ({role}): the protection levels do not account "
                            f"for it (set it off for levels that do)")
    return out, result, warnings

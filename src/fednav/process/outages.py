"""Outages on recorded data: a sensor's measurements withheld in windows, and the errors
scored inside them — how a user measures the drift through a GNSS outage on a real
recording (``sensors.<name>.outages_s`` in a processing config).

A window ``[start_s, end_s)`` holds the measurements with ``start_s <= t < end_s`` (the
simulator's rule, :meth:`fednav.sensors.spec.SensorConfig.simulate`), times on the
recording's own clock [s].
"""

from __future__ import annotations

import copy
import dataclasses

import numpy as np

#: The fields of the recorded-data containers that hold one row per measurement (not a
#: file's figures: GnssData's sigma_pos_enu, sigma_vel and lever are three values too).
ROW_FIELDS = {"t", "lla", "vel", "z", "cov", "sigma_rows", "sigma", "t_arrival", "t_avail"}


def inside(t, windows) -> np.ndarray:
    """Whether each time of ``t`` [s] lies in one of ``windows`` ([start, end) s)."""
    t = np.asarray(t, dtype=float)
    m = np.zeros(t.shape, dtype=bool)
    for a, b in windows:
        m |= (t >= a) & (t < b)
    return m


def withhold(data, windows, name: str = "sensor"):
    """A copy of ``data`` (:class:`~fednav.io.GnssData`, :class:`~fednav.io.VelocityData`
    or :class:`~fednav.io.SensorData`) without its measurements inside ``windows``
    (counted in its ``quality["<name>_withheld_in_outages"]``); ``data`` itself when no
    window holds any (or ``data`` is None)."""
    if data is None or not windows:
        return data
    drop = inside(data.t, windows)
    if not drop.any():
        return data
    n, keep = len(data.t), ~drop
    out = copy.copy(data)  # (the kept rows passed the container's checks already)
    own = {f.name for f in dataclasses.fields(data)}  # (fields, not a series' properties)
    for f in ROW_FIELDS & own:
        v = getattr(data, f, None)
        if isinstance(v, np.ndarray) and v.ndim >= 1 and v.shape[0] == n and (
                f != "sigma" or v.ndim == 2):
            setattr(out, f, v[keep])
    out.quality = {**getattr(data, "quality", {}),
                   f"{name}_withheld_in_outages": int(drop.sum())}
    return out


def windows_of(cfg, name: str) -> list[tuple[float, float]]:
    """Sensor ``name``'s ``outages_s`` in the system description ``cfg`` ([] when it has
    no section or none)."""
    sec = cfg.sensors[name] if name in cfg.sensors else None
    return [tuple(map(float, w)) for w in sec.outages_s] if sec is not None else []


def scored(errors: dict, windows) -> list[dict]:
    """Per window: its span, the number of solution rows inside and the RMSE of each
    error series inside (``errors``: :func:`fednav.process.run.errors_against`'s, its
    ``t`` [s]); windows the solution does not reach are left out."""
    from .run import rmse

    out = []
    t = np.asarray(errors["t"])
    for a, b in windows:
        m = (t >= a) & (t < b)
        if not m.any():
            continue
        sub = {k: np.asarray(v)[m] for k, v in errors.items()}
        out.append({"window_s": [a, b], "rows": int(m.sum()), "rmse": rmse(sub)})
    return out

"""Raw GNSS: each satellite's pseudorange and Doppler as measurements (tightly coupled).

Section ``sensors.gnss_raw``.  Where a loosely coupled filter takes the receiver's fix
(:mod:`fednav.sensors.gnss`), and has nothing below four satellites, this sensor takes one
pseudorange row and one range-rate row per satellite, so every satellite the receiver
still tracks aids — one, two or three of them included — and fault detection can exclude
one satellite rather than the receiver (:meth:`fednav.filters.federated.FederatedFilter.
update`'s leave-one-out over :attr:`BoundRanges.groups`).

**The measurement carries its satellites.**  One measurement (one epoch of the receiver)
is ``z`` of :data:`SLOTS` slots of :data:`FIELDS` values each: the satellite's number,
its ECEF position [m] and velocity [m/s] at transmission, already turned by the Earth's
rotation during the signal's transit into the ECEF frame of reception time, the
pseudorange [m] with the satellite clock, group delay, ionosphere and troposphere
removed, the range rate [m/s] (``-lambda`` times the Doppler, the satellite clock drift
removed), and the 1-sigma of both (NaN: the section's ``sigma_*`` scaled by elevation).
An empty slot is NaN.  The reader of a recording (RINEX, u-blox) builds these with the
broadcast ephemeris (:mod:`fednav.sensors.satellites`); the simulator with its
constellation.  The model itself is geometry alone, so one model serves both, and its
rows are compiled functions (:mod:`fednav.sensors.satellite_rows`) that the navigator's
compiled engine calls too.

**Model** (ECEF; ``r``, ``v`` the antenna's position and velocity — the INS's moved by
the lever arm, :func:`fednav.sensors.satellite_rows.antenna` — ``u = (r_s - r) / rho`` the
line of sight, ``cb``, ``cd`` the receiver clock's bias [m] and drift [m/s], the error
states of the ``clock`` block (:mod:`fednav.ins.states`), whose totals the navigator keeps
beside the INS)::

    pseudorange   rho_hat  = |r_s - r| + cb
    range rate    rhod_hat = u . (v_s - v) + cd

Residual ``INS-derived - measured``; with the error state (``dp`` = INS - true in ENU
metres, ``dv`` likewise, ``dcb`` = true - estimated clock, :mod:`fednav.ins.states`)::

    d(rho)  = -u_n . dp_ant - dcb
    d(rhod) = -u_n . dv_ant - ((w - rhod u) / rho)_n . dp_ant - dcd,  w = v_s - v

(``_n``: in ENU; ``dp_ant``, ``dv_ant`` the antenna's errors, the lever arm's attitude
coupling included as the position and velocity rows of
:mod:`fednav.sensors.measurement` have it).  ``tests/test_gnss_raw.py`` checks ``H``
against finite differences of the range model.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar, Literal

import numpy as np
from pydantic import Field, ValidationInfo, field_validator

from ..core import earth, units
from ..core.config import simulation_only
from .base import MeasurementSeries, flight_times
from .measurement import NavSnapshot, View
from .satellite_rows import (  # noqa: F401  (the clock test's thresholds, for the docs)
    CLOCK_DRIFT_JUMP_MPS,
    CLOCK_JUMP_M,
    FIELDS,
    MAX_ROWS,
    PR,
    PRN,
    RR,
    SLOTS,
    SPR,
    SRR,
    SVX,
    SVZ,
    SX,
    SZ,
    WIDTH,
    antenna,
    antenna_rows,
    bind,
    elevation_sigma,
    median,
    noise,
    points_rows,
)
from .satellites import (
    F_L1,
    GM,
    OMEGA_E,
    WEEK_S,
    Ephemerides,
    azimuth_elevation,
    dilution,
    earth_turned,
    epoch_least_squares,
    klobuchar,
    nearest_ephemeris,
    read_navigation,
    saastamoinen,
    satellite_states,
    single_point,
)
from .satellites import C as LIGHT
from .spec import Column, SensorConfig, SensorSpec

#: Receiver clocks' Allan-variance coefficients (h0, h_-2) [s, 1/s] (Brown and Hwang,
#: table 9.1): a temperature-compensated and an oven-controlled crystal oscillator.
CLOCKS = {"tcxo": (2e-19, 2e-20), "ocxo": (2e-25, 6e-25)}
#: ``np.median`` to the bit (the clock test's, :func:`fednav.sensors.satellite_rows.median`)
_median = median


def has_satellite(z) -> np.ndarray:
    """Rows of ``z`` (N, :data:`WIDTH`) holding at least one whole satellite (number,
    position, velocity, pseudorange)."""
    s = np.asarray(z, dtype=float).reshape(len(z), SLOTS, len(FIELDS))
    return np.isfinite(s[:, :, PRN:PR + 1]).all(axis=2).any(axis=1)


def pack(rows) -> np.ndarray:
    """Satellite rows (n <= SLOTS, len(FIELDS)) as one measurement's ``z`` (NaN slots
    after them)."""
    rows = np.asarray(rows, dtype=float).reshape(-1, len(FIELDS))
    if len(rows) > SLOTS:
        raise ValueError(f"gnss_raw: {len(rows)} satellites in one epoch; a measurement "
                         f"holds {SLOTS} (keep the highest)")
    out = np.full((SLOTS, len(FIELDS)), np.nan)
    out[:len(rows)] = rows
    return out.ravel()


def _antenna(nav: NavSnapshot, lever, frame: bool = False):
    """ECEF position and velocity of the antenna, C_n^e there and its latitude,
    longitude and height; with ``frame`` also d(C_n^e v)/d(east, north) [1/s] (3, 2)
    (:func:`fednav.sensors.satellite_rows.antenna`)."""
    out = antenna(_view(nav), np.ascontiguousarray(lever, dtype=float))
    return out if frame else out[:4]


def _view(nav: NavSnapshot) -> View:
    """The INS of ``nav`` as the compiled rows take it: position, velocity, C_b^n, body
    rate (zero when not given)."""
    return View(np.ascontiguousarray(nav.lla, dtype=float),
                np.ascontiguousarray(nav.vel, dtype=float),
                np.ascontiguousarray(nav.C, dtype=float),
                np.zeros(3) if nav.omega_b is None else np.ascontiguousarray(nav.omega_b,
                                                                             dtype=float))


class BoundRanges:
    """The rows of one measurement (see the module docstring): the satellites ``sat``
    used (rows of :data:`FIELDS`; a NaN range rate: no range-rate row) over an error
    state of ``n`` columns whose clock bias and drift are columns ``ic``, ``ic + 1``, with
    the clock totals ``clock`` = (cb, cd) [m, m/s] of the filter epoch, the measurement
    valid ``dt`` [s] after it.  ``dim`` rows, pseudoranges of the satellites first, then
    their range rates; ``groups`` the satellite of each row; ``R`` their noise [m^2,
    (m/s)^2].  The rows are :func:`fednav.sensors.satellite_rows.rows`, the compiled
    engine's own."""

    linear = True

    def __init__(self, sat, lever, n: int, ic: int, clock, dt: float = 0.0):
        self.sat = np.ascontiguousarray(sat, dtype=float)
        self.lever = np.ascontiguousarray(lever, dtype=float)
        self.n, self.ic, self.dt = int(n), int(ic), float(dt)
        self.clock = np.array(clock, dtype=float)
        self.R, self.groups, self._ids = noise(self.sat)
        self.dim = len(self.groups)
        self._cache = (None, None)

    @property
    def use_rr(self) -> np.ndarray:
        """Which satellites have a range-rate row."""
        return np.isfinite(self.sat[:, RR])

    @property
    def row_keys(self) -> list:
        """A key per row, the same for the same satellite's same kind of row from one
        measurement to the next (what an adaptive filter keeps its R estimate under)."""
        m = len(self.sat)
        return ([("gnss_raw.pr", int(g)) for g in self.groups[:m]]
                + [("gnss_raw.rr", int(g)) for g in self.groups[m:]])

    @property
    def row_ids(self) -> np.ndarray:
        """An integer per row, ``2 prn`` for a pseudorange and ``2 prn + 1`` for a range
        rate: the lockout guard compares two epochs' rows satellite by satellite by it
        (:func:`fednav.filters.federated.lockout_step`)."""
        return self._ids

    def _rows(self, nav: NavSnapshot):
        """(residual, H) against ``nav`` (the residual and H of one update: one call)."""
        if self._cache[0] is not nav:
            self._cache = (nav, antenna_rows(self.sat, _view(nav), self.lever, self.clock,
                                             self.dt, self.n, self.ic))
        return self._cache[1]

    def residual(self, nav: NavSnapshot, z=None) -> np.ndarray:
        return self._rows(nav)[0]

    def H(self, nav: NavSnapshot) -> np.ndarray:
        return self._rows(nav)[1]

    def h(self, X, nav: NavSnapshot) -> np.ndarray:
        return points_rows(np.ascontiguousarray(np.atleast_2d(X), dtype=float), self.H(nav))

    def subset(self, keep) -> BoundRanges:
        """These rows less those not in ``keep`` (a satellite's two rows go together when
        ``keep`` comes from :attr:`groups`)."""
        keep = np.asarray(keep, dtype=bool)
        m = len(self.sat)
        k_pr = keep[:m]
        k_rr = np.zeros(m, dtype=bool)
        k_rr[np.flatnonzero(self.use_rr)] = keep[m:]
        sat = self.sat[k_pr].copy()
        sat[~k_rr[k_pr], RR] = np.nan
        return BoundRanges(sat, self.lever, self.n, self.ic, self.clock, self.dt)


class SatelliteRanges:
    """The raw GNSS measurement model (module docstring): :meth:`bind` gives the rows of
    one measurement — how many depends on the satellites it holds — over the filter's
    error state with its ``clock`` block (:attr:`own_block`).  ``sigma_pr``,
    ``sigma_rr``: the zenith 1-sigma of a pseudorange [m] and a range rate [m/s] for
    satellites whose slot gives none; ``mask``: the elevation mask [rad].  The compiled
    engine runs it (:attr:`engine_rows`) with the same functions,
    :mod:`fednav.sensors.satellite_rows`."""

    kind = "gnss_raw"
    #: the optional error-state block the measurement needs (:mod:`fednav.ins.states`)
    own_block = "clock"
    #: the antenna's lever arm acts (:func:`fednav.sensors.measurement.mounted`)
    takes_lever = True
    #: its satellites fix the position (:attr:`fednav.sensors.spec.SensorSpec.
    #: fixes_position`: fault isolation may not lock it out for good)
    fixes_position = True
    #: no fixed component of ``z`` must be finite (empty slots are NaN)
    zindex = np.zeros(0, dtype=np.int64)
    linear = True
    #: the compiled engine's rows of this model (:data:`fednav.navigator.engine.ROWS`)
    engine_rows = "satellites"
    #: rows and values of ``z`` one measurement has at most
    max_rows, width = MAX_ROWS, WIDTH

    def __init__(self, sigma_pr: float = 3.0, sigma_rr: float = 0.1,
                 mask: float = float(units.deg(10.0))):
        self.sigma_pr, self.sigma_rr, self.mask = float(sigma_pr), float(sigma_rr), mask
        self.lever = np.zeros(3)
        #: how often :meth:`bind` moved the clock's total by a jump
        self.clock_resets = 0

    @property
    def figures(self) -> np.ndarray:
        """(mask [rad], sigma_pr [m], sigma_rr [m/s]) as the compiled engine takes them."""
        return np.array([self.mask, self.sigma_pr, self.sigma_rr])

    def bind(self, z, nav: NavSnapshot, layout, xa, dt: float = 0.0) -> BoundRanges:
        """The rows of measurement ``z`` against the INS ``nav``, over the error state of
        ``layout`` (:class:`~fednav.ins.states.StateLayout`) with the clock totals in
        ``xa`` (read now) — totals of the filter epoch, ``dt`` [s] after which the
        measurement is valid (negative: before; the rows take the clock there, ``cb + dt
        cd``, and its error ``dcb + dt dcd``).  When the median pseudorange residual
        exceeds ``CLOCK_JUMP_M`` the clock's total in ``xa`` moves by it first (a
        receiver's millisecond clock jump, or the first epoch's bias), and the drift's by
        the median range-rate residual beyond ``CLOCK_DRIFT_JUMP_MPS`` (counted in
        :attr:`clock_resets`; :func:`fednav.sensors.satellite_rows.bind`)."""
        ic = layout.start(self.own_block)
        if ic < 0:
            raise ValueError("gnss_raw: the error state has no clock block (the navigator "
                             "adds it when gnss_raw aids)")
        clock = xa[ic:ic + 2]  # (a view: moved in place)
        sat, y, H, moved = bind(np.ascontiguousarray(z, dtype=float), _view(nav),
                                self.lever, clock, float(dt), self.figures, layout.n, ic)
        self.clock_resets += int(moved)
        out = BoundRanges(sat, self.lever, layout.n, ic, clock, dt)
        out._cache = (nav, (y, H))
        return out


# ------------------------------------------------------------------ a receiver's files
def from_observations(t, pr, doppler, sv, eph, *, mask_deg: float = 10.0,
                      iono: bool = True, tropo: bool = True, cn0=None,
                      sigma_pr: float = 3.0, sigma_rr: float = 0.1):
    """Raw GNSS measurements (``z`` (N, :data:`WIDTH`)) from a receiver's observations.

    ``t`` (N,) receive times, GPS time [s]; ``pr`` (N, M) L1 C/A pseudoranges [m];
    ``doppler`` (N, M) L1 Dopplers [Hz] (positive approaching, RINEX's sign; None or NaN:
    no range-rate row); ``sv`` (M,) the satellites' ids in ``eph`` (GPS broadcast
    ephemerides, :func:`fednav.io.rinex.read_rinex_nav`); ``cn0`` (N, M) [dB-Hz],
    optional: each satellite's 1-sigma is then written, the zenith ``sigma_pr`` [m] and
    ``sigma_rr`` [m/s] scaled by elevation (:func:`elevation_sigma`) and by
    ``10^((45 - C/N0) / 20)`` below 45 dB-Hz (without ``cn0`` it is left NaN: the
    section's figures by elevation).

    Per epoch and satellite (:mod:`fednav.sensors.satellites`): the transmit time from
    the pseudorange and the satellite clock, the satellite's position, velocity, clock
    offset (relativistic term and ``TGD`` included) and drift there, turned by the
    Earth's rotation during the transit; the pseudorange less the satellite clock,
    Klobuchar's ionosphere and Saastamoinen's troposphere (both at the single-point
    position of the epoch, or the nearest epoch that has one: they change by centimetres
    over hundreds of metres); the range rate ``-lambda_L1 D`` plus the satellite's clock
    drift.  Satellites below ``mask_deg`` [deg] there, or without a usable ephemeris, are
    left out; an epoch keeps the :data:`SLOTS` highest.  Returns ``(t, z, used)``: the
    epochs with a satellite, their ``z``, and the satellites each kept (N,).
    """
    t = np.asarray(t, dtype=float)
    pr = np.asarray(pr, dtype=float)
    N, M = pr.shape
    dop = np.full_like(pr, np.nan) if doppler is None else np.asarray(doppler, dtype=float)
    spp = single_point(t, pr, sv, eph, iono=iono, tropo=tropo, mask_deg=mask_deg)
    good = np.flatnonzero(np.isfinite(spp.xyz[:, 0]))
    if not len(good):
        raise ValueError("gnss_raw: no epoch with four satellites to place the receiver "
                         "for its ionosphere, troposphere and elevation mask")
    j = np.clip(np.searchsorted(good, np.arange(N)), 1, max(len(good) - 1, 1))
    before, after = good[np.maximum(j - 1, 0)], good[np.minimum(j, len(good) - 1)]
    near = np.where(np.abs(after - np.arange(N)) < np.abs(np.arange(N) - before), after,
                    before)
    rx = spp.xyz[near]
    lla = earth.ecef_to_llh(rx)
    idx = nearest_ephemeris(eph, np.asarray(sv), t)
    tau = np.where(np.isfinite(pr), pr, 0.0) / LIGHT
    t_tx = t[:, None] - tau
    _, _, clk, _ = satellite_states(eph, idx, t_tx, True)
    t_tx = t_tx - np.nan_to_num(clk)
    pos, vel, clk, drift = satellite_states(eph, idx, t_tx, True)
    tau = np.linalg.norm(pos - rx[:, None, :], axis=-1) / LIGHT  # (transit)
    pos, vel = earth_turned(pos, tau), earth_turned(vel, tau)
    az, el = azimuth_elevation(lla[:, None, :], rx[:, None, :], pos)
    corr = np.zeros((N, M))
    if iono and eph.iono is not None:
        corr += klobuchar(eph.iono, lla[:, None, 0], lla[:, None, 1], az, el,
                          np.mod(t[:, None], 604800.0))
    if tropo:
        corr += saastamoinen(lla[:, None, 0], lla[:, None, 2], el)
    prc = pr + LIGHT * clk - corr
    rr = -LIGHT / F_L1 * dop + LIGHT * drift
    ok = np.isfinite(prc) & np.isfinite(pos[..., 0]) & (el >= np.radians(mask_deg))
    prn = np.array([int(str(v)[1:]) if str(v)[:1].isalpha() else int(v) for v in sv],
                   dtype=float)
    w = np.full((N, M), np.nan) if cn0 is None else \
        10.0 ** ((45.0 - np.asarray(cn0, dtype=float)) / 20.0)
    z = np.full((N, WIDTH), np.nan)
    used = np.zeros(N, dtype=int)
    for i in range(N):
        k = np.flatnonzero(ok[i])
        k = k[np.argsort(-el[i, k])][:SLOTS]
        if not len(k):
            continue
        f = np.maximum(w[i, k], 1.0)  # (no better than the elevation's own figure)
        rows = np.column_stack([prn[k], pos[i, k], vel[i, k], prc[i, k], rr[i, k],
                                f * elevation_sigma(sigma_pr, el[i, k]),
                                f * elevation_sigma(sigma_rr, el[i, k])])
        z[i] = pack(rows)
        used[i] = len(k)
    keep = used > 0
    return t[keep], z[keep], used[keep]


def geometry(z, lla, mask: float = float(units.deg(10.0))):
    """Satellites above ``mask`` [rad] and their DOP per measurement: ``z`` (N,
    :data:`WIDTH`) seen from ``lla`` (N, 3) [rad, rad, m] (the solution at each
    measurement's time).  Returns ``(n, pdop, hdop, vdop)`` (N,) each (DOP NaN below four
    satellites; a receiver clock per epoch)."""
    z = np.asarray(z, dtype=float).reshape(len(z), SLOTS, len(FIELDS))
    lla = np.asarray(lla, dtype=float)
    r = earth.llh_to_ecef(lla[:, 0], lla[:, 1], lla[:, 2])
    az, el = azimuth_elevation(lla[:, None, :], r[:, None, :], z[:, :, SX:SZ + 1])
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(z[:, :, PRN]) & (el >= mask)
    ce = np.cos(el)
    G = np.stack([ce * np.sin(az), ce * np.cos(az), np.sin(el), np.ones_like(el)], axis=-1)
    dop = dilution(np.where(ok[..., None], G, 0.0))
    return ok.sum(axis=1), dop[:, 1], dop[:, 2], dop[:, 3]


def report(series, solution, model=None) -> dict:
    """What ``summary.json`` says of a raw GNSS recording flown against ``solution``
    (:class:`fednav.navigator.Solution`): satellites above the mask per epoch (mean,
    least, epochs with fewer than four), PDOP / HDOP (median, largest) and how often
    ``model`` (its :class:`SatelliteRanges`) moved the receiver clock's total by a jump."""
    t = np.asarray(series.t, dtype=float)
    flown = (t >= solution.t[0]) & (t <= solution.t[-1])  # (those the solution covers)
    t = t[flown]
    lla = np.column_stack([np.interp(t, solution.t, solution.lla[:, i]) for i in range(3)])
    n, pdop, hdop, _ = geometry(np.asarray(series.z)[flown], lla)
    out = {"epochs": int(len(t)), "satellites_mean": round(float(np.mean(n)), 2) if len(n)
           else 0.0, "satellites_min": int(n.min()) if len(n) else 0,
           "epochs_below_four": int((n < 4).sum())}
    for name, v in (("pdop", pdop), ("hdop", hdop)):
        f = v[np.isfinite(v)]
        out[f"{name}_median"] = round(float(np.median(f)), 2) if len(f) else None
        out[f"{name}_max"] = round(float(f.max()), 2) if len(f) else None
    out["clock_resets"] = int(getattr(model, "clock_resets", 0))
    return out


def single_point_fixes(series, section):
    """The receiver's single-point solutions from its own rows (what a recording without
    a fix sensor and without ``initial:`` starts from): per epoch with four satellites or
    more, the position and clock by iterated least squares over the pseudoranges (each
    weighted by its 1-sigma: the slot's, else ``section``'s zenith figure by elevation),
    then the velocity and clock drift from the range rates, every epoch at once.
    Returns ``(t, lla (N, 3) [rad, rad, m], ENU velocity (N, 3) [m/s], position 1-sigma
    (3,) east/north/up [m], velocity 1-sigma (3,) [m/s])`` of the epochs solved, the
    1-sigma the median over them of each row's 1-sigma times the DOP; without range
    rates at four satellites (a receiver file without Doppler) in most epochs, the
    positions alone (velocity None, its 1-sigma NaN: the start takes the velocity from
    the positions' differences)."""
    t = np.asarray(series.t, dtype=float)
    z = np.asarray(series.z, dtype=float).reshape(len(t), SLOTS, len(FIELDS))
    S, V = z[..., SX:SZ + 1], z[..., SVX:SVZ + 1]
    pr, rr = z[..., PR], z[..., RR]
    ok = np.isfinite(z[..., PRN]) & np.isfinite(S).all(-1) & np.isfinite(pr)
    okr = ok & np.isfinite(V).all(-1) & np.isfinite(rr)
    x = np.zeros((len(t), 4))  # (from the Earth's centre: a few iterations to converge)
    solved = ok.sum(axis=1) >= 4
    sig_pr = np.where(np.isfinite(z[..., SPR]), z[..., SPR], section.sigma_pseudorange_m)
    sig_rr = np.where(np.isfinite(z[..., SRR]), z[..., SRR], section.sigma_range_rate_mps)

    def solve(G, w, y, good):
        dx, A = epoch_least_squares(G, w, y, good)
        dx[~good] = np.nan
        return dx, A

    with np.errstate(invalid="ignore", divide="ignore"):
        for _ in range(10):
            d = np.where(ok[..., None], S - x[:, None, :3], 1.0)
            rho = np.linalg.norm(d, axis=-1)
            u = d / rho[..., None]
            G = np.concatenate([-u, np.ones((*u.shape[:2], 1))], axis=-1)
            dx, A = solve(G, np.where(ok, 1.0 / sig_pr**2, 0.0),
                          np.where(ok, pr - rho - x[:, 3:], 0.0), solved)
            x[solved] += dx[solved]
        vd, Av = solve(G, np.where(okr, 1.0 / sig_rr**2, 0.0),
                       np.where(okr, rr - np.einsum("nsi,nsi->ns", u, np.nan_to_num(V)), 0.0),
                       solved & (okr.sum(axis=1) >= 4))
    moving = np.isfinite(vd[:, 0])
    with_vel = (moving & solved).sum() >= 0.5 * solved.sum()
    good = solved & moving if with_vel else solved
    if not good.any():
        return t[good], np.zeros((0, 3)), None, np.full(3, np.nan), np.full(3, np.nan)
    lla = earth.ecef_to_llh(x[good, :3])
    Cne = earth.enu_to_ecef(lla[:, 0], lla[:, 1])

    def enu_sigma(A):  # (the rows' own 1-sigma through the dilution, median over epochs)
        Q = np.linalg.inv(A[good])[:, :3, :3]
        return np.sqrt(np.median(np.einsum("nji,njk,nkl->nil", Cne, Q, Cne).diagonal(
            axis1=1, axis2=2), axis=0))

    if not with_vel:
        return t[good], lla, None, enu_sigma(A), np.full(3, np.nan)
    vel = np.einsum("nji,nj->ni", Cne, vd[good, :3])
    return t[good], lla, vel, enu_sigma(A), enu_sigma(Av)


def figure(series, solution, excluded=()):
    """``gnss_raw.png`` of ``fednav process`` as a :class:`~matplotlib.figure.Figure`:
    the satellites above the mask at each epoch the solution covers (the satellites
    fault detection ``excluded`` — ``(t, local filter, satellite id, statistic)`` —
    marked at their epochs, with their ids), and the PDOP and HDOP (NaN below four
    satellites: the epochs with fewer shaded), against time [s]."""
    from ..core import plots

    t = np.asarray(series.t, dtype=float)
    flown = (t >= solution.t[0]) & (t <= solution.t[-1])
    t = t[flown]
    lla = np.column_stack([np.interp(t, solution.t, solution.lla[:, i]) for i in range(3)])
    n, pdop, hdop, _ = geometry(np.asarray(series.z)[flown], lla)
    fig, axes = plots.new_figure(2, 1, figsize=(11, 6.5), sharex=True)
    a, b = axes[0, 0], axes[1, 0]
    a.step(t, n, where="post", color="C0", label="above the mask")
    edges = np.flatnonzero(np.diff(np.r_[0, (n < 4).astype(int), 0]))
    few = [(t[i], t[min(j, len(t) - 1)]) for i, j in zip(edges[::2], edges[1::2],
                                                          strict=True)]
    for ax in (a, b):
        plots.shade_spans(ax, few)
    if len(excluded):
        te = np.array([float(e[0]) for e in excluded])
        a.plot(te, np.interp(te, t, n), "x", color="C3", ms=8,
               label=f"excluded by fault detection ({len(te)})")
        for k, e in enumerate(excluded[:20]):
            a.annotate(f"{int(e[2])}", (te[k], np.interp(te[k], t, n)), fontsize=7,
                       xytext=(3, 3), textcoords="offset points", color="C3")
    a.axhline(4, color="0.5", lw=0.8, ls=":")
    a.set_ylabel("satellites")
    a.set_ylim(0, max(5, int(n.max(initial=0)) + 1))
    a.set_title("raw GNSS: satellites and dilution of precision (fewer than four shaded)")
    b.plot(t, pdop, color="C1", label="PDOP")
    b.plot(t, hdop, color="C2", label="HDOP")
    b.set_ylabel("DOP")
    fin = np.concatenate([pdop[np.isfinite(pdop)], [1.0]])
    b.set_ylim(0, min(20.0, 1.1 * float(np.percentile(fin, 99))) + 0.5)
    b.set_xlabel("time [s]")
    for ax in (a, b):
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    return fig


def light_time(eph, t, r, iterations: int = 3):
    """What a receiver at ECEF ``r`` (N, 3) [m] sees at GPS times ``t`` (N,) [s] of every
    satellite of ``eph`` (its ``sv`` in order of first record): the light-time equation
    ``tau = |R(OMEGA_E tau) p(t - tau) - r| / c`` solved by iteration.  Returns the
    satellites' ids (M,), and per epoch and satellite (N, M) their positions and
    velocities at transmission in the frame at reception [m, m/s], their clock offsets
    [s] and drifts [s/s] (relativistic term and TGD included: what an L1 pseudorange
    carries) and the geometric ranges [m]; NaN where a satellite has no ephemeris within
    2 h."""
    sv = np.array(list(dict.fromkeys(np.asarray(eph.sv).tolist())))
    idx = nearest_ephemeris(eph, sv, np.asarray(t, dtype=float))
    tau = np.full(idx.shape, 0.075)
    for _ in range(iterations + 1):
        p, v, clk, drift = satellite_states(eph, idx, t[:, None] - tau, True)
        pos = earth_turned(p, tau)
        rho = np.linalg.norm(pos - r[:, None, :], axis=-1)
        tau = np.where(np.isfinite(rho), rho / LIGHT, 0.075)
    return sv, pos, earth_turned(v, tau), clk, drift, rho


# ---------------------------------------------------------------------------- simulation
#: GPS's nominal orbit: semi-major axis [m] and inclination (IS-GPS-200, the almanac's).
GPS_A = 26_559_700.0
GPS_I = np.radians(55.0)
#: GPS time [s] of a simulation's zero by default: 2026-01-04 00:00:00 GPS (week 2400).
START_GPS_S = 2400 * WEEK_S
#: How long a broadcast ephemeris record of :func:`walker_ephemerides` is used [s]
#: (GPS's: a new record every 2 h).
RECORD_S = 7200.0


def _walker_slots(n_planes: int, per_plane: int, phasing: int, epoch_deg: float):
    """Each satellite's right ascension of its node and argument of latitude at time zero
    [rad] in a Walker delta constellation (planes, satellites per plane, phasing)."""
    S = n_planes * per_plane
    plane, slot = np.divmod(np.arange(S), per_plane)
    return (2 * np.pi * plane / n_planes,
            2 * np.pi * slot / per_plane + 2 * np.pi * phasing * plane / S
            + np.radians(epoch_deg))


def walker(t, n_planes: int = 6, per_plane: int = 5, phasing: int = 1,
           epoch_deg: float = 0.0):
    """A Walker delta constellation of GPS's orbits (circular, 55 deg, 26 560 km) at
    times ``t`` [s]: ECEF positions and velocities (N, S, 3) [m, m/s] of its
    ``n_planes * per_plane`` satellites (numbered 1..S).  ``epoch_deg`` turns the whole
    constellation along its orbits (another geometry of the sky)."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    n = np.sqrt(GM / GPS_A**3)
    raan, m0 = _walker_slots(n_planes, per_plane, phasing, epoch_deg)
    u = m0[None, :] + n * t[:, None]  # argument of latitude
    lon = raan[None, :] - OMEGA_E * t[:, None]  # node's longitude in the Earth frame
    cu, su = np.cos(u), np.sin(u)
    cO, sO = np.cos(lon), np.sin(lon)
    ci, si = np.cos(GPS_I), np.sin(GPS_I)
    pos = GPS_A * np.stack([cu * cO - su * ci * sO, cu * sO + su * ci * cO, su * si], -1)
    # inertial velocity, then less the Earth's rotation (w x r)
    du = -su * n, cu * n
    vel = GPS_A * np.stack([du[0] * cO - du[1] * ci * sO, du[0] * sO + du[1] * ci * cO,
                            du[1] * si], -1)
    vel = vel + OMEGA_E * np.stack([pos[..., 1], -pos[..., 0], np.zeros_like(pos[..., 0])],
                                   -1)
    return pos, vel


def walker_ephemerides(start: float, end: float, n_planes: int = 6, per_plane: int = 5,
                       phasing: int = 1, epoch_deg: float = 0.0) -> Ephemerides:
    """:func:`walker`'s constellation as GPS broadcast ephemerides from GPS time
    ``start`` [s] (the walker's time zero) to ``end``: circular orbits (``e``, the
    perturbation terms and the clocks zero), one record per satellite every
    :data:`RECORD_S` (``toe`` = ``toc`` on that grid), so that
    :func:`~fednav.sensors.satellites.satellite_states` at GPS time ``T`` gives
    ``walker(T - start)`` and a RINEX navigation file carries the sky
    (:func:`fednav.io.rinex.write_rinex_nav`).  No Klobuchar coefficients (the simulated
    signal has no ionosphere)."""
    raan, m0 = _walker_slots(n_planes, per_plane, phasing, epoch_deg)
    S, k = len(raan), np.arange(len(raan))
    n = np.sqrt(GM / GPS_A**3)
    toe = start + RECORD_S * np.arange(int(np.ceil(max(end - start, 0.0) / RECORD_S)) + 1)
    toe_r, sat = np.repeat(toe, S), np.tile(k, len(toe))
    z = np.zeros(len(sat))
    el = {"sqrt_a": np.full(len(sat), np.sqrt(GPS_A)), "e": z, "i0": np.full(len(sat), GPS_I),
          "omega0": np.mod(raan[sat] + OMEGA_E * (start - toe_r)
                           + OMEGA_E * np.mod(toe_r, WEEK_S), 2 * np.pi),
          "omega": z, "m0": np.mod(m0[sat] + n * (toe_r - start) + np.pi, 2 * np.pi) - np.pi,
          **{k_: z for k_ in ("delta_n", "omega_dot", "idot", "cuc", "cus", "cic", "cis",
                              "crc", "crs", "af0", "af1", "af2", "tgd", "health")}}
    return Ephemerides("walker", np.array([f"G{i + 1:02d}" for i in sat]), toe_r, toe_r,
                       {k_: v.copy() for k_, v in el.items()})


def clock_walk(t, h0: float, hm2: float, bias0: float, drift0: float, rng):
    """A receiver clock's bias [m] and drift [m/s] at times ``t`` [s]: the two-state model
    (white frequency noise ``S_f = h0 / 2 c^2``, random-walk frequency ``S_g = 2 pi^2
    h_-2 c^2``) discretised exactly between samples."""
    sf, sg = h0 / 2 * LIGHT**2, 2 * np.pi**2 * hm2 * LIGHT**2
    out = np.empty((len(t), 2))
    x = np.array([bias0, drift0])
    prev = t[0] if len(t) else 0.0
    for i, ti in enumerate(t):
        d = ti - prev
        if d > 0:
            Q = np.array([[sf * d + sg * d**3 / 3, sg * d**2 / 2], [sg * d**2 / 2, sg * d]])
            x = np.array([x[0] + d * x[1], x[1]]) + np.linalg.cholesky(
                Q + 1e-30 * np.eye(2)) @ rng.standard_normal(2)
        out[i] = x
        prev = ti
    return out


class SatelliteSeries(MeasurementSeries):
    """Raw GNSS measurements: a satellite's slot is NaN where the epoch lacks it."""

    def _check_values(self) -> None:
        s = self.z.reshape(len(self.z), SLOTS, len(FIELDS))
        have = np.isfinite(s[:, :, PRN])
        bad = have & ~np.isfinite(s[:, :, SX:RR]).all(axis=2) if len(s) else have
        if len(s) and (~have.any(axis=1)).any():
            raise ValueError(f"gnss_raw: the epoch at t = {self.t[np.argmin(have.any(1))]} s "
                             f"has no satellite")
        if bad.any():
            raise ValueError(f"gnss_raw: a satellite's position, velocity or pseudorange is "
                             f"NaN at t = {self.t[np.argmax(bad.any(axis=1))]} s")


@dataclass(frozen=True)
class RawReceiver:
    """A receiver tracking a constellation (:func:`walker`'s, ``constellation`` = planes,
    satellites per plane, phasing, ``epoch_deg``, as broadcast ephemerides:
    :meth:`sky`) from GPS time ``start_gps_s`` [s] (the simulation's zero): every
    ``period`` [s] the pseudorange and range rate of each satellite above ``mask`` [rad]
    (at most :data:`SLOTS`, the highest) as the light reaches it (:func:`light_time`:
    the satellite where it transmitted, turned by the Earth's rotation during the
    transit), with white noise of zenith 1-sigma ``sigma_pr`` [m],
    ``sigma_rr`` [m/s] scaled by elevation (:func:`elevation_sigma`), a multipath-like
    first-order Gauss–Markov error per satellite (``multipath`` [m], ``multipath_tau``
    [s]; 0: none), and the receiver clock (:func:`clock_walk`; ``clock`` = h0, h_-2,
    initial bias [m], drift [m/s]).  ``limits`` = ((start, end, n), ...): within
    ``[start, end)`` only the ``n`` highest satellites (jamming, masking; 0: none)."""

    period: float
    sigma_pr: float
    sigma_rr: float
    mask: float
    clock: tuple
    constellation: tuple = (6, 5, 1, 0.0)
    multipath: float = 0.0
    multipath_tau: float = 60.0
    limits: tuple = ()
    start_gps_s: float = START_GPS_S
    navigation: str | None = None

    def sky(self, end: float) -> Ephemerides:
        """The sky's broadcast ephemerides over the simulation's ``[0, end]`` [s]: the
        ``navigation`` file's (a real sky: :func:`~fednav.sensors.satellites.
        read_navigation`), else the constellation's (:func:`walker_ephemerides`)."""
        if self.navigation is not None:
            return read_navigation(self.navigation)
        return walker_ephemerides(self.start_gps_s, self.start_gps_s + end,
                                  *self.constellation)

    def simulate(self, truth, rng: np.random.Generator, t=None,
                 t_avail=None) -> MeasurementSeries:
        t = flight_times(truth, self.period, t)
        tr = truth.at(t)
        lla, vel = tr["lla"], tr["vel"]
        r = earth.llh_to_ecef(lla[:, 0], lla[:, 1], lla[:, 2])
        v = np.einsum("nij,nj->ni", earth.enu_to_ecef(lla[:, 0], lla[:, 1]), vel)
        sv, pos, svel, _, _, rho = light_time(
            self.sky(float(t[-1]) if len(t) else 0.0), t + self.start_gps_s, r)
        prn = np.array([int(x[1:]) for x in sv], dtype=float)
        u = (pos - r[:, None, :]) / rho[..., None]
        with np.errstate(invalid="ignore"):
            _, el = azimuth_elevation(lla[:, None, :], r[:, None, :], pos)
        rhod = np.einsum("nsi,nsi->ns", u, svel - v[:, None, :])
        h0, hm2, b0, d0 = self.clock
        clk = clock_walk(t, h0, hm2, b0, d0, rng)
        S = pos.shape[1]
        spr, srr = elevation_sigma(self.sigma_pr, el), elevation_sigma(self.sigma_rr, el)
        e_pr = rng.standard_normal(rho.shape) * spr
        e_rr = rng.standard_normal(rho.shape) * srr
        if self.multipath > 0.0:
            mp = np.empty_like(rho)
            mp[0] = rng.standard_normal(S) * self.multipath
            a = np.exp(-np.diff(t, prepend=t[0]) / self.multipath_tau)
            for i in range(1, len(t)):
                mp[i] = a[i] * mp[i - 1] + np.sqrt(1 - a[i] ** 2) * self.multipath * \
                    rng.standard_normal(S)
            e_pr = e_pr + mp
        pr = rho + clk[:, :1] + e_pr
        rr = rhod + clk[:, 1:] + e_rr
        z = np.full((len(t), WIDTH), np.nan)
        for i in range(len(t)):
            with np.errstate(invalid="ignore"):
                seen = np.flatnonzero(el[i] >= self.mask)
            n = SLOTS
            for a, b, k in self.limits:
                if a <= t[i] < b:
                    n = min(n, int(k))
            seen = seen[np.argsort(-el[i, seen])][:n]
            seen.sort()
            rows = np.column_stack([prn[seen], pos[i, seen], svel[i, seen], pr[i, seen],
                                    rr[i, seen], spr[i, seen], srr[i, seen]])
            z[i] = pack(rows)
        keep = np.isfinite(z[:, PRN])  # (an epoch without satellites is no measurement)
        return SatelliteSeries("gnss_raw", t[keep], z[keep],
                                 np.array([self.sigma_pr, self.sigma_rr]),
                                 None if t_avail is None else t_avail[keep])


class GnssRawConfig(SensorConfig):
    """Raw GNSS (module docstring): ``sigma_pseudorange_m``, ``sigma_range_rate_mps``
    (zenith 1-sigma, for satellites whose data give none; scaled by elevation),
    ``elevation_mask_deg``, the receiver ``clock`` (``tcxo``, ``ocxo`` or ``[h0, h_-2]``,
    its Allan-variance coefficients: the clock states' process noise), the clock's initial
    1-sigma ``clock_bias_sigma_m``, ``clock_drift_sigma_mps`` (what is left after the
    first epoch's jump test has moved the totals to within :data:`CLOCK_JUMP_M` and
    :data:`CLOCK_DRIFT_JUMP_MPS` of the median residuals: 10 km and 100 m/s cover that
    tenfold and twofold; 300 km, a millisecond, made the unscented update lose
    definiteness on the first epoch), ``time_offset_s`` added to
    a file's time stamps (a receiver's files are in GPS time [s]: minus the GPS time of
    the IMU clock's zero).  Simulation only: the ``constellation`` (Walker planes,
    satellites per plane, phasing, ``epoch_deg``) or a ``navigation_file`` (RINEX, its
    path relative to the description's folder: its broadcast ephemerides are the sky, so
    its geometry and DOP are real), ``start_gps_s`` the GPS time of the simulation's zero
    (default: 2026-01-04 for the Walker sky, the file's first ephemeris epoch),
    ``multipath_sigma_m`` and ``multipath_tau_s``, the initial clock ``clock_bias_m`` and
    ``clock_drift_mps``, and ``satellites_s`` — windows ``[start_s, end_s, n]`` with only
    the ``n`` highest satellites (jamming, an urban canyon; 0: none)."""

    KIND: ClassVar[str] = "gnss_raw"

    sigma_pseudorange_m: float = Field(default=3.0, gt=0.0)
    sigma_range_rate_mps: float = Field(default=0.1, gt=0.0)
    elevation_mask_deg: float = Field(default=10.0, ge=0.0, lt=90.0)
    clock: Literal["tcxo", "ocxo"] | tuple[float, float] = "tcxo"
    clock_bias_sigma_m: float = Field(default=1.0e4, gt=0.0)
    clock_drift_sigma_mps: float = Field(default=100.0, gt=0.0)
    time_offset_s: float = 0.0
    start_gps_s: float | None = Field(default=None, ge=0.0, json_schema_extra=simulation_only(
        "the simulated sky's time"))
    navigation_file: str | None = Field(default=None, json_schema_extra=simulation_only(
        "a simulated sky"))
    constellation: tuple[int, int, int, float] = Field(
        default=(6, 5, 1, 0.0), json_schema_extra=simulation_only("a simulated sky"))
    multipath_sigma_m: float = Field(default=0.0, ge=0.0,
                                     json_schema_extra=simulation_only("simulated error"))
    multipath_tau_s: float = Field(default=60.0, gt=0.0,
                                   json_schema_extra=simulation_only("simulated error"))
    clock_bias_m: float = Field(default=1.0e4, json_schema_extra=simulation_only(
        "the simulated clock's start"))
    clock_drift_mps: float = Field(default=5.0, json_schema_extra=simulation_only(
        "the simulated clock's start"))
    satellites_s: list[tuple[float, float, int]] = Field(
        default=[], json_schema_extra=simulation_only("simulated loss of satellites"))

    @field_validator("clock")
    @classmethod
    def _clock(cls, v):
        if not isinstance(v, str) and (v[0] < 0.0 or v[1] < 0.0):
            raise ValueError(f"the clock's [h0, h_-2] are non-negative, got {list(v)}")
        return v

    @field_validator("navigation_file")
    @classmethod
    def _navigation(cls, v, info: ValidationInfo):
        if v is None:
            return v
        p = Path(v)  # (read when a simulation flies it: a processed copy needs it not)
        if not p.is_absolute() and info.context and info.context.get("folder"):
            p = info.context["folder"] / p
        return str(p.resolve())

    @field_validator("timing")
    @classmethod
    def _timing(cls, v):
        if v.delay_compensation == "curve_fit":
            raise ValueError("delay_compensation: curve_fit extrapolates a measurement's "
                             "values, and a raw GNSS epoch's satellites differ from one "
                             "epoch to the next; use interpolate, ins_increment or "
                             "recompute")
        return v

    @field_validator("satellites_s")
    @classmethod
    def _limits(cls, v):
        for a, b, n in v:
            if not b > a or n < 0:
                raise ValueError(f"a window [start_s, end_s, n] ends after it starts and "
                                 f"keeps n >= 0 satellites, got [{a}, {b}, {n}]")
        return v

    def h_coefficients(self) -> tuple[float, float]:
        """The clock's (h0, h_-2)."""
        return CLOCKS[self.clock] if isinstance(self.clock, str) else tuple(self.clock)

    def block_figures(self) -> tuple:
        """The ``clock`` block's (1-sigma, tau, qc) (:meth:`fednav.ins.states.StateLayout.
        of`): the initial 1-sigma, a random walk, the densities ``S_f``, ``S_g``."""
        h0, hm2 = self.h_coefficients()
        return ((self.clock_bias_sigma_m, self.clock_drift_sigma_mps), np.inf,
                (h0 / 2 * LIGHT**2, 2 * np.pi**2 * hm2 * LIGHT**2))

    def sensor(self) -> RawReceiver:
        h0, hm2 = self.h_coefficients()
        return RawReceiver(self.period_s, self.sigma_pseudorange_m, self.sigma_range_rate_mps,
                           float(units.deg(self.elevation_mask_deg)),
                           (h0, hm2, self.clock_bias_m, self.clock_drift_mps),
                           tuple(self.constellation), self.multipath_sigma_m,
                           self.multipath_tau_s, tuple(tuple(w) for w in self.satellites_s),
                           self.start_s(), self.navigation_file)

    def start_s(self) -> float:
        """GPS time of the simulation's zero [s]: ``start_gps_s``, else the navigation
        file's first healthy ephemeris epoch (whole seconds), else :data:`START_GPS_S`."""
        if self.start_gps_s is not None:
            return float(self.start_gps_s)
        if self.navigation_file is None:
            return START_GPS_S
        eph = read_navigation(self.navigation_file)
        return float(np.ceil(np.min(eph.toe[eph.health == 0])))

    def model(self) -> SatelliteRanges:
        return SatelliteRanges(self.sigma_pseudorange_m, self.sigma_range_rate_mps,
                               float(units.deg(self.elevation_mask_deg)))

    def sigma(self) -> np.ndarray:
        """Zenith 1-sigma of a pseudorange [m] and a range rate [m/s] (each satellite's
        own, from its slot or its elevation, is what the rows take)."""
        return np.array([self.sigma_pseudorange_m, self.sigma_range_rate_mps])


SPEC = SensorSpec(
    "gnss_raw", "GNSS pseudorange and Doppler of each satellite (tightly coupled; receiver "
                "clock states)", GnssRawConfig, SatelliteRanges,
    columns=tuple(Column(f"s{k:02d}_{f}") for k in range(SLOTS) for f in FIELDS),
    label="raw GNSS", sparse=True, valid=has_satellite, report=report, figure=figure,
    start=single_point_fixes,
    files_doc="a u-blox .ubx raw log (RXM-RAWX, RXM-SFRBX), a RINEX observation file with "
              "its navigation file beside it (GPS time [s] since 1980-01-06)",
    columns_doc=f"{SLOTS} satellite slots `sNN_`: " + ", ".join(f"`{f}`" for f in FIELDS))

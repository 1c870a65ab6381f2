"""GPS satellites from broadcast ephemerides, the signal's path, and single-point
positioning — the models of raw GNSS pseudoranges (IS-GPS-200, RTKLIB's conventions).

* :func:`satellite_states`: ECEF position [m] and velocity [m/s] and clock offset [s]
  and drift [s/s] of each satellite at its transmit time (IS-GPS-200 table 20-IV:
  Kepler's equation, the harmonic corrections, the relativistic clock term
  ``F e sqrt(A) sin E``; the group delay ``TGD`` for an L1-only user).
* :func:`klobuchar` (L1 ionospheric delay from the broadcast alpha/beta [m]) and
  :func:`saastamoinen` (tropospheric delay: Saastamoinen's zenith delays of a standard
  atmosphere mapped by ``1 / cos z`` [m]).
* :func:`single_point`: each epoch's receiver position [m, ECEF], clock bias [m] and DOP
  by iterated weighted least squares over the satellites above the elevation mask —
  every epoch at once (the epochs' normal equations solved together) — with the signal
  transit time and the Earth's rotation during it (Sagnac).

Inputs are numpy arrays (epochs N, satellites M); a satellite missing at an epoch is NaN
and drops out of that epoch's solution.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ..core import earth

#: Speed of light [m/s] (IS-GPS-200).
C = 299792458.0
#: WGS-84 Earth gravitational constant [m^3/s^2] and rotation rate [rad/s] (IS-GPS-200).
GM = 3.986005e14
OMEGA_E = 7.2921151467e-5
#: Relativistic clock constant F [s/m^0.5].
F_REL = -4.442807633e-10
#: GPS L1 and L2 frequencies [Hz].
F_L1, F_L2 = 1575.42e6, 1227.60e6
#: Seconds in a GPS week.
WEEK_S = 604800.0


@dataclass
class Ephemerides:
    """GPS broadcast ephemerides, one row per record: ``sv`` (K,), the clock epoch
    ``toc`` and the ephemeris epoch ``toe`` in GPS time [s], the clock terms ``af0``
    [s], ``af1`` [s/s], ``af2`` [s/s^2], ``tgd`` [s], ``health``, and the orbit's
    ``sqrt_a`` [m^0.5], ``e``, ``i0``, ``omega0``, ``omega``, ``m0`` [rad], ``delta_n``,
    ``omega_dot``, ``idot`` [rad/s], ``cuc``, ``cus``, ``cic``, ``cis`` [rad], ``crc``,
    ``crs`` [m]; ``iono`` (8,) the Klobuchar alpha and beta of the header (None if
    absent)."""

    source: str
    sv: np.ndarray
    toc: np.ndarray
    toe: np.ndarray
    elements: dict[str, np.ndarray]
    iono: np.ndarray | None = None

    def __getattr__(self, name: str) -> np.ndarray:
        try:
            return self.__dict__["elements"][name]
        except KeyError:
            raise AttributeError(name) from None


#: The reader of broadcast navigation files (``path -> Ephemerides``): set by
#: :mod:`fednav.io.rinex` when it is imported (the file layer sits above the models;
#: the simulation imports it), for :func:`read_navigation`.
NAVIGATION_READER = None


@functools.lru_cache(maxsize=8)
def read_navigation(path: str) -> Ephemerides:
    """The broadcast ephemerides of the navigation file ``path`` (RINEX), read once per
    process by :data:`NAVIGATION_READER`."""
    if NAVIGATION_READER is None:
        raise ValueError(f"{path}: no reader of navigation files is loaded (fednav.io "
                         f"registers RINEX's when imported)")
    return NAVIGATION_READER(path)


def nearest_ephemeris(eph, sv, t) -> np.ndarray:
    """Index of the record of each satellite ``sv`` (M,) nearest each time ``t`` (N,)
    [GPS s] among the healthy ones within 2 h of their ``toe`` (N, M; -1 where none)."""
    out = np.full((len(t), len(sv)), -1, dtype=np.int64)
    for j, s in enumerate(sv):  # (per satellite: a few records each)
        rows = np.flatnonzero((eph.sv == s) & (eph.health == 0))
        if not len(rows):
            continue
        d = np.abs(t[:, None] - eph.toe[rows][None, :])
        k = np.argmin(d, axis=1)
        out[:, j] = np.where(d[np.arange(len(t)), k] <= 7200.0, rows[k], -1)
    return out


def _kepler(M, e, iterations: int = 10):
    E = M.copy()
    for _ in range(iterations):
        E = M + e * np.sin(E)
    return E


def _orbit(g, toe, tk):
    """ECEF position [m] and eccentric anomaly [rad] of the elements ``g`` (a record
    per element) ``tk`` [s] after their ``toe`` [GPS s] (IS-GPS-200 table 20-IV)."""
    A = g["sqrt_a"] ** 2
    n = np.sqrt(GM / A**3) + g["delta_n"]
    e = g["e"]
    E = _kepler(g["m0"] + n * tk, e)
    sE, cE = np.sin(E), np.cos(E)
    phi = np.arctan2(np.sqrt(1.0 - e**2) * sE, cE - e) + g["omega"]
    s2, c2 = np.sin(2 * phi), np.cos(2 * phi)
    u = phi + g["cus"] * s2 + g["cuc"] * c2
    r = A * (1.0 - e * cE) + g["crs"] * s2 + g["crc"] * c2
    inc = g["i0"] + g["idot"] * tk + g["cis"] * s2 + g["cic"] * c2
    Om = g["omega0"] + (g["omega_dot"] - OMEGA_E) * tk - OMEGA_E * np.mod(toe, WEEK_S)
    x, y = r * np.cos(u), r * np.sin(u)
    cO, sO, ci, si = np.cos(Om), np.sin(Om), np.cos(inc), np.sin(inc)
    return np.stack([x * cO - y * ci * sO, x * sO + y * ci * cO, y * si], axis=-1), E


def satellite_states(eph, idx, t_tx, l1_only: bool = True):
    """Satellite position and velocity (ECEF at the transmit time, m and m/s), clock
    offset [s] and drift [s/s] for the records ``idx`` (any shape; -1: NaN) at GPS
    times ``t_tx`` [s] (same shape).  The clock offset includes the relativistic term
    and, for ``l1_only`` (an L1 pseudorange), minus ``TGD``; velocity and drift are the
    central differences over 1 s."""
    idx = np.asarray(idx)
    ok = idx >= 0
    i = np.where(ok, idx, 0)
    g = {k: v[i] for k, v in eph.elements.items()}
    toe, toc = eph.toe[i], eph.toc[i]

    def at(t):
        pos, E = _orbit(g, toe, t - toe)
        dt = t - toc
        clock = (g["af0"] + g["af1"] * dt + g["af2"] * dt**2
                 + F_REL * g["e"] * g["sqrt_a"] * np.sin(E)
                 - (g["tgd"] if l1_only else 0.0))
        return pos, clock

    pos, clock = at(t_tx)
    (p1, c1), (p0, c0) = at(t_tx + 0.5), at(t_tx - 0.5)
    vel, drift = p1 - p0, c1 - c0
    for a in (pos, vel):
        a[~ok] = np.nan
    return pos, vel, np.where(ok, clock, np.nan), np.where(ok, drift, np.nan)


def earth_turned(a, tau):
    """ECEF vectors ``a`` (..., 3) of the frame at a signal's transmission in the frame at
    its reception ``tau`` [s] later (...,): turned by the Earth's rotation ``OMEGA_E tau``
    about z (the Sagnac correction)."""
    c, s = np.cos(OMEGA_E * tau), np.sin(OMEGA_E * tau)
    return np.stack([c * a[..., 0] + s * a[..., 1], -s * a[..., 0] + c * a[..., 1],
                     a[..., 2]], axis=-1)


def epoch_least_squares(H, w, y, enough):
    """Weighted least squares of every epoch at once: rows ``H`` (N, M, k), weights ``w``
    (N, M) (0: no row), residuals ``y`` (N, M); the epochs ``enough`` (N,) solved.
    Returns the corrections (N, k) (zero where not solved) and the normal matrices
    (N, k, k) (their inverses: the solutions' covariances)."""
    Hw = H * w[..., None]
    A = np.einsum("nmi,nmj->nij", Hw, H) + 1e-9 * np.eye(H.shape[-1])
    b = np.einsum("nmi,nm->ni", Hw, y)
    dx = np.zeros(b.shape)
    dx[enough] = np.linalg.solve(A[enough], b[enough][..., None])[..., 0]
    return dx, A


def azimuth_elevation(rx_lla, rx_xyz, sat_xyz):
    """Azimuth (from north, clockwise) and elevation [rad] of satellites ``sat_xyz``
    (..., 3) seen from a receiver at ``rx_xyz`` (..., 3) ECEF [m], ``rx_lla`` its
    latitude and longitude [rad] (..., 2 or 3)."""
    d = sat_xyz - rx_xyz
    lat, lon = rx_lla[..., 0], rx_lla[..., 1]
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    east = -so * d[..., 0] + co * d[..., 1]
    north = -sl * co * d[..., 0] - sl * so * d[..., 1] + cl * d[..., 2]
    up = cl * co * d[..., 0] + cl * so * d[..., 1] + sl * d[..., 2]
    return np.arctan2(east, north), np.arctan2(up, np.hypot(east, north))


def klobuchar(iono, lat, lon, az, el, tow):
    """The Klobuchar model's L1 ionospheric delay [m] (IS-GPS-200 20.3.3.5.2.5) from the
    broadcast ``iono`` = alpha0..3, beta0..3, at the receiver's ``lat``, ``lon`` [rad],
    the satellite's ``az``, ``el`` [rad] and the GPS time of week ``tow`` [s]."""
    a, b = np.asarray(iono[:4]), np.asarray(iono[4:])
    E = el / np.pi  # semicircles
    psi = 0.0137 / (E + 0.11) - 0.022
    phi_i = np.clip(lat / np.pi + psi * np.cos(az), -0.416, 0.416)
    lam_i = lon / np.pi + psi * np.sin(az) / np.cos(phi_i * np.pi)
    phi_m = phi_i + 0.064 * np.cos((lam_i - 1.617) * np.pi)
    t = np.mod(4.32e4 * lam_i + tow, 86400.0)
    amp = np.maximum(a[0] + phi_m * (a[1] + phi_m * (a[2] + phi_m * a[3])), 0.0)
    per = np.maximum(b[0] + phi_m * (b[1] + phi_m * (b[2] + phi_m * b[3])), 72000.0)
    x = 2.0 * np.pi * (t - 50400.0) / per
    f = 1.0 + 16.0 * (0.53 - E) ** 3
    delay = np.where(np.abs(x) < 1.57, 5e-9 + amp * (1.0 - x**2 / 2.0 + x**4 / 24.0), 5e-9)
    return C * f * delay


def saastamoinen(lat, h, el, humidity: float = 0.7):
    """Tropospheric delay [m]: Saastamoinen's hydrostatic and wet zenith delays of a
    standard atmosphere (1013.25 hPa, 15 °C at sea level, ``humidity``) at the
    receiver's latitude ``lat`` [rad] and height ``h`` [m], mapped by ``1 / cos z``
    (zenith angle ``z = pi/2 - el``)."""
    hh = np.clip(h, 0.0, 1e4)
    p = 1013.25 * (1.0 - 2.2557e-5 * hh) ** 5.2568
    T = 15.0 - 6.5e-3 * hh + 273.16
    e = 6.108 * humidity * np.exp((17.15 * T - 4684.0) / (T - 38.45))
    z = np.pi / 2.0 - np.maximum(el, np.radians(1.0))
    zhd = 0.0022768 * p / (1.0 - 0.00266 * np.cos(2.0 * lat) - 0.00028 * hh / 1e3)
    zwd = 0.002277 * (1255.0 / T + 0.05) * e
    return (zhd + zwd) / np.cos(z)


def iono_free(p1, p2):
    """The ionosphere-free combination of L1 and L2 pseudoranges [m]."""
    g = (F_L1 / F_L2) ** 2
    return (g * p1 - p2) / (g - 1.0)


@dataclass
class SinglePoint:
    """Single-point solutions, one row per epoch: ``t`` (N,) GPS time [s], ``xyz``
    (N, 3) ECEF [m], ``lla`` (N, 3) [rad, rad, m], ``clock_m`` (N,) the receiver clock
    bias [m], ``dop`` (N, 4) GDOP, PDOP, HDOP, VDOP, ``used`` (N,) satellites used,
    ``residuals`` (N, M) the post-fit pseudorange residuals [m] (NaN: not used)."""

    t: np.ndarray
    xyz: np.ndarray
    lla: np.ndarray
    clock_m: np.ndarray
    dop: np.ndarray
    used: np.ndarray
    residuals: np.ndarray


def dilution(G) -> np.ndarray:
    """GDOP, PDOP, HDOP, VDOP (N, 4) of geometry rows ``G`` (N, M, 4): per satellite the
    line of sight's east, north, up components (any sign) and 1 for the receiver clock,
    zero rows for satellites not used; NaN with fewer than four."""
    G = np.asarray(G, dtype=float)
    out = np.full((G.shape[0], 4), np.nan)
    four = (np.abs(G).sum(axis=2) > 0).sum(axis=1) >= 4
    if four.any():
        q = np.diagonal(np.linalg.inv(np.einsum("nmi,nmj->nij", G[four], G[four])),
                        axis1=1, axis2=2)
        out[four] = np.sqrt(np.column_stack([q.sum(1), q[:, :3].sum(1), q[:, :2].sum(1),
                                             q[:, 2]]))
    return out


def single_point(t, pr, sv, eph, *, l1_only: bool = True, iono: bool = True,
                 tropo: bool = True, mask_deg: float = 10.0, x0=None,
                 iterations: int = 10) -> SinglePoint:
    """Single-point positioning of every epoch at once.

    Parameters
    ----------
    t : ndarray (N,)
        Receive times, GPS time [s].
    pr : ndarray (N, M)
        Pseudoranges [m] of satellites ``sv`` (NaN: not observed): L1 code for
        ``l1_only`` (Klobuchar ionosphere and ``TGD`` applied when ``iono``), else the
        ionosphere-free combination (:func:`iono_free`).
    sv : ndarray (M,)
        Satellite ids as in ``eph.sv``.
    eph : Ephemerides
        Broadcast ephemerides (:func:`fednav.io.rinex.read_rinex_nav`).
    tropo : bool
        Apply :func:`saastamoinen`.
    mask_deg : float
        Elevation mask [deg] (applied from the second iteration, once a position is
        known).
    x0 : ndarray (3,), optional
        Starting position ECEF [m] (default: the Earth's centre).

    Returns
    -------
    SinglePoint
        The solutions; an epoch with fewer than four satellites is NaN.
    """
    t = np.asarray(t, dtype=float)
    pr = np.asarray(pr, dtype=float)
    N, M = pr.shape
    idx = nearest_ephemeris(eph, np.asarray(sv), t)
    x = np.zeros((N, 4))
    if x0 is not None:
        x[:, :3] = np.asarray(x0, dtype=float)
    have = np.isfinite(pr) & (idx >= 0)
    w = np.where(have, 1.0, 0.0)
    for it in range(iterations):
        tau = np.where(have, pr, 0.0) / C
        t_tx = t[:, None] - tau
        _, _, clk, _ = satellite_states(eph, idx, t_tx, l1_only)
        t_tx = t_tx - np.nan_to_num(clk)
        pos, _, clk, _ = satellite_states(eph, idx, t_tx, l1_only)
        rx = x[:, None, :3]
        # (the Earth turns while the signal travels: Sagnac)
        rot = earth_turned(pos, np.linalg.norm(pos - rx, axis=-1) / C)
        los = rot - rx
        rho = np.linalg.norm(los, axis=-1)
        lla = earth.ecef_to_llh(x[:, :3]) if it else np.zeros((N, 3))
        az, el = azimuth_elevation(lla[:, None, :], rx, rot)
        model = rho + x[:, None, 3] - C * clk
        if it:
            if l1_only and iono and eph.iono is not None:
                model = model + klobuchar(eph.iono, lla[:, None, 0], lla[:, None, 1], az, el,
                                          np.mod(t[:, None], WEEK_S))
            if tropo:
                model = model + saastamoinen(lla[:, None, 0], lla[:, None, 2], el)
            w = np.where(have & (el >= np.radians(mask_deg)), np.sin(el) ** 2, 0.0)
        w = np.where(np.isfinite(model), w, 0.0)
        H = np.concatenate([-los / np.where(rho > 0, rho, 1.0)[..., None],
                            np.ones((N, M, 1))], axis=-1)
        # (a satellite without a usable ephemeris is NaN: zero rows, not NaN, in the sums)
        H = np.where((w > 0)[..., None], H, 0.0)
        v = np.where(w > 0, pr - model, 0.0)
        enough = (w > 0).sum(axis=1) >= 4
        dx, _ = epoch_least_squares(H, w, v, enough)
        x = x + dx
        if it and np.all(np.abs(dx[enough, :3]) < 1e-4):
            break
    used = (w > 0).sum(axis=1)
    lla = earth.ecef_to_llh(x[:, :3])
    # the geometry rows in the local frame (east, north, up, clock) for the DOP
    G = H * (w > 0)[..., None]
    G[..., :3] = np.einsum("nmi,nij->nmj", G[..., :3], earth.enu_to_ecef(lla[:, 0],
                                                                         lla[:, 1]))
    dop = dilution(G)
    dop[~enough] = np.nan
    bad = ~enough
    x[bad] = np.nan
    lla[bad] = np.nan
    res = np.where(w > 0, v - np.einsum("nmi,ni->nm", H, dx), np.nan)
    return SinglePoint(t, x[:, :3], lla, x[:, 3], dop, used, res)


__all__ = ["C", "F_L1", "F_L2", "SinglePoint", "azimuth_elevation", "dilution", "iono_free",
           "klobuchar",
           "nearest_ephemeris", "saastamoinen", "satellite_states", "single_point"]

"""A solution against a reference: its error series (:func:`errors_against`, the
solution moved to the reference's point and time) and their RMSE (:func:`rmse`)."""

from __future__ import annotations

import warnings as _warnings

import numpy as np

from ..core import attitude as att
from ..core import earth, units
from ..io.data import DataError, Reference
from ..navigator.solution import Solution

#: Error keys of earlier releases (north, east, down) -> their key now (east, north, up).
RENAMED_ERRORS = {"down_m": "up_m", "vd_mps": "vu_mps"}


class _Errors(dict):
    """Error series (``signed``) or their RMSE by key; the keys of
    :data:`RENAMED_ERRORS` are read, as minus the new series (or the same RMSE), with a
    ``FutureWarning`` for one more release."""

    def __init__(self, *args, signed: bool = True):
        super().__init__(*args)
        self.signed = signed

    def __missing__(self, key):
        new = RENAMED_ERRORS.get(key)
        if new is None or new not in self:
            raise KeyError(key)
        _warnings.warn(f"error key '{key}' is now '{new}' (errors are east, north, up, as the "
                       f"solution): read as {'-' if self.signed else ''}{new} for one more "
                       f"release", FutureWarning, stacklevel=2)
        return -self[new] if self.signed else self[new]

    def get(self, key, default=None):
        """``self[key]`` (an old key too, with its warning), else ``default``."""
        try:
            return self[key]
        except KeyError:
            return default

    def __contains__(self, key):
        return super().__contains__(key) or (key in RENAMED_ERRORS
                                             and super().__contains__(RENAMED_ERRORS[key]))


def errors_against(sol: Solution, ref: Reference) -> dict[str, np.ndarray]:
    """The solution's errors: solution minus reference at the reference's times inside
    the solution's span.

    The solution is moved to the point the reference describes (its lever arm) and
    interpolated to the reference's times (attitude through quaternions, longitude
    across +-180 deg unwrapped) before differencing.

    Parameters
    ----------
    sol : Solution
        A solution (``ProcessResult.forward``, ``NavResult.forward``; lat/lon [rad], h
        [m], ENU velocity [m/s], Euler angles [rad]).
    ref : Reference
        The reference (:func:`fednav.read_reference_csv`; lat/lon [rad], h [m], ENU
        velocity [m/s], optional Euler angles [rad]).

    Returns
    -------
    dict of str to ndarray
        ``t`` [s]; position errors ``east_m``, ``north_m``, ``up_m`` [m]; velocity
        errors ``ve_mps``, ``vn_mps``, ``vu_mps`` [m/s] (ENU, as the solution); with a
        reference attitude ``pitch_rad``, ``roll_rad``, ``yaw_rad`` [rad] (the Euler
        angles' order).  The old keys ``down_m`` and ``vd_mps`` are read (as minus
        ``up_m``, ``vu_mps``) with a ``FutureWarning`` for one more release.

    Raises
    ------
    DataError
        When the reference does not overlap the solution or lies over 10 km away.
    """
    # (the solution's time stamps t0 + k dt may end a few ulp before a reference stamp)
    tol = 1e-6 * float(sol.t[1] - sol.t[0]) if len(sol.t) > 1 else 0.0
    m = (ref.t >= sol.t[0] - tol) & (ref.t <= sol.t[-1] + tol)
    if not m.any():
        raise DataError(f"{ref.source}: reference does not overlap the solution in time")
    tr = ref.t[m]
    interp = lambda a: np.column_stack([np.interp(tr, sol.t, a[:, j])  # noqa: E731
                                        for j in range(a.shape[1])])
    lla, vel = sol.lla, sol.vel
    if np.any(ref.lever):
        lla, vel = earth.lever_arm_point(lla, vel, att.euler_to_dcm(sol.euler), sol.omega,
                                         ref.lever)
    # longitude unwrapped before interpolating: a span across +-180 deg is not 2 pi wide
    lla = interp(np.column_stack([lla[:, 0], np.unwrap(lla[:, 1]), lla[:, 2]]))
    lla[:, 1] = earth.wrap_lon_array(lla[:, 1])
    vel = interp(vel)
    rl = ref.lla[m]
    d = earth.llh_difference_enu(lla[:, 0], lla[:, 1], lla[:, 2], rl[:, 0], rl[:, 1], rl[:, 2])
    dv = vel - ref.vel[m]
    far = float(np.median(np.hypot(d[:, 0], d[:, 1])))
    if far > 10_000.0:
        raise DataError(f"{ref.source}: the solution and the reference are {far / 1000:.0f} "
                        f"km apart (median): reference or GNSS positions in another unit "
                        f"(radians vs degrees) or datum?")
    out = _Errors({"t": tr, "east_m": d[:, 0], "north_m": d[:, 1], "up_m": d[:, 2],
                   "ve_mps": dv[:, 0], "vn_mps": dv[:, 1], "vu_mps": dv[:, 2]})
    if ref.euler is not None:
        # Interpolate attitude through unit quaternions (no heading wrap problems).
        q = att.euler_to_quat(sol.euler)
        flip = np.r_[1.0, np.sign(np.sum(q[1:] * q[:-1], axis=1))]
        q = q * np.cumprod(np.where(flip == 0, 1.0, flip))[:, None]  # continuous sign
        qi = interp(q)
        qi /= np.linalg.norm(qi, axis=1)[:, None]
        de = att.euler_difference(att.quat_to_euler(qi), ref.euler[m])
        out.update({"pitch_rad": de[:, 0], "roll_rad": de[:, 1], "yaw_rad": de[:, 2]})
    return out


def rmse(err: dict[str, np.ndarray]) -> dict[str, float]:
    """Root-mean-square of each error series.

    Parameters
    ----------
    err : dict of str to ndarray
        Error series by name (:func:`errors_against`'s), each in the unit its name says
        [m, m/s, rad]; a ``t`` entry is left out.

    Returns
    -------
    dict of str to float
        The RMSE of each series in its unit [m, m/s]; angles (``*_rad``) in degrees under
        ``*_deg`` [deg].  The old keys ``down_m`` and ``vd_mps`` are read (the same as
        ``up_m``, ``vu_mps``) with a ``FutureWarning`` for one more release.
    """
    out = _Errors(signed=False)
    for k, v in err.items():
        if k == "t":
            continue
        r = float(np.sqrt(np.mean(v**2)))
        if k.endswith("_rad"):
            out[k[:-4] + "_deg"] = float(units.to_deg(r))
        else:
            out[k] = r
    return out

"""GNSS receiver: position (latitude, longitude, height) and ENU velocity fixes.

Section ``sensors.gnss``: ``sigma_pos_enu_m`` (one value or [east, north, up]),
``sigma_vel_mps`` (one value or [east, north, up]), ``lever_m`` (antenna from the IMU,
body right-forward-up), ``time_offset_s`` (added to the file's time stamps), ``period_s``.
The old key ``sigma_pos_m`` ([north, east, up]) is read, reordered, with a
``FutureWarning`` for one more release (:func:`renamed_neu_keys`).
File columns: ``t_s, lat_deg, lon_deg, h_m, vE_mps, vN_mps, vU_mps``
(:func:`fednav.io.read_gnss_csv`).  Residual: INS-derived antenna - GNSS,
``[dE, dN, dU] m, [dvE, dvN, dvU] m/s`` (linear in the error state).
"""

from __future__ import annotations

import dataclasses
import functools
import warnings
from dataclasses import dataclass
from typing import ClassVar, Literal

import numpy as np
from pydantic import Field, model_validator

from ..core import earth
from ..core.errors import DataError
from ..ins.strapdown import STATE_VEL
from ..ins.total_state import N_BIAS, TSCALE
from .base import MeasurementSeries, flight_times, position_noise_to_llh
from .measurement import POS_E, POS_N, POS_U, VEL_E, VEL_N, VEL_U, RowModel
from .spec import Column, SensorConfig, SensorSpec

_V3 = tuple[float, float, float]

#: Old keys holding a [north, east, up] vector -> their new [east, north, up] key.
NEU_KEYS = {"sigma_pos_m": "sigma_pos_enu_m"}


def neu_to_enu(v):
    """A [north, east, up] vector (list, tuple or array of 3) as [east, north, up]; a
    single value (or anything else, left for validation to report) unchanged."""
    if isinstance(v, np.ndarray) and v.shape == (3,):
        return v[[1, 0, 2]]
    if isinstance(v, list | tuple) and len(v) == 3:
        return type(v)((v[1], v[0], v[2]))
    return v


def renamed_neu_keys(data, where: str, renamed: dict[str, str] = NEU_KEYS):
    """``data`` (a section's mapping) with the old [north, east, up] keys
    (``renamed``: old -> new) moved to their [east, north, up] keys, the values
    reordered (:func:`neu_to_enu`), with one ``FutureWarning`` naming the old key, the
    new key and the order change; ``where``: the section's place (``sensors.gnss``).

    Raises
    ------
    ValueError
        When the old and the new key are both given.
    """
    if not isinstance(data, dict) or not any(k in data for k in renamed):
        return data
    out = dict(data)
    for old, new in renamed.items():
        if old not in out:
            continue
        if new in out:
            raise ValueError(f"'{old}' ([north, east, up]) and '{new}' ([east, north, up]) "
                             f"are the same setting; give {new} only")
        warnings.warn(f"{where}.{old} [north, east, up] is now {where}.{new} [east, north, "
                      f"up]: read and reordered for one more release", FutureWarning,
                      stacklevel=2)
        out[new] = neu_to_enu(out.pop(old))
    return out


def reads_old_sigma_pos(cls):
    """Class decorator of a dataclass with a ``sigma_pos_enu`` field ([east, north, up]):
    its constructor also takes the old keyword ``sigma_pos`` ([north, east, up]), read
    reordered (:func:`neu_to_enu`) with a ``FutureWarning`` naming both and the order
    change (both at once: a TypeError), and its attribute ``sigma_pos`` gives the old
    order — for one more release."""
    name = cls.__name__
    at = [f.name for f in dataclasses.fields(cls)].index("sigma_pos_enu")
    message = (f"{name}.sigma_pos [north, east, up] is now {name}.sigma_pos_enu [east, "
               f"north, up]: read and reordered for one more release")
    init = cls.__init__

    @functools.wraps(init)
    def __init__(self, *args, sigma_pos=None, **kwargs):
        if sigma_pos is not None:
            if len(args) > at or "sigma_pos_enu" in kwargs:
                raise TypeError(f"{name}: sigma_pos ([north, east, up]) and sigma_pos_enu "
                                f"([east, north, up]) are the same setting; give "
                                f"sigma_pos_enu only")
            warnings.warn(message, FutureWarning, stacklevel=2)
            kwargs["sigma_pos_enu"] = neu_to_enu(sigma_pos)
        init(self, *args, **kwargs)

    def sigma_pos(self):
        """Deprecated (removed in 0.3): ``sigma_pos_enu`` in the old order [north, east,
        up] [m], with a ``FutureWarning``."""
        warnings.warn(message, FutureWarning, stacklevel=2)
        return neu_to_enu(self.sigma_pos_enu)  # (the same swap both ways)

    cls.__init__ = __init__
    cls.sigma_pos = property(sigma_pos)
    return cls


@reads_old_sigma_pos
@dataclass(frozen=True)
class Gnss:
    """Fix ``[lat, lon, h, vE, vN, vU]`` every ``period`` [s] with white noise.

    ``sigma_pos_enu`` [m]: scalar, or ``(east, north, up)``; ``sigma_vel`` [m/s]: scalar
    or ``(east, north, up)``.  The series' ``sigma`` follows ``z`` (``[lat, lon, h, vE,
    vN, vU]``): ``[north m, east m, up m, vE, vN, vU]``.  The old keyword ``sigma_pos``
    ([north, east, up]) is read with a ``FutureWarning`` (:func:`reads_old_sigma_pos`).
    """

    sigma_pos_enu: float | tuple
    sigma_vel: float | tuple
    period: float

    def simulate(self, truth, rng: np.random.Generator, t=None,
                 t_avail=None) -> MeasurementSeries:
        t = flight_times(truth, self.period, t)
        tr = truth.at(t)
        sp = np.broadcast_to(np.asarray(self.sigma_pos_enu, dtype=float), (3,))[[1, 0, 2]]
        sv = np.broadcast_to(np.asarray(self.sigma_vel, dtype=float), (3,))
        npos = rng.standard_normal((len(t), 3)) * sp  # north, east, up
        z = np.column_stack([position_noise_to_llh(tr["lla"], npos),
                             tr["vel"] + rng.standard_normal((len(t), 3)) * sv])
        return MeasurementSeries("gnss", t, z, np.r_[sp, sv], t_avail)


class GnssPosVel(RowModel):
    """GNSS position and velocity of an antenna at ``lever`` (body right-forward-up, m)
    from the IMU: residual = INS-derived antenna - GNSS, ``[dE, dN, dU] m, [dvE, dvN, dvU]``.

    The INS-derived antenna position is ``p + C l``; with ``C_hat = exp(-[phi x]) C`` its
    error is ``dp + [(C l) x] phi`` (and likewise ``[(C (w x l)) x] phi`` for the
    velocity), so a lever arm makes attitude observable from GNSS (tested numerically)."""

    kind = "gnss"
    rows = ((POS_E, 1), (POS_N, 0), (POS_U, 2), (VEL_E, 3), (VEL_N, 4), (VEL_U, 5))
    #: the positions' time-correlated error, [east, north, up] (``gnss_markov``)
    markov_block, markov_kinds = "gnss_markov", (POS_E, POS_N, POS_U)

    def __init__(self, lever=(0.0, 0.0, 0.0), measures: str = "position_velocity"):
        # z keeps its 6 components; a receiver without velocity (or position) has rows
        # for the others only
        keep = {"position_velocity": slice(0, 6), "position": slice(0, 3),
                "velocity": slice(3, 6)}[measures]
        self.rows = GnssPosVel.rows[keep]
        super().__init__(lever)

    def R(self, sigma) -> np.ndarray:
        s = np.asarray(sigma, dtype=float)  # [north, east, up m, vE, vN, vU], as z
        return self.white(np.diag(s[self.zindex] ** 2))


class GnssConfig(SensorConfig):
    """GNSS receiver: 1-sigma position noise ``sigma_pos_enu_m`` (one value or [east,
    north, up] m) and velocity noise ``sigma_vel_mps`` (one value or [east, north, up]
    m/s) — the data file's when left out —
    antenna ``lever_m`` from the IMU (body right-forward-up; the file's when left out),
    ``time_offset_s`` added to the file's time stamps, and ``velocity_latency_s``: how
    much older than its stamp each velocity is [s] (a receiver's Doppler velocity lagging
    its position); None (default): the latency ``fednav process`` sees from the
    positions (``gnss_velocity_latency_seen_s`` and its 1-sigma) or, where they are too
    noisy to tell, against the INS of a pass on the positions alone, taken out when it is
    confident (beyond 0.05 s and three sigmas), else none; 0: the stamps as they are.
    The old key ``sigma_pos_m`` ([north, east, up]) is read as ``sigma_pos_enu_m``,
    reordered, with a ``FutureWarning``.
    ``markov_sigma_enu_m`` (one value or [east, north, up] m) and ``markov_tau_s`` [s]:
    the time-correlated part of the position error (first-order Gauss–Markov: RTK / PPP
    and multipath errors), which the optional ``gnss_markov`` error state
    (``filter.states``) estimates; the position sigma is then the whole error's and the
    filter's R its white part (:meth:`GnssPosVel.with_markov`)."""

    sigma_pos_enu_m: float | _V3 | None = None
    sigma_vel_mps: float | _V3 | None = None
    time_offset_s: float = 0.0
    velocity_latency_s: float | None = Field(default=None, ge=0.0, le=2.0)
    markov_sigma_enu_m: float | _V3 | None = None
    markov_tau_s: float | None = Field(default=None, gt=0.0)
    #: the key of the 1-sigma the model's Gauss-Markov state takes
    MARKOV_KEY: ClassVar[str] = "markov_sigma_enu_m"
    #: what the local filter uses (None: what the data hold; both in a simulation)
    measures: Literal["position_velocity", "position", "velocity"] | None = None

    #: old spellings of its keys -> today's (read, reordered, with a FutureWarning)
    old_keys: ClassVar[dict[str, str]] = NEU_KEYS
    flat_keys: ClassVar[dict[str, tuple]] = {
        "gnss_sigma_pos_m": ("sigma_pos_enu_m", neu_to_enu,
                             "[north, east, up] -> [east, north, up]"),
        "gnss_sigma_vel_mps": ("sigma_vel_mps",), "gnss_lever_m": ("lever_m",),
        "gnss_time_offset_s": ("time_offset_s",)}

    @model_validator(mode="before")
    @classmethod
    def _renamed(cls, data):
        return cls.renamed_keys(data)

    @classmethod
    def renamed_keys(cls, data, where: str = "sensors.gnss"):
        """A section's mapping with its old [north, east, up] keys in today's places
        (:func:`renamed_neu_keys`)."""
        return renamed_neu_keys(data, where, cls.old_keys)

    def sensor(self) -> Gnss:
        from ..core.config import ConfigError

        if self.sigma_pos_enu_m is None or self.sigma_vel_mps is None:
            raise ConfigError("sensors.gnss: sigma_pos_enu_m and sigma_vel_mps are needed "
                              "to simulate the receiver")
        return Gnss(self.sigma_pos_enu_m, self.sigma_vel_mps, self.period_s)

    def model(self) -> GnssPosVel:
        return GnssPosVel(measures=self.measures or "position_velocity")

    def for_recording(self, data) -> GnssConfig:
        """The section as it flies the receiver's recording ``data``
        (:class:`~fednav.io.GnssData`): the antenna lever arm and the position and
        velocity 1-sigma the section leaves out taken from the data's figures, ``measures``
        from what the file holds (a section that asks for what the file lacks: a
        one-line :class:`~fednav.core.errors.DataError`); ``period_s`` left as it is (the
        filter's epochs follow the fixes)."""
        absent = set(data.absent)
        has = ("position" if {3, 4, 5} <= absent else "velocity" if {0, 1, 2} <= absent
               else "position_velocity")
        if self.measures is not None and self.measures != has and has != "position_velocity":
            raise DataError(f"{data.source}: sensors.gnss.measures is {self.measures}, the "
                            f"file has {has.replace('_', ' and ')} only")

        def three(mine, theirs):
            v = theirs if mine is None else mine
            return tuple(map(float, np.broadcast_to(np.asarray(v, dtype=float), (3,))))

        return self.model_copy(update={  # (its period: the filter's epochs take the fixes')
            "lever_m": three(self.lever_m, getattr(data, "lever", 0.0)),
            "sigma_pos_enu_m": three(self.sigma_pos_enu_m, getattr(data, "sigma_pos_enu",
                                                                   5.0)),
            "sigma_vel_mps": three(self.sigma_vel_mps, getattr(data, "sigma_vel", 0.1)),
            "measures": self.measures or has})

    def total_state_refusal(self) -> str | None:
        """The total-state model needs positions and velocities."""
        if self.measures in (None, "position_velocity"):
            return None
        return (f"the total-state navigator's GNSS model needs positions and velocities; "
                f"the file has {self.measures.replace('_', ' and ')} only")

    def sigma(self) -> np.ndarray | None:
        """1-sigma of ``z``: ``[north m, east m, up m, vE, vN, vU m/s]`` (None when the
        data's are to be used)."""
        m = self.measures or "position_velocity"
        pos = self.sigma_pos_enu_m if m != "velocity" else 1.0
        vel = self.sigma_vel_mps if m != "position" else 1.0
        if pos is None or vel is None:
            return None
        return np.r_[np.broadcast_to(np.asarray(pos, dtype=float), (3,))[[1, 0, 2]],
                     np.broadcast_to(np.asarray(vel, dtype=float), (3,))]


_DEG = float(np.radians(1.0))
class GnssTotal:
    """GNSS on the total state: residual ``GNSS [-] X`` = [dv (3), dp ENU (3)] (filter
    units); linear ``H = [0 I 0]``."""

    kind = "gnss"
    dim = 6
    H = np.hstack([np.zeros((6, 3)), np.eye(6), np.zeros((6, N_BIAS))])

    def residual(self, state, z) -> np.ndarray:
        lat, lon, h = state[7], state[8], state[9]
        rm, rn = earth.radii_nb(lat)
        v = state[STATE_VEL]
        return np.array([z[3] - v[0], z[4] - v[1], z[5] - v[2],
                         earth.wrap_lon(z[1] - lon) * (rn + h) * np.cos(lat),
                         (z[0] - lat) * (rm + h),
                         z[2] - h]) / TSCALE[3:9]

    def R(self, sigma) -> np.ndarray:
        s = np.asarray(sigma, dtype=float)  # [north, east, up m, vE, vN, vU] as z
        return np.diag(s[[3, 4, 5, 1, 0, 2]] ** 2)

    def terms(self, state, z, sigma) -> tuple[np.ndarray, np.ndarray]:
        return self.residual(state, z), self.R(sigma)


SPEC = SensorSpec(
    "gnss", "GNSS receiver: position and ENU velocity of its antenna", GnssConfig, GnssPosVel,
    columns=(Column("lat_deg", _DEG, sigma=("sigma_north_m", 1.0)),
             Column("lon_deg", _DEG, sigma=("sigma_east_m", 1.0)),
             Column("h_m", sigma=("sigma_up_m", 1.0)),
             Column("vE_mps"), Column("vN_mps"), Column("vU_mps")),
    latlon=(0, 1), height=2, fixes=True, total=GnssTotal(),
    label="GNSS", tuned=("sigma_pos_enu_m", "sigma_vel_mps"))

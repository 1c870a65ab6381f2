"""Air data: true airspeed, and the wind estimate that goes with it (paper 000).

The airship's ground velocity is its air velocity plus the wind.  The air-data system
measures the airspeed; the wind constraint of the CUKF also needs the current wind,
which the paper takes as known.  fednav makes both explicit: the series carries
``z = [airspeed (m/s), wind east, wind north (m/s)]`` where the wind estimate is the
truth plus white noise ``wind_sigma`` and a constant ``wind_bias`` (east, north) — the
knob that shows what a wrong wind estimate does to the constrained filter.

Section ``sensors.airdata``: ``sigma_airspeed_mps``, ``wind_sigma_mps``,
``wind_bias_mps`` (east, north), ``period_s``.  File columns: ``t_s, airspeed_mps,
wind_e_mps, wind_n_mps`` and optionally ``aoa_deg, sideslip_deg``: without the angles
the airspeed is the horizontal airspeed along the heading (the airship of paper 000);
with them it is the true airspeed, directed in the body by the angle of attack and the
sideslip.  It does not feed a local filter: the wind constraint (:class:`WindConstraint`)
uses it in every local filter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import Field

from ..core import attitude as att
from ..core.config import simulation_only
from ..core.units import ARCMIN
from ..ins.error_model import N_STATES, PHI
from .base import MeasurementSeries, flight_times
from .measurement import NavSnapshot
from .spec import Column, SensorConfig, SensorSpec


@dataclass(frozen=True)
class AirData:
    """Airspeed noise ``sigma`` [m/s], wind-estimate noise ``wind_sigma`` [m/s] and bias
    ``wind_bias`` (east, north) [m/s], every ``period`` [s]."""

    sigma: float
    wind_sigma: float
    wind_bias: tuple[float, float]
    period: float

    def simulate(self, truth, rng: np.random.Generator, t=None,
                 t_avail=None) -> MeasurementSeries:
        t = flight_times(truth, self.period, t)
        tr = truth.at(t)
        air = tr["vel"][:, :2] - tr["wind"][:, :2]
        n = rng.standard_normal((len(t), 3))
        z = np.column_stack([np.linalg.norm(air, axis=1) + n[:, 0] * self.sigma,
                             tr["wind"][:, :2] + np.asarray(self.wind_bias)
                             + n[:, 1:] * self.wind_sigma])
        return MeasurementSeries("airdata", t, z,
                                 np.array([self.sigma, self.wind_sigma, self.wind_sigma]),
                                 t_avail)


class WindConstraint:
    """Air-data wind constraint on the velocity errors (paper 000, eq. 3 and 49–50),
    derived in fednav's convention (heading ψ from north toward east):

    the true ground velocity is ``v = v_a u(ψ) + w`` with ``u(ψ) = [sin ψ, cos ψ]``, so
    with the measured airspeed ``v_a``, the INS heading ``ψ^`` and the wind estimate ``w^``::

        d = v^_EN - (v_a u(ψ^) + w^)  =  δv_EN - v_a u'(ψ) δψ      u' = [cos ψ, -sin ψ]
        D = [ -v_a u'(ψ) ⊗ ∂δψ/∂φ ,  I (δvE, δvN) ]

    ``δψ = φU - tanθ (sinψ φE + cosψ φN)`` (``attitude.euler_error_jacobian``).  The paper
    prints ``D = [.. sinψ .. ; .. cosψ ..]`` on δvE/δvN and ``d = δv_w + δv_a cos/sinψ``;
    its sin/cos placement fits a heading from east; here both rows follow from the same
    expression, and the test suite checks ``D x = d`` against a perturbed truth.

    ``z = [airspeed, wind E, wind N]`` (:class:`AirData`); ``R`` is the covariance of
    ``d`` from the airspeed and wind-estimate noise.  ``constraint = True``: constrained
    filters project onto it (CUKF), others would treat it as a measurement.
    """

    kind = "airdata"
    dim = 2
    constraint = True

    def __init__(self, airspeed: float = 0.0, aoa: float | None = None,
                 sideslip: float | None = None):
        self.va = float(airspeed)  # measured airspeed [m/s] (enters D)
        # with the angles the airspeed is the true airspeed and the air velocity's
        # direction in the body is b = [sin beta, cos alpha cos beta, -sin alpha cos beta]
        # (right, forward, up; alpha > 0: the body moves below its nose, beta > 0: to its
        # right); without them, the horizontal airspeed along the heading
        self.b = None
        if aoa is not None or sideslip is not None:
            a, bb = (0.0 if v is None or not np.isfinite(v) else float(v)
                     for v in (aoa, sideslip))
            self.b = np.array([np.sin(bb), np.cos(a) * np.cos(bb), -np.sin(a) * np.cos(bb)])

    @classmethod
    def of(cls, z) -> WindConstraint:
        """The constraint for one air-data row ``z = [airspeed, wind E, wind N]`` (and,
        in a file with them, ``angle of attack, sideslip`` [rad]; NaN: absent)."""
        z = np.asarray(z, dtype=float)
        angles = z[3:5] if len(z) >= 5 and np.isfinite(z[3:5]).any() else (None, None)
        return cls(z[0], *angles)

    def _air(self, nav: NavSnapshot, va: float) -> np.ndarray:
        """Horizontal air velocity (east, north) [m/s] the INS attitude gives."""
        if self.b is None:
            psi = nav.euler[2]
            return va * np.array([np.sin(psi), np.cos(psi)])
        return va * (nav.C @ self.b)[:2]

    def residual(self, nav: NavSnapshot, z) -> np.ndarray:
        return np.asarray(nav.vel[:2], dtype=float) - (self._air(nav, z[0])
                                                       + np.asarray(z[1:3]))

    def h(self, X, nav: NavSnapshot) -> np.ndarray:
        return np.atleast_2d(X) @ self.H(nav).T

    def H(self, nav: NavSnapshot) -> np.ndarray:
        va = self.va
        D = np.zeros((2, N_STATES))
        if self.b is None:
            psi = nav.euler[2]
            du = np.array([np.cos(psi), -np.sin(psi)])
            jpsi = att.euler_error_jacobian(nav.euler)[2]  # d(heading error)/d(phi)
            D[:, PHI] = -va * np.outer(du, jpsi) * ARCMIN
        else:  # C_hat a = C a + [(C a) x] phi: d loses the first two rows of that
            D[:, PHI] = -att.skew(va * (nav.C @ self.b))[:2] * ARCMIN
        D[0, 3] = D[1, 4] = 1.0
        return D

    def R(self, sigma, nav: NavSnapshot | None = None) -> np.ndarray:
        s = np.asarray(sigma, dtype=float)  # [airspeed, wind E, wind N, ...]
        R = np.diag(s[1:3] ** 2)
        if nav is not None:
            u = self._air(nav, 1.0)
            R = R + s[0] ** 2 * np.outer(u, u)
        return R


class AirDataConfig(SensorConfig):
    """Air data (horizontal airspeed) and the wind estimate the wind constraint uses."""

    sigma_airspeed_mps: float = Field(gt=0.0)
    wind_sigma_mps: float = Field(default=0.0, ge=0.0)
    #: (east, north) error of the simulated wind estimate
    wind_bias_mps: tuple[float, float] = Field((0.0, 0.0), json_schema_extra=simulation_only(
        "a recorded wind estimate has the error it has"))

    def sensor(self) -> AirData:
        return AirData(self.sigma_airspeed_mps, max(self.wind_sigma_mps, 1e-6),
                       self.wind_bias_mps, self.period_s)

    def model(self) -> WindConstraint:
        return WindConstraint()

    def roles(self, system) -> dict[str, str]:
        """The wind constraint, when the system flies it (``constraint: wind``)."""
        return {"constraint": "constraint: wind"} if system.constraint == "wind" else {}

    def sigma(self) -> np.ndarray:
        w = max(self.wind_sigma_mps, 1e-6)
        return np.array([self.sigma_airspeed_mps, w, w])


_DEG = float(np.radians(1.0))
SPEC = SensorSpec("airdata", "air data: true airspeed and the wind estimate (the wind "
                  "constraint; no local filter of its own)", AirDataConfig, WindConstraint,
                  columns=(Column("airspeed_mps"), Column("wind_e_mps"),
                           Column("wind_n_mps"), Column("aoa_deg", _DEG, absent={}),
                           Column("sideslip_deg", _DEG, absent={})),
                  aiding=False, angles=(3, 4))

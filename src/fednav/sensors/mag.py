"""Magnetometer used as a heading sensor: the tilt-compensated magnetic heading.

Section ``sensors.mag``: ``sigma_heading_deg`` (1-sigma of the heading it gives),
``declination_deg`` (magnetic north's azimuth east of true north: added to the magnetic
heading), ``inclination_deg`` (the field's dip below the horizon), ``field_gauss``
(simulation only), ``period_s``.  File columns: ``t_s, magR_gauss, magF_gauss,
magU_gauss`` (the field in body right-forward-up axes, gauss; ``z`` holds it in tesla,
and only its direction is used), optionally one ``sigma_heading_deg`` column (each row's
heading 1-sigma).

Residual (INS - sensor, arc-minutes, wrapped to +-180 deg)::

    y = psi_INS - (psi_mag + D)      psi_mag = atan2(-l_R, l_F),  l = L(theta, gamma) z

with ``L`` the INS attitude's roll and pitch alone (``euler_to_dcm([pitch, roll, 0])``:
body -> the level frame whose forward axis is the nose's azimuth).  Since
``C = Rz(-psi) L``, this is exactly the azimuth of the measured field's horizontal part
in the INS's navigation frame, ``alpha(C_hat z)``, minus ``D``: the INS heading cancels.
For the platform error ``phi`` (``C_hat = exp(-[phi x]) C``) the measured field in the
INS frame is ``exp(-[phi x]) b``, so to first order::

    dy = phiU + tan(I) (sin(D) phiE + cos(D) phiN)

— a tilt error ``e`` moves the tilt-compensated heading by ``tan(I) e`` (the field's
vertical part leaks into the horizontal), whatever the vehicle's attitude.  That row is
``H``.  The heading row of the Euler-error Jacobian,
``phiU - tan(theta) (sin(psi) phiE + cos(psi) phiN)``, is the sensitivity of the INS
heading alone: it misses the tilt compensation's share and does not describe this
residual (``tests/test_mag.py`` checks ``H`` against finite differences).  ``H`` and the
sigma-point prediction ``h`` use the configured field direction (``inclination_deg``,
``declination_deg``); the residual uses the measured field.  Additive faults
(``faults:``) are not defined for this sensor: its ``sigma`` is the heading's, one
component, while ``z`` has three.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import Field

from ..core import attitude as att
from ..core import units
from ..core.config import simulation_only
from ..core.units import ARCMIN
from ..ins.error_model import N_STATES, PHI, SCALE
from .base import MeasurementSeries, flight_times
from .measurement import NavSnapshot
from .spec import Column, SensorConfig, SensorSpec

#: Tesla per gauss (the unit PX4 and most magnetometers report).
GAUSS = 1.0e-4
#: A field weaker than this [gauss] is no measurement (the Earth's is 0.25-0.65 gauss): a
#: sensor reporting zeros, a saturated or disconnected one.
MIN_FIELD_GAUSS = 1.0e-3


def usable(z) -> np.ndarray:
    """Rows of fields ``z`` (N, 3) [T] that can give a heading (stronger than
    :data:`MIN_FIELD_GAUSS`)."""
    return np.linalg.norm(np.asarray(z, dtype=float), axis=1) > MIN_FIELD_GAUSS * GAUSS


def field_enu(inclination: float, declination: float, strength: float = 1.0) -> np.ndarray:
    """The Earth's field in ENU: ``strength [cos I sin D, cos I cos D, -sin I]`` (its
    horizontal part points to magnetic north, ``D`` east of true north; ``I`` > 0 dips it
    below the horizon, as in the northern hemisphere).  Angles [rad]."""
    ci = np.cos(inclination)
    return strength * np.array([ci * np.sin(declination), ci * np.cos(declination),
                                -np.sin(inclination)])


def azimuth(b) -> np.ndarray:
    """Azimuth [rad] of the horizontal part of ENU vectors ``b`` (..., 3), from north
    toward east, in (-pi, pi]."""
    b = np.asarray(b, dtype=float)
    return np.arctan2(b[..., 0], b[..., 1])


def magnetic_heading(euler, z) -> np.ndarray:
    """The tilt-compensated magnetic heading [rad] in (-pi, pi] of body fields ``z``
    (..., 3) (right-forward-up, any unit) levelled with the pitch and roll of ``euler``
    ``[pitch, roll, heading]`` [rad] (its heading is not used)."""
    e = np.array(euler, dtype=float)
    e[..., 2] = 0.0
    level = np.einsum("...ij,...j->...i", att.euler_to_dcm(e), np.asarray(z, dtype=float))
    return np.arctan2(-level[..., 0], level[..., 1])


@dataclass(frozen=True)
class Magnetometer:
    """The body field ``C^T b`` of a field of ``strength`` [T], ``inclination`` and
    ``declination`` [rad], plus white noise on each axis of
    ``sigma_heading * strength * cos(inclination)`` [T] every ``period`` [s]: the noise
    component across the horizontal field turns it by ``sigma_heading`` [rad] (1-sigma,
    first order; tilt compensation rotates the isotropic noise without changing it)."""

    sigma_heading: float
    inclination: float
    declination: float
    strength: float
    period: float

    def simulate(self, truth, rng: np.random.Generator, t=None,
                 t_avail=None) -> MeasurementSeries:
        t = flight_times(truth, self.period, t)
        C = att.euler_to_dcm(truth.at(t)["euler"])
        b = field_enu(self.inclination, self.declination, self.strength)
        z = np.einsum("kji,j->ki", C, b)  # C^T b
        sig_b = self.sigma_heading * self.strength * np.cos(self.inclination)
        z = z + rng.standard_normal(z.shape) * sig_b
        return MeasurementSeries("mag", t, z, np.array([self.sigma_heading]), t_avail)


class MagHeading:
    """The magnetometer's heading measurement (see the module docstring): residual
    [arcmin], ``H`` and ``h`` over the error state in filter units; runs in the
    navigator's Python loop."""

    kind = "mag"
    dim = 1
    linear = False

    def __init__(self, declination: float = 0.0, inclination: float = units.deg(60.0)):
        self.declination = float(declination)
        self.inclination = float(inclination)
        self.b = field_enu(self.inclination, self.declination)
        row = np.zeros(N_STATES)
        t = np.tan(self.inclination)
        row[PHI] = [t * np.sin(self.declination), t * np.cos(self.declination), 1.0]
        self._H = row[None, :]

    def residual(self, nav: NavSnapshot, z) -> np.ndarray:
        """INS heading minus the true heading from the field ``z`` (body RFU) [arcmin]."""
        e = nav.euler
        psi = magnetic_heading(e, np.asarray(z, dtype=float)[:3]) + self.declination
        return np.array([float(att.wrap_pi(e[2] - psi)) / ARCMIN])

    def H(self, nav: NavSnapshot) -> np.ndarray:
        """d(residual)/d(error state), arcmin per filter unit (attitude only)."""
        return self._H.copy()

    def h(self, X, nav: NavSnapshot) -> np.ndarray:
        """Predicted residual of each row of error states ``X`` (filter units): the
        azimuth of the configured field seen through ``exp(-[phi x])``, minus ``D``."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        rot = att.misalignment_dcm(X[:, PHI] * SCALE[PHI])
        a = azimuth(rot @ self.b)
        return (att.wrap_pi(a - self.declination) / ARCMIN)[:, None]

    def R(self, sigma) -> np.ndarray:
        """Heading variance [arcmin^2] from its 1-sigma [rad] (the first component)."""
        s = float(np.ravel(np.asarray(sigma, dtype=float))[0])
        return np.array([[(s / ARCMIN) ** 2]])


class MagConfig(SensorConfig):
    """Magnetometer heading: ``sigma_heading_deg`` 1-sigma of the heading,
    ``declination_deg`` (east of true north; added to the magnetic heading),
    ``inclination_deg`` (dip; the simulator's field and the tilt coupling of ``H``),
    ``field_gauss`` (field strength, simulation only)."""

    sigma_heading_deg: float = Field(gt=0.0)
    declination_deg: float = Field(default=0.0, ge=-180.0, le=180.0)
    inclination_deg: float = Field(default=60.0, gt=-89.0, lt=89.0)
    field_gauss: float = Field(default=0.5, gt=0.0, json_schema_extra=simulation_only(
        "only the measured field's direction is used"))

    def sensor(self) -> Magnetometer:
        return Magnetometer(float(units.deg(self.sigma_heading_deg)),
                            float(units.deg(self.inclination_deg)),
                            float(units.deg(self.declination_deg)),
                            self.field_gauss * GAUSS, self.period_s)

    def model(self) -> MagHeading:
        return MagHeading(float(units.deg(self.declination_deg)),
                          float(units.deg(self.inclination_deg)))

    def sigma(self) -> np.ndarray:
        """The heading 1-sigma [rad], shape (1,) (``z`` is a field: R is the heading's)."""
        return np.array([float(units.deg(self.sigma_heading_deg))])


_DEG = float(units.deg(1.0))
_SIGMA = ("sigma_heading_deg", _DEG)  # one column: every component's row 1-sigma
SPEC = SensorSpec(
    "mag", "magnetometer: heading from the field tilt-compensated with the INS roll and "
           "pitch", MagConfig, MagHeading,
    columns=(Column("magR_gauss", GAUSS, sigma=_SIGMA),
             Column("magF_gauss", GAUSS, sigma=_SIGMA),
             Column("magU_gauss", GAUSS, sigma=_SIGMA)), valid=usable, mountable=True)

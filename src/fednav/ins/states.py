"""Optional error states, appended after the 18 of :mod:`fednav.ins.error_model`.

A system description selects them (``filter.states``); each is a block of three::

    gyro_scale    sg_x sg_y sg_z   gyro scale-factor error, body axes   [ppm; SI: fraction]
    accel_scale   sa_x sa_y sa_z   accelerometer scale-factor error     [ppm; SI: fraction]
    gnss_markov   bE bN bU         GNSS position error correlated in    [m]
                                   time (first-order Gauss–Markov), ENU
    velocity_markov  vbE vbN vbU   the velocity sensor's error (visual  [m/s]
                                   odometry, DVL) likewise, ENU
    clock         cb cd            receiver clock bias and drift, as    [m, m/s]
                                   range (c dt) and range rate

in this order after state 17 when present (KF-GINS's 21-state model is the 18 with the
two scale-factor blocks).  The bracket is the filter unit (see
:data:`fednav.ins.error_model.SCALE`).

A measured rate is ``(1 + s) w + b``: the INS compensates ``(w_meas - b_hat) / (1 +
s_hat)``, so the compensated rate's error is ``eps + diag(w_b) ds`` (first order) and the
attitude error rate gains ``-C diag(w_b) ds_g``, the velocity error rate ``C diag(f_b)
ds_a`` (``w_b``, ``f_b``: the interval's mean compensated body rate and specific force).
A GNSS fix is ``p + b + v`` with ``b`` Gauss–Markov: the residual of its position rows is
``INS - (z - b_hat) = dp - db``, so those rows have ``-1`` on ``db`` (a velocity sensor's
rows the same with its velocity error)
(:func:`fednav.sensors.measurement.bias_columns`).  The navigator keeps the totals
(``s_hat``, ``b_hat``) beside the INS and feeds every estimated error back into them, as
it does the biases; ``b_hat`` follows its mean dynamics (decays by ``exp(-T / tau)``)
between epochs.

Each block is a first-order Gauss–Markov process of stationary 1-sigma ``sigma`` (also
its P0) and correlation time ``tau`` (``inf``: a random constant, no process noise), or
given its own white-noise densities ``qc`` (then a random walk when ``tau`` is ``inf``).
A state may integrate another of its block (:attr:`Block.drives`): the receiver clock's
bias is the integral of its drift, ``d(cb)/dt = cd + w_b``, ``d(cd)/dt = w_d``, whose
densities are those of the two-state clock model (Brown and Hwang, ch. 9: ``S_f = h0 / 2
c^2``, ``S_g = 2 pi^2 h_-2 c^2``); its totals then follow the mean dynamics
``cb += T cd`` between epochs (:meth:`StateLayout.transition`).  A sensor whose
measurement needs a block names it (its model's ``own_block``, the raw GNSS's clock) and
the block joins the layout whenever the sensor aids.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np


class Block(NamedTuple):
    """One optional block: its three ``states``' names, the SI value of one filter
    ``unit``, and how reports show it: the key ``suffix`` (``summary.json``
    ``error_states``: name + suffix, values in filter units), its ``axes`` and its unit
    ``label``."""

    states: tuple[str, ...]
    unit: float
    suffix: str
    axes: str
    label: str
    #: pairs (i, j) of the block's states: state i's rate includes state j (the clock's
    #: bias integrates its drift)
    drives: tuple = ()


#: The optional blocks, in state order.  A sensor whose error a block models names it
#: (its model's ``markov_block``, :class:`fednav.sensors.measurement.RowModel`).
BLOCKS = {"gyro_scale": Block(("sg_x", "sg_y", "sg_z"), 1e-6, "ppm", "x/y/z", "ppm"),
          "accel_scale": Block(("sa_x", "sa_y", "sa_z"), 1e-6, "ppm", "x/y/z", "ppm"),
          "gnss_markov": Block(("gnss_bE", "gnss_bN", "gnss_bU"), 1.0, "enu_m", "E/N/U",
                               "m"),
          "velocity_markov": Block(("vel_bE", "vel_bN", "vel_bU"), 1.0, "enu_mps", "E/N/U",
                                   "m/s"),
          "clock": Block(("clk_b", "clk_d"), 1.0, "m_mps", "bias/drift", "m, m/s",
                         drives=((0, 1),))}
#: The 18 core states.
N_CORE = 18


@dataclass(frozen=True)
class StateLayout:
    """The error state's optional blocks: ``blocks`` = ((name, sigma SI, tau [s], qc
    SI), ...) in :data:`BLOCKS` order, one sigma and one white-noise density ``qc`` per
    state of the block.  The empty layout is the 18-state model."""

    blocks: tuple = ()

    @classmethod
    def of(cls, blocks: dict) -> StateLayout:
        """From ``{name: (sigma, tau)}`` or ``{name: (sigma, tau, qc)}`` (sigma and qc one
        value or per state, SI; tau [s], inf for a random constant or, with ``qc``, a
        random walk; qc default: the Gauss–Markov process's ``2 sigma^2 / tau``), ordered
        as :data:`BLOCKS`."""
        for k in blocks:
            if k not in BLOCKS:
                raise ValueError(f"unknown optional error state '{k}'; known: "
                                 f"{', '.join(BLOCKS)}")
        out = []
        for k in BLOCKS:
            if k in blocks:
                sigma, tau, *qc = blocks[k]
                m = len(BLOCKS[k].states)
                sigma = tuple(float(s) for s in np.broadcast_to(np.asarray(sigma, float), m))
                tau = float(tau)
                if min(sigma) < 0.0 or not tau > 0.0:
                    raise ValueError(f"optional error state '{k}': sigma >= 0 and tau > 0")
                qc = (np.broadcast_to(np.asarray(qc[0], float), m) if qc else
                      [0.0 if np.isinf(tau) else 2.0 * s * s / tau for s in sigma])
                if min(qc) < 0.0:
                    raise ValueError(f"optional error state '{k}': qc >= 0")
                out.append((k, sigma, tau, tuple(float(q) for q in qc)))
        return cls(tuple(out))

    @property
    def names(self) -> tuple[str, ...]:
        """The blocks present, in state order."""
        return tuple(b[0] for b in self.blocks)

    @property
    def n(self) -> int:
        """Number of error states."""
        return N_CORE + sum(len(b[1]) for b in self.blocks)

    def start(self, name: str) -> int:
        """Column of block ``name``'s first state; -1 when it is not in the layout."""
        i = N_CORE
        for b in self.blocks:
            if b[0] == name:
                return i
            i += len(b[1])
        return -1

    def size(self, name: str) -> int:
        """How many states block ``name`` has."""
        return len(BLOCKS[name].states)

    def state_names(self, core: tuple) -> tuple[str, ...]:
        """``core`` (the 18 names) and every optional state's."""
        return tuple(core) + tuple(s for b in self.blocks for s in BLOCKS[b[0]].states)

    def scale(self, core: np.ndarray) -> np.ndarray:
        """SI value of one filter unit per state (``core``: the 18 states')."""
        return np.r_[core, [BLOCKS[b[0]].unit for b in self.blocks for _ in b[1]]]

    def _per_state(self, f) -> np.ndarray:
        return np.array([f(s, b[2]) for b in self.blocks for s in b[1]], dtype=float)

    def drivers(self) -> np.ndarray:
        """Per optional state, the column of the state its rate integrates (-1: none;
        :attr:`Block.drives`)."""
        out = []
        for b in self.blocks:
            i0, drv = self.start(b[0]), [-1] * len(b[1])
            for i, j in BLOCKS[b[0]].drives:
                drv[i] = i0 + j
            out += drv
        return np.array(out, dtype=float)

    @property
    def coupled(self) -> bool:
        """Whether a state integrates another (:meth:`drivers`): the totals then follow
        :meth:`transition`, not each its own decay alone."""
        return bool((self.drivers() >= 0).any())

    def model_vector(self) -> np.ndarray:
        """What the compiled model reads of the layout: ``[start of gyro_scale, start of
        accel_scale, 1/tau per optional state..., Qc diagonal per optional state...,
        driver column per optional state...]`` (starts and drivers -1 when absent; SI)."""
        itau = self._per_state(lambda s, t: 0.0 if np.isinf(t) else 1.0 / t)
        qc = np.array([q for b in self.blocks for q in b[3]], dtype=float)
        return np.r_[float(self.start("gyro_scale")), float(self.start("accel_scale")),
                     itau, qc, self.drivers()]

    def sigma(self) -> np.ndarray:
        """1-sigma of every optional state (SI): their P0."""
        return self._per_state(lambda s, t: s)

    def transition(self, T: float) -> np.ndarray:
        """The optional states' mean transition over ``T`` [s], ``expm(F_opt T)`` (m, m):
        ``exp(-T / tau)`` on the diagonal, and a driven state's integral of its driver (the clock's
        ``cb += T cd``)."""
        import scipy.linalg

        m = self.n - N_CORE
        F = np.diag(-self._per_state(lambda s, t: 0.0 if np.isinf(t) else 1.0 / t))
        for i, j in enumerate(self.drivers().astype(int)):
            if j >= 0:
                F[i, j - N_CORE] = 1.0
        return scipy.linalg.expm(F * T) if m else np.zeros((0, 0))


@numba.njit(cache=True)
def follow_mean(transition, xa) -> None:
    """The optional states' totals ``xa[18:]`` (SI) moved in place by their mean
    transition over an epoch (:meth:`StateLayout.transition`): the Python loop's and the
    compiled engine's one rule."""
    m = transition.shape[0]
    old = xa[N_CORE:N_CORE + m].copy()
    for i in range(m):
        s = 0.0
        for j in range(m):
            s += transition[i, j] * old[j]
        xa[N_CORE + i] = s


#: The 18-state model.
CORE = StateLayout()


def with_optional(P0, layout: StateLayout) -> np.ndarray:
    """``P0`` (filter units) over every state of ``layout``: an 18-state P0 gains the
    optional blocks' 1-sigma on its diagonal (at least 1e-6 filter units); a P0 of the
    whole layout is returned as it is."""
    P0 = np.asarray(P0, dtype=float)
    n = layout.n
    if P0.shape == (n, n):
        return P0
    if P0.shape != (N_CORE, N_CORE):
        raise ValueError(f"P0 is {P0.shape[0]}x{P0.shape[1]}; the error state has {n} "
                         f"states ({N_CORE} and {', '.join(layout.names) or 'no others'})")
    units = np.array([BLOCKS[b[0]].unit for b in layout.blocks for _ in b[1]])
    out = np.zeros((n, n))
    out[:N_CORE, :N_CORE] = P0
    sd = np.maximum(layout.sigma() / units, 1e-6)
    out[N_CORE:, N_CORE:] = np.diag(sd**2)
    return out

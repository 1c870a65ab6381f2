"""What the navigator keeps: growing arrays of its inputs and of what each epoch made.

Arrays grow by doubling, so feeding a stream one sample or one measurement at a time
costs no more per item than one block: nothing is copied per epoch.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Growing:
    """A float array that grows along its first axis (capacity doubling); new capacity
    holds ``fill`` (None: left uninitialised, for arrays written before they are read)."""

    def __init__(self, shape_tail=(), fill=None, dtype=float):
        self.tail = tuple(shape_tail)
        self.fill, self.dtype = fill, dtype
        self.a = self._new(16)
        self.n = 0

    def _new(self, cap: int) -> np.ndarray:
        if self.fill is None:
            return np.empty((cap, *self.tail), dtype=self.dtype)
        return np.full((cap, *self.tail), self.fill, dtype=self.dtype)

    def _room(self, m: int) -> None:
        if self.n + m > len(self.a):
            # a quarter more than asked: the epoch or two after a block fits without
            # copying it (for fill=None, np.empty's untouched pages cost no memory)
            cap = max(2 * len(self.a), self.n + m + (self.n + m) // 4)
            a = self._new(cap)
            a[:self.n] = self.a[:self.n]
            self.a = a

    def extend(self, block) -> None:
        if not (isinstance(block, np.ndarray) and block.dtype == self.dtype
                and block.shape[1:] == self.tail):
            block = np.asarray(block, dtype=self.dtype).reshape((-1, *self.tail))
        m = len(block)
        self._room(m)
        self.a[self.n:self.n + m] = block
        self.n += m

    def grow(self, m: int) -> None:
        """``m`` more entries of the fill value (new capacity holds it already)."""
        self._room(m)
        self.n += m

    def append(self, item) -> None:
        if self.n == len(self.a):
            self._room(1)
        self.a[self.n] = item
        self.n += 1

    @property
    def view(self) -> np.ndarray:
        return self.a[:self.n]


class InnovationRecord(NamedTuple):
    """One measurement's innovation: local filter ``local``, time ``t`` [s], residual ``r``
    and covariance ``S`` of the local filter, the measurement noise ``R`` and the local's
    information share ``beta`` (its covariance is ``P / beta``, so ``beta (S - R) + R`` is
    the innovation covariance of the equivalent centralized filter), whether the
    update was applied, the rows' ``H`` (d, n; filter units) and the ``epoch`` whose
    update took it (the index of :class:`Record`'s entries); ``H`` None and ``epoch`` -1
    in a record made elsewhere (a test's, an older pickle's).  The compiled engine's
    ``r``, ``S`` and ``H`` are read-only views of its run's arrays (one run's records
    share them: a record kept keeps its run's)."""

    local: str
    t: float
    r: np.ndarray
    S: np.ndarray
    R: np.ndarray
    beta: float
    accepted: bool
    H: np.ndarray | None = None
    epoch: int = -1


class Record:
    """Per epoch (entry 0: the start): the INS state after the feedback, the fused
    covariance, the sharing factors and, with ``covariance``, the interval's transition
    and noise and the correction fed back; with ``rows``: quaternion, ENU velocity, lla
    and body rate at every IMU sample; with ``innovations``: every measurement's
    :class:`InnovationRecord`."""

    def __init__(self, n_state: int, n: int, nf: int, covariance: bool, rows: bool,
                 innovations: bool):
        self.states = Growing((n_state,))
        self.P = Growing((n, n))
        self.beta = Growing((nf,))
        self.covariance = covariance
        self.Phi = Growing((n, n)) if covariance else None
        self.Qd = Growing((n, n)) if covariance else None
        self.dx = Growing((n,)) if covariance else None
        self.rows = Growing((13,)) if rows else None
        self.innovations = [] if innovations else None

    def epoch(self, state, P, beta, Phi=None, Qd=None, dx=None) -> None:
        self.states.append(state)
        self.P.append(P)
        if beta is not None:
            self.beta.append(beta)
        if self.covariance:
            n = P.shape[0]
            self.Phi.append(np.zeros((n, n)) if Phi is None else Phi)
            self.Qd.append(np.zeros((n, n)) if Qd is None else Qd)
            self.dx.append(np.zeros(n) if dx is None else dx)

    def row_block(self, q, v, p, w) -> None:
        """IMU-rate rows: (m, 4), (m, 3), (m, 3), (m, 3)."""
        self.rows.extend(np.column_stack([q, v, p, w]))

    @property
    def n_epochs(self) -> int:
        return self.states.n - 1

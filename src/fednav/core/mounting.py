"""How a sensor or an IMU is mounted: the rotation from its own axes to the body frame.

A mounting is written in a system description in one of two ways:

* **axis letters** — three letters naming, for the device's x, y and z axis in turn, the
  body direction it points to: ``F``/``B`` forward/back, ``R``/``L`` right/left,
  ``U``/``D`` up/down; ``N``, ``E``, ``S``, ``W`` are read as ``F``, ``R``, ``B``, ``L`` (a
  device whose axes are named north-east-down for a vehicle facing north).  ``RFU`` is
  fednav's own body frame (no rotation); ``FRD`` is the aerospace body frame of PX4,
  NaveGo and KF-GINS; ``FLU`` the ROS one (REP-103); ``NED`` the same as ``FRD``.
* **Euler angles** — ``{euler_deg: [pitch, roll, heading]}``: the device frame's attitude
  in the body frame, in the convention of the vehicle's attitude in ENU
  (``docs/conventions.md``): ``C_s^b = euler_to_dcm([pitch, roll, heading])``.  A star
  sensor tilted 30 deg up from the nose is ``{euler_deg: [30, 0, 0]}``.

Either gives ``C_s^b`` (3 x 3, a proper rotation): a vector in the device's axes ``x_s``
is ``C_s^b x_s`` in body axes.  :func:`parse` reads both forms (one line naming the
problem for anything else); :func:`letters_of` names a rotation that is an axis
permutation by its letters (what a refusal suggests).
"""

from __future__ import annotations

import itertools

import numpy as np

from . import attitude, units

#: Body direction (right, forward, up components) of each axis letter.
_AXES = {"R": (1, 0, 0), "L": (-1, 0, 0), "F": (0, 1, 0), "B": (0, -1, 0),
         "U": (0, 0, 1), "D": (0, 0, -1)}
#: Compass letters read as body letters (a device named north-east-down faces north).
_COMPASS = {"N": "F", "E": "R", "S": "B", "W": "L"}


def from_letters(letters: str) -> np.ndarray:
    """``C_s^b`` of a mounting given as three axis letters (see the module docstring).

    Raises
    ------
    ValueError
        One line when the letters are not three known ones, repeat an axis, or make a
        left-handed frame.
    """
    s = str(letters).strip().upper()
    body = "".join(_COMPASS.get(c, c) for c in s)
    if len(body) != 3 or any(c not in _AXES for c in body):
        raise ValueError(f"'{letters}': three axis letters of F B R L U D (or N E S W), "
                         f"one per device axis x, y, z, e.g. FRD")
    M = np.array([_AXES[c] for c in body], dtype=float).T  # columns: device axes in body
    if abs(abs(np.linalg.det(M)) - 1.0) > 1e-9:
        raise ValueError(f"'{letters}': two device axes point along the same body axis")
    if np.linalg.det(M) < 0:
        raise ValueError(f"'{letters}' is a left-handed frame (no IMU or sensor has one): "
                         f"one axis letter is flipped")
    return M


def from_euler_deg(euler_deg) -> np.ndarray:
    """``C_s^b`` of a mounting given as Euler angles ``[pitch, roll, heading]`` [deg]."""
    e = np.asarray(euler_deg, dtype=float)
    if e.shape != (3,) or not np.all(np.isfinite(e)):
        raise ValueError(f"euler_deg: three finite angles [pitch, roll, heading] in "
                         f"degrees, got {euler_deg!r}")
    return attitude.euler_to_dcm(units.deg(e))


def parse(value) -> np.ndarray | None:
    """``C_s^b`` of a mounting as written in a system description: axis letters, a
    mapping ``{euler_deg: [pitch, roll, heading]}``, or None (no rotation: None)."""
    if value is None:
        return None
    if isinstance(value, str):
        return from_letters(value)
    if isinstance(value, dict) and set(value) == {"euler_deg"}:
        return from_euler_deg(value["euler_deg"])
    raise ValueError(f"a mounting is axis letters (e.g. FRD) or {{euler_deg: [pitch, roll, "
                     f"heading]}}, got {value!r}")


def validate(value):
    """``value`` unchanged when :func:`parse` reads it (a pydantic validator's body)."""
    parse(value)
    return value.upper() if isinstance(value, str) else value


def is_identity(M) -> bool:
    """Whether ``M`` (or None) is no rotation."""
    return M is None or bool(np.allclose(M, np.eye(3), atol=1e-15, rtol=0.0))


def letters_of(M) -> str | None:
    """The axis letters (body letters F B R L U D) of ``M`` when it is an axis
    permutation with signs, else None."""
    M = np.asarray(M, dtype=float)
    out = ""
    for j in range(3):
        col = np.rint(M[:, j])
        if not np.allclose(M[:, j], col, atol=1e-9):
            return None
        hit = [k for k, v in _AXES.items() if np.array_equal(col, v)]
        if not hit:
            return None
        out += hit[0]
    return out


def rotate_rows(a, R) -> np.ndarray:
    """``a @ R.T`` for rows of 3-vectors ``a`` (N, 3): each row turned by ``R``, by three
    multiply-adds (a BLAS product of a tall, thin, column-major array with a 3 x 3 one
    costs 70 ms per 100 000 rows on some kernels)."""
    a = np.asarray(a, dtype=float)
    R = np.asarray(R, dtype=float)
    return a[:, 0:1] * R[:, 0] + a[:, 1:2] * R[:, 1] + a[:, 2:3] * R[:, 2]


def proper_permutations() -> list[np.ndarray]:
    """The 24 axis-permutation rotations (every way a box can be mounted square)."""
    out = []
    for axes in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            M = np.zeros((3, 3))
            for j, (a, s) in enumerate(zip(axes, signs, strict=True)):
                M[a, j] = s
            if np.linalg.det(M) > 0:
                out.append(M)
    return out

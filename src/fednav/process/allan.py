"""Noise figures of a static IMU recording from its Allan deviation: ``fednav allan``.

The overlapping Allan deviation of every gyro [rad/s] and accelerometer [m/s^2] axis
(body right-forward-up, as :class:`~fednav.io.data.ImuData` holds them) comes from
``allantools.oadev`` on the rate data, at octave-spaced averaging times
τ = 2^k / f_s up to an eighth of the recording.  Each axis is then read as IEEE Std
952-1997 (annex C, "Allan variance method of data reduction") reads a gyro's curve,
σ²(τ) = N²/τ + (2 ln 2/π) B² + K² τ/3 for the three terms fitted here:

* **white noise** N — angle random walk [rad/√s] of a gyro, velocity random walk
  [m/s/√s] of an accelerometer: the line of slope −1/2, σ(τ) = N/√τ, read at
  τ = 1 s;
* **bias instability** B [rad/s, m/s^2]: the flat floor of the curve divided by
  √(2 ln 2/π) = 0.664 (B is the coefficient of a flicker rate noise of two-sided power
  spectral density B²/(2π f); its Allan variance is (2 ln 2/π) B² at every τ);
* **rate random walk** K [rad/s/√s, m/s^2/√s]: the line of slope +1/2,
  σ(τ) = K √(τ/3), read at τ = 3 s.

Fit rules (local slope s = d ln σ / d ln τ, central differences on the octave grid):

1. A point belongs to a line when its local slope is within :data:`SLOPE_TOL` (0.1)
   of the line's slope (0.15 for the +1/2 line, :data:`RRW_TOL`: it lies at the
   longest, noisiest averaging times); a point is *flat* when |s| ≤ 0.1, or when the
   slope changes sign between it and a neighbour and it is the flatter of the two (so
   that a narrow minimum or maximum between two octaves is never missed).
2. The **floor** is the first stretch of flat points above the −1/2 region (at a τ
   beyond the first point on the −1/2 line), unless the curve then rises (s > 0.1) to
   a later flat stretch at least 10 % higher (:data:`HUMP_RISE`) that it leaves
   downwards (s < −0.1 at some later τ, not counting the last, whose one-sided slope
   is the noisiest): that is the hump of a first-order Gauss–Markov bias (below), and
   its top is the floor — the dip before it is only where the falling white-noise line
   crosses the Gauss–Markov curve's rising side.  The floor's level is the zero-slope
   line fitted over its stretch (IEEE 952 reads the level of the flat region; for a
   V-shaped minimum that is its tip), its τ that of the stretch's lowest point (its
   highest for a hump).
3. **White noise** is fitted on the −1/2 points below the floor; **rate random walk**
   on the +1/2 points above it.  Each line is fitted with its slope fixed, by weighted
   least squares on ln σ with weights ∝ 1/τ (the number of independent averages: the
   inverse variance of ln σ).
4. A curve with no flat point (still falling at its largest τ) has no floor yet: the
   bias instability is then read at the lowest point (too high if the curve were
   exact; with the scatter of the last octaves, merely uncertain) and a warning says
   the recording is too short.  With no point on the −1/2 line (e.g. a
   low-pass-filtered or quantised output) N is read at the point closest to it, with
   a warning.

**Gauss–Markov bias for fednav's filter** (``imu:`` keys ``gyro_markov_radps`` /
``gyro_tau_s``, ``accel_markov_mps2`` / ``accel_tau_s``).  A first-order Gauss–Markov
process of steady-state σ and correlation time T_c has the Allan variance (IEEE 952
annex C, exponentially correlated noise; El-Sheimy, Hou and Niu, "Analysis and
modeling of inertial sensors using Allan variance", IEEE Trans. Instrum. Meas. 57(1),
2008), with q_c² = 2σ²/T_c its driving noise density:

    σ_A²(τ) = (q_c T_c)²/τ · [1 − T_c/(2τ) (3 − 4 e^(−τ/T_c) + e^(−2τ/T_c))]

It rises as q_c √(τ/3) for τ ≪ T_c, falls as q_c T_c / √τ for τ ≫ T_c, and peaks at
τ = 1.893 T_c (:data:`GM_PEAK_TAU`), where σ_A = 0.4365 q_c √T_c = 0.6174 σ
(:data:`GM_PEAK_ADEV`) — maximising the bracket numerically (:func:`gauss_markov_adev`;
the test checks the figures).  The snippet's Gauss–Markov bias is the one whose hump
touches the measured floor: σ = floor / 0.6174 (= 1.076 B) and T_c = τ_floor / 1.893.
The snippet takes the largest axis of each figure (and that axis's correlation time).
Conversely a Gauss–Markov bias of σ reads as B = 0.6174 σ / 0.6643 = 0.929 σ.

Limits (simulated, 2.5 h at 100 Hz, tests/test_allan.py): white noise comes out within
1 %, a flicker bias instability within ~15 %; a Gauss–Markov bias whose hump and
descent lie inside the curve (T_c up to ~1/150 of the recording) and stand out of the
white noise (N < 0.2 σ √T_c) within ~15 % in σ and a factor 1.5 in T_c (the octave
grid).  When white noise hides the hump's rising side (N ≈ 0.2–0.5 σ √T_c) σ is still
within ~30 % but the floor's τ is the dip's, and T_c comes out 2–5 times too short; a
hump beyond the curve's end (T_c longer than the recording allows) leaves only the dip,
and σ reads 1.5–3 times too low.  A longer recording is the cure for both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core import units
from ..core.atomic import clear_results, save_figure, write_json, write_text
from ..io.data import DataError, ImuData

#: √(2 ln 2 / π): the Allan-deviation floor of flicker rate noise per unit of the bias
#: instability B (IEEE Std 952-1997, annex C.1.3).
BI_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)
#: Where a first-order Gauss–Markov process's Allan deviation peaks, in correlation times.
GM_PEAK_TAU = 1.8926
#: That peak per unit of the process's steady-state σ (0.4365 per unit of q_c √T_c).
GM_PEAK_ADEV = 0.6174
#: Largest slope difference for a point to count on a line (and |slope| for flat).
SLOPE_TOL = 0.1
#: A Gauss–Markov hump stands at least this factor above the dip before it, and the
#: curve falls beyond it at least this steeply (a first-order Gauss–Markov curve's slope
#: reaches −0.1 at 2.6 T_c, −0.25 at 4.2 T_c).
HUMP_RISE = 1.1
HUMP_FALL = -SLOPE_TOL
#: Largest slope difference for a point to count on the +1/2 line (the rate random walk
#: shows at the longest, noisiest averaging times).
RRW_TOL = 0.15
#: The longest averaging time as a fraction of the recording.
MAX_TAU_FRACTION = 1.0 / 8.0
#: Static checks: mean specific force within this of standard gravity [m/s^2], mean
#: rate below this [rad/s], tilt between the first and last tenth below this [rad].
STATIC_ACCEL_TOL = 0.5
STATIC_RATE_MAX = float(units.deg(1.0))
STATIC_TILT_MAX = float(units.deg(1.0))
#: Fewest samples to make an Allan curve of (six octave taus up to the eighth).
MIN_SAMPLES = 256


def gauss_markov_adev(tau, sigma: float, tau_c: float):
    """Allan deviation of a first-order Gauss–Markov process (closed form).

    Parameters
    ----------
    tau : float or array_like
        Averaging time(s) [s].
    sigma : float
        Steady-state standard deviation of the process [unit].
    tau_c : float
        Correlation time [s].

    Returns
    -------
    numpy.ndarray
        σ_A(τ) [unit] (IEEE Std 952-1997 annex C; module docstring).
    """
    x = np.asarray(tau, dtype=float) / tau_c
    bracket = 1.0 - (3.0 - 4.0 * np.exp(-x) + np.exp(-2.0 * x)) / (2.0 * x)
    return sigma * np.sqrt(2.0 * bracket / x)


@dataclass(frozen=True)
class AxisFit:
    """The figures read off one axis's Allan curve (NaN where not found).

    Units per sensor: ``white`` [rad/√s | m/s/√s], ``bias_instability``, ``floor`` and
    ``markov_sigma`` [rad/s | m/s^2], ``rate_random_walk`` [rad/s/√s | m/s^2/√s];
    times [s].  ``*_taus_s``: the (first, last) τ each line was fitted over, None when
    it was not.
    """

    white: float
    bias_instability: float
    rate_random_walk: float
    floor: float
    tau_floor_s: float
    markov_sigma: float
    markov_tau_s: float
    floor_is_hump: bool = False
    floor_reached: bool = True
    white_taus_s: tuple[float, float] | None = None
    floor_taus_s: tuple[float, float] | None = None
    rrw_taus_s: tuple[float, float] | None = None


@dataclass
class AllanResult:
    """Allan deviations and fitted figures of a static IMU recording.

    Attributes
    ----------
    source : str
        The data's name (file).
    rate_hz, duration_s : float
        Sample rate [Hz] and length of the recording [s].
    taus_s : numpy.ndarray
        Averaging times (K,) [s].
    gyro_adev, accel_adev : numpy.ndarray
        Overlapping Allan deviation (K, 3) [rad/s], [m/s^2], columns x, y, z.
    gyro, accel : tuple of AxisFit
        The fitted figures per axis.
    mean_gyro, mean_accel : numpy.ndarray
        Mean rate [rad/s] and specific force [m/s^2] (3,).
    warnings : list of str
        Why the figures may not be what they seem (short or moving recording, no
        −1/2 region).
    """

    source: str
    rate_hz: float
    duration_s: float
    taus_s: np.ndarray
    gyro_adev: np.ndarray
    accel_adev: np.ndarray
    gyro: tuple[AxisFit, ...]
    accel: tuple[AxisFit, ...]
    mean_gyro: np.ndarray
    mean_accel: np.ndarray
    warnings: list[str] = field(default_factory=list)

    def _per_axis(self, sensor: str, name: str) -> np.ndarray:
        return np.array([getattr(f, name) for f in getattr(self, sensor)])

    @property
    def gyro_arw_rad_sqrt_s(self) -> np.ndarray:
        """Angle random walk per axis [rad/√s]."""
        return self._per_axis("gyro", "white")

    @property
    def accel_vrw_mps_sqrt_s(self) -> np.ndarray:
        """Velocity random walk per axis [m/s/√s]."""
        return self._per_axis("accel", "white")

    @property
    def gyro_bias_instability_radps(self) -> np.ndarray:
        """Gyro bias instability B per axis [rad/s] (floor / 0.664)."""
        return self._per_axis("gyro", "bias_instability")

    @property
    def accel_bias_instability_mps2(self) -> np.ndarray:
        """Accelerometer bias instability B per axis [m/s^2] (floor / 0.664)."""
        return self._per_axis("accel", "bias_instability")

    def config(self) -> dict[str, float]:
        """The ``imu:`` section of a processing config, SI keys, largest axis of each
        figure (figures not found are left out).

        Returns
        -------
        dict
            ``gyro_arw_rad_sqrt_s`` [rad/√s], ``accel_vrw_mps_sqrt_s`` [m/s/√s],
            ``gyro_markov_radps`` [rad/s] with ``gyro_tau_s`` [s],
            ``accel_markov_mps2`` [m/s^2] with ``accel_tau_s`` [s] (the Gauss–Markov
            bias whose Allan hump touches the floor, module docstring) and, where a
            +1/2 line was found, ``gyro_bias_rw_deg_h_sqrt_h`` [deg/h/√h] and
            ``accel_bias_rw_ug_sqrt_h`` [µg/√h].
        """
        out: dict[str, float] = {}

        def largest(values):
            v = np.asarray(values, dtype=float)
            return None if np.all(np.isnan(v)) else int(np.nanargmax(v))

        for sensor, white, markov, tau, rw, rw_unit in (
                ("gyro", "gyro_arw_rad_sqrt_s", "gyro_markov_radps", "gyro_tau_s",
                 "gyro_bias_rw_deg_h_sqrt_h", units.to_deg_per_h),
                ("accel", "accel_vrw_mps_sqrt_s", "accel_markov_mps2", "accel_tau_s",
                 "accel_bias_rw_ug_sqrt_h", units.to_micro_g)):
            fits = getattr(self, sensor)
            i = largest([f.white for f in fits])
            if i is not None:
                out[white] = _sig(fits[i].white)
            i = largest([f.markov_sigma for f in fits])
            if i is not None:
                out[markov] = _sig(fits[i].markov_sigma)
                out[tau] = _sig(fits[i].markov_tau_s)
            i = largest([f.rate_random_walk for f in fits])
            if i is not None:  # the bias grows by this much per √h
                out[rw] = _sig(rw_unit(fits[i].rate_random_walk) * math.sqrt(units.HOUR))
        return out

    def config_yaml(self) -> str:
        """:meth:`config` as a YAML ``imu:`` section with a comment header."""
        import yaml

        head = (f"# IMU noise figures from the Allan deviation of {self.source}\n"
                f"# ({self.duration_s:.0f} s at {self.rate_hz:.4g} Hz; fednav allan). Largest "
                f"axis of each figure; the\n# Gauss-Markov bias is the one whose Allan hump "
                f"touches the measured floor.\n")
        head += "".join(f"# warning: {w}\n" for w in self.warnings)
        lines = yaml.safe_dump({"imu": self.config()}, sort_keys=False).splitlines()
        for i, line in enumerate(lines):  # each figure also in its engineering unit
            key, _, value = line.strip().partition(": ")
            if key in _ENGINEERING:
                unit, factor = _ENGINEERING[key]
                lines[i] = f"{line}  # {float(value) * factor:.3g} {unit}"
        return head + "\n".join(lines) + "\n"

    def summary(self) -> dict:
        """JSON-ready summary: per-axis lists (x, y, z; None where not found), the curves,
        the config snippet and the warnings (SI throughout)."""
        def lst(a):
            return [_finite(v) for v in np.asarray(a, dtype=float).ravel()]

        fits = {}
        for sensor, rate, rrw in (("gyro", "radps", "radps_sqrt_s"),
                                  ("accel", "mps2", "mps2_sqrt_s")):
            for name, key in (("rate_random_walk", f"rrw_{rrw}"),
                              ("floor", f"adev_floor_{rate}"), ("tau_floor_s", "tau_floor_s"),
                              ("markov_sigma", f"markov_{rate}"), ("markov_tau_s", "tau_s")):
                fits[f"{sensor}_{key}"] = lst(self._per_axis(sensor, name))
            fits[f"{sensor}_floor_is_hump"] = [bool(f.floor_is_hump)
                                               for f in getattr(self, sensor)]
            fits[f"{sensor}_floor_reached"] = [bool(f.floor_reached)
                                               for f in getattr(self, sensor)]
        return {
            "source": self.source, "rate_hz": _finite(self.rate_hz),
            "duration_s": _finite(self.duration_s), "samples": int(
                round(self.duration_s * self.rate_hz)),
            "gyro_arw_rad_sqrt_s": lst(self.gyro_arw_rad_sqrt_s),
            "accel_vrw_mps_sqrt_s": lst(self.accel_vrw_mps_sqrt_s),
            "gyro_bias_instability_radps": lst(self.gyro_bias_instability_radps),
            "accel_bias_instability_mps2": lst(self.accel_bias_instability_mps2),
            **fits,
            "mean_gyro_radps": lst(self.mean_gyro), "mean_accel_mps2": lst(self.mean_accel),
            "config": {"imu": self.config()},
            "warnings": list(self.warnings),
            "conventions": ("overlapping Allan deviation (allantools.oadev) at octave taus; "
                            "N = sigma(1 s) on the -1/2 line, B = floor / 0.664 (IEEE Std "
                            "952-1997 annex C), K = sigma(3 s) on the +1/2 line; "
                            "Gauss-Markov sigma = floor / 0.6174, tau = tau_floor / 1.893"),
            "curves": {"tau_s": lst(self.taus_s),
                       "gyro_adev_radps": [lst(c) for c in self.gyro_adev.T],
                       "accel_adev_mps2": [lst(c) for c in self.accel_adev.T]},
        }


#: The snippet's SI keys in engineering units (for its comments): (unit, factor).
_ENGINEERING = {
    "gyro_arw_rad_sqrt_s": ("deg/sqrt(h)", 1.0 / float(units.deg_per_sqrt_h(1.0))),
    "gyro_markov_radps": ("deg/h", float(units.to_deg_per_h(1.0))),
    "accel_vrw_mps_sqrt_s": ("ug/sqrt(Hz)", float(units.to_micro_g(1.0))),
    "accel_markov_mps2": ("ug", float(units.to_micro_g(1.0))),
}


def _finite(v) -> float | None:
    """A float for JSON: None for NaN or infinity (JSON has neither)."""
    v = float(v)
    return v if math.isfinite(v) else None


def _sig(v: float) -> float:
    return float(f"{float(v):.4g}")


# ------------------------------------------------------------------------ the fits
def _line(taus, adev, idx, slope: float) -> float:
    """The value at τ = 1 s of the line of fixed ``slope`` fitted to points ``idx``
    (weighted least squares on ln σ, weights ∝ 1/τ)."""
    w = 1.0 / taus[idx]
    return float(np.exp(np.sum(w * (np.log(adev[idx]) - slope * np.log(taus[idx])))
                        / np.sum(w)))


def _runs(mask: np.ndarray) -> list[np.ndarray]:
    """The runs of consecutive True indices of ``mask``."""
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return []
    return np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)


def _span(taus, idx) -> tuple[float, float] | None:
    return None if len(idx) == 0 else (float(taus[idx[0]]), float(taus[idx[-1]]))


def fit_axis(taus, adev) -> tuple[AxisFit, list[str]]:
    """Read white noise, bias instability and rate random walk off one Allan curve.

    Parameters
    ----------
    taus : array_like
        Averaging times (K,) [s], increasing, octave-spaced (or at least log-spaced).
    adev : array_like
        Allan deviation at ``taus`` (K,) [unit].

    Returns
    -------
    AxisFit
        The figures (rules in the module docstring).
    list of str
        What went wrong (no −1/2 region, no floor), for the caller to name the axis.
    """
    taus = np.asarray(taus, dtype=float)
    adev = np.asarray(adev, dtype=float)
    ok = np.isfinite(adev) & (adev > 0)
    taus, adev = taus[ok], adev[ok]
    notes: list[str] = []
    nan = float("nan")
    if taus.size < 3:
        return AxisFit(nan, nan, nan, nan, nan, nan, nan, floor_reached=False), [
            "a constant output (or fewer than 3 averaging times): no figure read"]
    s = np.gradient(np.log(adev), np.log(taus))
    white = np.abs(s + 0.5) <= SLOPE_TOL
    rising = np.abs(s - 0.5) <= RRW_TOL
    flat = np.abs(s) <= SLOPE_TOL
    change = np.flatnonzero(np.sign(s[:-1]) * np.sign(s[1:]) < 0)
    flat[change + (np.abs(s[change + 1]) < np.abs(s[change]))] = True
    start = int(np.argmax(white)) if white.any() else 0
    flat[:start] = False
    runs = _runs(flat)

    floor_run, hump = None, False
    if runs:
        floor_run = runs[0]
        for r in runs[1:]:  # a Gauss-Markov hump after the first flat stretch?
            between = s[floor_run[-1] + 1:r[0]]
            after = s[r[-1] + 1:-1]  # (not the last point's one-sided, noisiest slope)
            top = r[np.argmax(adev[r])]
            if (between.size and between.max() > SLOPE_TOL and (after < HUMP_FALL).any()
                    and adev[top] >= HUMP_RISE * adev[floor_run].max()):
                floor_run, hump = r, True
                break
    if floor_run is not None:
        floor = _line(taus, adev, floor_run, 0.0)
        k = floor_run[np.argmax(adev[floor_run])] if hump else \
            floor_run[np.argmin(adev[floor_run])]
        tau_floor, reached = float(taus[k]), True
        below = taus < taus[floor_run[0]]
        above = taus > taus[floor_run[-1]]
    else:  # no floor: the lowest point, for want of one
        k = int(np.argmin(adev))
        floor, tau_floor, reached = float(adev[k]), float(taus[k]), False
        below = np.ones_like(white)
        above = np.zeros_like(white)
        if s[-1] < 0:
            notes.append(f"the curve is still falling at its largest tau ({taus[-1]:.4g} s): "
                         f"the recording is too short for the bias-instability minimum "
                         f"(read at the lowest point: likely too high, and uncertain)")
        else:
            notes.append("the curve has no flat part (it rises from the shortest tau: a "
                         "drift or motion dominates): bias instability read at the lowest "
                         "point")

    wi = np.flatnonzero(white & below)
    if wi.size:
        n_white = _line(taus, adev, wi, -0.5)
    else:
        cand = np.flatnonzero(below) if below.any() else np.arange(taus.size)
        j = cand[np.argmin(np.abs(s[cand] + 0.5))]
        n_white = float(adev[j] * np.sqrt(taus[j]))
        wi = np.array([j])
        notes.append(f"no -1/2 slope region (slopes {s.min():+.2f} to {s.max():+.2f}): "
                     f"white noise read at tau {taus[j]:.4g} s where the slope is "
                     f"{s[j]:+.2f}")
    ri = np.flatnonzero(rising & above)
    k_rrw = _line(taus, adev, ri, 0.5) * math.sqrt(3.0) if ri.size else nan
    fit = AxisFit(
        white=n_white, bias_instability=floor / BI_FACTOR, rate_random_walk=k_rrw,
        floor=floor, tau_floor_s=tau_floor, markov_sigma=floor / GM_PEAK_ADEV,
        markov_tau_s=tau_floor / GM_PEAK_TAU, floor_is_hump=hump, floor_reached=reached,
        white_taus_s=_span(taus, wi),
        floor_taus_s=_span(taus, floor_run) if floor_run is not None else None,
        rrw_taus_s=_span(taus, ri))
    return fit, notes


# ------------------------------------------------------------------ the computation
def octave_taus(n: int, rate_hz: float) -> np.ndarray:
    """Octave-spaced averaging times 2^k / f_s [s] up to :data:`MAX_TAU_FRACTION` of
    ``n`` samples."""
    m_max = max(1, int(n * MAX_TAU_FRACTION))
    return 2.0 ** np.arange(int(math.floor(math.log2(m_max))) + 1) / rate_hz


def _static_warnings(imu: ImuData) -> list[str]:
    """Why the recording may not be static (vectorised over the samples)."""
    out = []
    f = imu.accel.mean(axis=0)
    g = float(np.linalg.norm(f))
    if abs(g - units.G0) > STATIC_ACCEL_TOL:
        out.append(f"mean specific force {g:.3f} m/s^2 is {g - units.G0:+.3f} m/s^2 from "
                   f"standard gravity: not a static recording (or the accelerometers are "
                   f"not in m/s^2)?")
    w = imu.gyro.mean(axis=0)
    if np.max(np.abs(w)) > STATIC_RATE_MAX:
        out.append(f"mean angular rate {units.to_deg(np.abs(w)).max():.3g} deg/s on one axis: "
                   f"not a static recording (or the gyros are not in rad/s)?")
    tenth = max(1, len(imu.t) // 10)
    a, b = imu.accel[:tenth].mean(axis=0), imu.accel[-tenth:].mean(axis=0)
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    if na > 0 and nb > 0:
        tilt = float(np.arccos(np.clip(a @ b / (na * nb), -1.0, 1.0)))
        if tilt > STATIC_TILT_MAX:
            out.append(f"the gravity direction turned {units.to_deg(tilt):.2g} deg between "
                       f"the first and the last tenth of the recording: it moved")
    return out


def allan(imu: ImuData, taus=None) -> AllanResult:
    """Overlapping Allan deviation of each gyro and accelerometer axis, and its figures.

    Parameters
    ----------
    imu : ImuData
        A static recording (rates on a uniform grid, body right-forward-up; e.g.
        :func:`fednav.io.read_imu_csv`): gyro [rad/s], accelerometer [m/s^2].
    taus : array_like, optional
        Averaging times [s]; default octave-spaced up to an eighth of the recording
        (:func:`octave_taus`).  Each is rounded to a whole number of samples.

    Returns
    -------
    AllanResult
        Curves, per-axis fits (module docstring for the rules and references), the
        ``imu:`` config snippet and the warnings.

    Raises
    ------
    DataError
        A recording of fewer than :data:`MIN_SAMPLES` samples.
    """
    import allantools

    n = len(imu.t)
    if n < MIN_SAMPLES:
        raise DataError(f"{imu.source}: {n} IMU samples; an Allan deviation needs a static "
                        f"recording of at least {MIN_SAMPLES} (hours for the bias "
                        f"instability)")
    dt = imu.period()
    rate = 1.0 / dt
    if taus is None:
        taus = octave_taus(n, rate)
    taus = np.asarray(taus, dtype=float)
    m = np.unique(np.round(taus * rate).astype(np.int64))
    m = m[(m >= 1) & (m <= (n - 1) // 2)]
    if m.size == 0:
        raise DataError(f"{imu.source}: no averaging time between one sample and half the "
                        f"recording ({(n - 1) // 2 * dt:.4g} s) among those asked for")
    tau_s = m / rate
    curves = {}
    for name, data in (("gyro", imu.gyro), ("accel", imu.accel)):
        dev = np.empty((m.size, 3))
        for i in range(3):  # (allantools is vectorised over the samples)
            t_used, d, _, _ = allantools.oadev(data[:, i], rate=rate, data_type="freq",
                                               taus=tau_s)
            dev[:, i] = np.interp(tau_s, t_used, d, left=np.nan, right=np.nan) \
                if len(t_used) != m.size else d
        curves[name] = dev
    warns = _static_warnings(imu)
    fits = {}
    for name, label in (("gyro", "gyro"), ("accel", "accelerometer")):
        per, axes = [], {}
        for i, axis in enumerate("xyz"):
            fit, notes = fit_axis(tau_s, curves[name][:, i])
            per.append(fit)
            for note in notes:  # one warning per note, naming the axes it holds for
                axes.setdefault(note, []).append(axis)
        warns += [f"{label} {', '.join(a)}: {note}" for note, a in axes.items()]
        fits[name] = tuple(per)
    return AllanResult(
        source=imu.source, rate_hz=rate, duration_s=float(n * dt), taus_s=tau_s,
        gyro_adev=curves["gyro"], accel_adev=curves["accel"], gyro=fits["gyro"],
        accel=fits["accel"], mean_gyro=imu.gyro.mean(axis=0),
        mean_accel=imu.accel.mean(axis=0), warnings=warns)


# --------------------------------------------------------------------------- output
#: Display units of the plot and the table: (name, factor from SI) per sensor.
GYRO_UNITS = {"adev": ("deg/h", units.to_deg_per_h(1.0)),
              "white": ("deg/√h", 1.0 / float(units.deg_per_sqrt_h(1.0))),
              "rrw": ("deg/h/√h", units.to_deg_per_h(1.0) * math.sqrt(units.HOUR))}
ACCEL_UNITS = {"adev": ("µg", units.to_micro_g(1.0)),
               "white": ("µg/√Hz", units.to_micro_g(1.0)),
               "rrw": ("µg/√h", units.to_micro_g(1.0) * math.sqrt(units.HOUR))}
_COLOURS = ("tab:red", "tab:green", "tab:blue")


def display_rows(res: AllanResult, sensor: str) -> list[tuple[str, ...]]:
    """Rows (axis, white, bias instability, RRW, floor τ, Gauss–Markov σ, T_c) of one
    sensor in its display units (:data:`GYRO_UNITS`, :data:`ACCEL_UNITS`), '—' where
    not found."""
    u = GYRO_UNITS if sensor == "gyro" else ACCEL_UNITS

    def fmt(v, factor=1.0, mark=""):
        return "—" if not math.isfinite(v) else f"{v * factor:.3g}{mark}"

    rows = []
    for axis, f in zip("xyz", getattr(res, sensor), strict=True):
        rows.append((axis, fmt(f.white, u["white"][1]),
                     fmt(f.bias_instability, u["adev"][1], "" if f.floor_reached else "?"),
                     fmt(f.rate_random_walk, u["rrw"][1]), fmt(f.tau_floor_s),
                     fmt(f.markov_sigma, u["adev"][1]), fmt(f.markov_tau_s)))
    return rows


def allan_figure(res: AllanResult):
    """``allan.png`` as a :class:`~matplotlib.figure.Figure`: two log–log panels (gyro
    [deg/h], accelerometer [µg] against the averaging time [s]; log–log is how an Allan
    deviation is read: its slopes name the noises), a curve per IMU axis (body
    right-forward-up), the fitted −1/2, flat and +1/2 lines dashed over the stretch they
    were fitted on (and an octave beyond), the figures annotated, one legend beside the
    panels."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    fig = Figure(figsize=(13.5, 5.6), layout="constrained")
    axes = fig.subplots(1, 2)
    tau = res.taus_s
    for ax, sensor, dev, title in ((axes[0], "gyro", res.gyro_adev, "gyro"),
                                   (axes[1], "accel", res.accel_adev, "accelerometer")):
        u = GYRO_UNITS if sensor == "gyro" else ACCEL_UNITS
        k = u["adev"][1]
        text = []
        for i, (axis, f) in enumerate(zip("xyz", getattr(res, sensor), strict=True)):
            c = _COLOURS[i]
            ax.loglog(tau, dev[:, i] * k, "o-", color=c, ms=3.5, lw=1.4)
            for span, curve, (below, beyond) in (
                    (f.white_taus_s, lambda t, f=f: f.white / np.sqrt(t), (1, 8)),
                    (f.floor_taus_s, lambda t, f=f: np.full_like(t, f.floor), (2, 2)),
                    (f.rrw_taus_s, lambda t, f=f: f.rate_random_walk * np.sqrt(t / 3.0),
                     (4, 4))):
                if span is None or not np.isfinite(curve(np.ones(1))).all():
                    continue  # (each line over its stretch, and a little beyond)
                t = np.geomspace(max(tau[0], span[0] / below), min(tau[-1], span[1] * beyond),
                                 20)
                ax.loglog(t, curve(t) * k, "--", color=c, lw=1.6, alpha=0.9, zorder=3)
            _, n_, b_, k_, at, _, _ = display_rows(res, sensor)[i]
            text.append(f"{axis}: N {n_} {u['white'][0]}, B {b_} {u['adev'][0]} "
                        f"({at} s), K {k_}" + (f" {u['rrw'][0]}" if k_ != "—" else ""))
        ax.set_title(f"{title}: overlapping Allan deviation")
        ax.set_xlabel("averaging time τ [s]")
        ax.set_ylabel(f"σ(τ) [{u['adev'][0]}]")
        ax.grid(True, which="both", alpha=0.3)
        ax.text(0.02, 0.02, "\n".join(text), transform=ax.transAxes, fontsize=8,
                family="monospace", va="bottom",
                bbox={"boxstyle": "round", "fc": "white", "ec": "0.7", "alpha": 0.85})
        lo, hi = ax.get_ylim()
        ax.set_ylim(lo / 10 ** (0.45 * math.log10(hi / lo)), hi)  # room for the figures
    handles = [Line2D([], [], color=c, marker="o", ms=3.5, label=f"{a} axis ({name})")
               for a, name, c in zip("xyz", ("right", "forward", "up"), _COLOURS,
                                     strict=True)]
    handles += [Line2D([], [], color="0.3", ls="--",
                       label="fitted lines:\n−1/2 (white noise N),\nflat (B × 0.664),\n"
                             "+1/2 (rate random walk K)")]
    fig.legend(handles=handles, loc="outside right center", fontsize=9)
    fig.suptitle(f"{Path(res.source).name}: {res.duration_s:.0f} s at {res.rate_hz:.4g} Hz"
                 + (f" — {len(res.warnings)} warning(s)" if res.warnings else ""))
    return fig


def plot(res: AllanResult, path) -> Path:
    """Write :func:`allan_figure` to ``path`` (``allan.png`` of ``fednav allan``)."""
    return save_figure(allan_figure(res), path)


def write(res: AllanResult, out) -> list[Path]:
    """Write ``allan.png``, ``imu-figures.yaml`` and ``summary.json`` (last) in ``out``;
    returns their paths."""
    out = Path(out)
    clear_results(out)
    files = [plot(res, out / "allan.png"),
             write_text(out / "imu-figures.yaml", res.config_yaml())]
    s = res.summary()
    files.append(write_json(out / "summary.json", s))
    return files

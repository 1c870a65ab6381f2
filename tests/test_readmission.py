"""Issue 27, item 2: fault isolation that cannot lock out the last position source.

A filter too confident of its IMU figures isolates a sound receiver and never re-admits
it (the rover with its file's figures and ``fdi_alpha: 0.001`` drifted hundreds of km);
a receiver that jumps and stays must stay isolated.  ``filter.fdi_readmit_s`` tells the
two apart by the drift of the innovation since the isolation began
(:func:`fednav.filters.federated.lockout_step`)."""

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fednav import System
from fednav.core import earth
from fednav.filters import FederatedFilter, KalmanFilter
from fednav.filters.base import FunctionModel, FunctionProcess
from fednav.filters.federated import READMIT_ALPHA, LockoutState, drift_threshold, lockout_step
from fednav.navigator.health import readmission_warnings
from fednav.navigator.system import FilterConfig
from fednav.process import process
from fednav.process.run import prepare, solution
from fednav.sensors.registry import SENSORS
from fednav.sim.drives import car_drive

ROOT = Path(__file__).resolve().parents[1]
ROVER = ROOT.parent / "shared" / "data" / "canada-planetary"
FIGURES = ("gyro_bias_radps", "gyro_markov_radps", "gyro_arw_rad_sqrt_s", "accel_bias_mps2",
           "accel_markov_mps2", "accel_vrw_mps_sqrt_s")


# ------------------------------------------------------------------ the kernel alone
def _state(nf=2, w=6):
    st = np.zeros((nf, 3))
    st[:, 0], st[:, 2] = np.nan, np.inf
    return (st, np.zeros((nf, w)), np.zeros((nf, w, w)), np.zeros((nf, w), dtype=np.int64),
            np.array([-np.inf]))


def _thr(m, alpha=0.001):
    """The drift test's thresholds by number of rows compared, up to ``m``."""
    return np.array([np.nan] + [drift_threshold(d, alpha) for d in range(1, m + 1)])


KEYS2 = np.arange(2)


def test_kernel_waits_for_the_hold_then_needs_a_drift():
    """Nothing before ``hold`` seconds of lockout; then a residual that did not move
    (a jump that stays) is not re-admitted, one that drifted is, with the inflation that
    gives it its expected statistic."""
    pos = np.array([True, False])
    st, r0, S0, k0, tp = _state()
    S, R = np.eye(2) * 2.0, np.eye(2)
    thr = _thr(2)
    call = lambda t, r, acc=False: lockout_step(  # noqa: E731
        0, t, acc, float(r @ r / 2.0), r, S, R, KEYS2, thr,
        LockoutState(pos, 5.0, st, r0, S0, k0, tp))
    assert call(0.0, np.zeros(2), True)[0] == 0.0 and tp[0] == 0.0
    jump = np.array([40.0, 0.0])
    assert call(1.0, jump)[0] == 0.0 and st[0, 0] == 1.0  # the reference of the run
    assert call(5.9, jump + 0.5)[0] == 0.0  # within the hold
    assert call(7.0, jump + 1.0)[0] == 0.0  # a jump that stays: no drift
    s, t0 = call(8.0, jump + np.array([0.0, 30.0]))  # drifted 30 (sigma 2): the filter
    assert s > 1.0 and t0 == 1.0
    r = jump + np.array([0.0, 30.0])
    M = s * (S - R) + R
    assert r @ np.linalg.solve(M, r) == pytest.approx(2.0, rel=1e-9)  # NIS = m after
    # not a position source, or the guard off: never
    lk = LockoutState(pos, 5.0, st, r0, S0, k0, tp)
    assert lockout_step(1, 9.0, False, 1e6, r, S, R, KEYS2, thr, lk)[0] == 0.0
    assert lockout_step(0, 9.0, False, 1e6, r, S, R, KEYS2, thr,
                        lk._replace(hold=np.nan))[0] == 0.0
    assert drift_threshold(2, 0.001) == pytest.approx(-2 * np.log(READMIT_ALPHA), rel=1e-6)
    assert drift_threshold(2, 1e-9) > drift_threshold(2, 0.001)  # never looser than FDI


def test_kernel_compares_rows_by_what_they_measure():
    """A raw GNSS epoch's rows change as satellites rise and set: the drift is measured on
    the rows both epochs hold (keys: 2 prn for a pseudorange), the lockout's start kept
    when no row is left in common (the reference renewed)."""
    pos = np.array([True])
    R = np.eye(4)
    thr = _thr(4)

    def call(lk, t, keys, r):
        r = np.asarray(r, dtype=float)
        m = len(r)
        return lockout_step(0, t, False, float(r @ r / 2.0), r, 2.0 * np.eye(m), R[:m, :m],
                            np.asarray(keys, dtype=np.int64), thr, lk)

    # a fault that stays (40 m on every satellite) while satellite 1 sets and 4 rises
    lk = LockoutState(pos, 5.0, *_state(1))
    assert call(lk, 1.0, [2, 4, 6], [40.0, 40.0, 40.0])[0] == 0.0
    assert call(lk, 7.0, [4, 6, 8], [40.5, 40.0, 90.0])[0] == 0.0  # 8 is new: not compared
    assert call(lk, 8.0, [6, 8, 10], [40.0, 40.0, 40.0])[0] == 0.0
    assert call(lk, 9.0, [12, 14], [40.0, 40.0])[0] == 0.0  # nothing in common: renewed
    assert lk.state[0, 0] == 1.0 and list(lk.k0[0, :2]) == [12, 14]
    s, t0 = call(lk, 10.0, [14, 12, 16], [70.0, 70.0, 0.0])  # drifted since the renewal
    assert s > 1.0 and t0 == 1.0
    # the filter drifting (30 m on the satellites both epochs see): re-admitted at once
    lk = LockoutState(pos, 5.0, *_state(1))
    call(lk, 1.0, [2, 4, 6], [40.0, 40.0, 40.0])
    assert call(lk, 7.0, [4, 6, 8], [70.0, 70.0, 70.0])[0] > 1.0
    # rows of a position fix keep their order: the same test as before keys
    lk = LockoutState(pos, 5.0, *_state(1))
    call(lk, 1.0, [0, 1], [40.0, 0.0])
    assert call(lk, 7.0, [0, 1], [40.0, 1.0])[0] == 0.0


def test_inflation_covers_what_the_states_can_show():
    """The inflation gives the residual its expected statistic; where the filter's part
    ``A`` of ``S`` spans fewer dimensions than the rows (a raw GNSS epoch), the part of the
    statistic outside it is what it is and the rest is brought to its dimension: with
    ``A = diag(1, 0, 0)``, ``R = I`` and ``r = (10, 2, 1)``: ``100 / (s + 1) + 5 = 5 + 1``,
    ``s = 99`` (the old target, 3, no ``s`` reaches)."""
    from fednav.filters.federated import _inflation

    R = np.eye(3)
    r = np.array([10.0, 2.0, 1.0])
    s = _inflation(r, np.diag([1.0, 0.0, 0.0]) + R, R, float(r @ r))
    assert s == pytest.approx(99.0, rel=1e-9)
    s = _inflation(r, 3.0 * R, R, float(r @ r) / 3.0)  # A = 2 I: r'r / (2 s + 1) = 3
    assert s == pytest.approx((r @ r / 3.0 - 1.0) / 2.0, rel=1e-9)
    # a residual the states cannot show at all (outside A's range): no factor helps
    r = np.array([0.0, 5.0, 5.0])
    assert _inflation(r, np.diag([1.0, 0.0, 0.0]) + R, R, float(r @ r)) == 0.0


def test_kernel_readmits_the_most_consistent_source():
    pos = np.array([True, True])
    st, r0, S0, k0, tp = _state()
    S, R = np.eye(2), np.full((2, 2), np.nan)  # (R unknown: s = NIS / m)
    thr = _thr(2)
    for f, size in ((0, 10.0), (1, 3.0)):
        lockout_step(f, 0.0, False, size**2, np.array([size, 0.0]), S, R, KEYS2, thr,
                     LockoutState(pos, 5.0, st, r0, S0, k0, tp))
    r = np.array([10.0, 60.0])  # source 0 drifted, but source 1 is more consistent
    lk = LockoutState(pos, 5.0, st, r0, S0, k0, tp)
    assert lockout_step(0, 6.0, False, r @ r, r, S, R, KEYS2, thr, lk)[0] == 0.0
    r1 = np.array([3.0, 40.0])
    s, _ = lockout_step(1, 6.0, False, r1 @ r1, r1, S, R, KEYS2, thr, lk)
    assert s == pytest.approx(r1 @ r1 / 2.0)


# ---------------------------------------------- a federated filter on a toy drift
def _drift(rate, jump, readmit, seed=3):
    """A position that drifts at ``rate`` [m/s] (an INS drifting) fixed every second by a
    'gnss' local filter (sigma 1 m) with fdi_alpha 0.001 whose model claims it constant
    (process noise 1e-6 m^2/s); the fixes jump by ``jump`` [m] at 30 s and stay."""
    rng = np.random.default_rng(seed)
    proc = FunctionProcess(lambda x: x, np.eye(1), np.array([[1e-6]]))
    m = FunctionModel(lambda x: x, np.eye(1))
    fed = FederatedFilter({"gnss": KalmanFilter(np.zeros(1), np.eye(1))}, fdi_alpha=0.001,
                          fdi_readmit_s=readmit, positions=["gnss"])
    err = []
    for k in range(1, 121):
        x = rate * k
        fed.predict(proc)
        fed.update("gnss", np.array([x + rng.normal() + (jump if k >= 30 else 0.0)]), m,
                   R=np.eye(1), t=float(k))
        fed.fuse()
        err.append(fed.x[0] - x)
    return fed, np.abs(err)


def test_federated_filter_overconfident_recovers_true_fault_stays_isolated():
    over_off, e_off = _drift(0.5, 0.0, None)
    over, e = _drift(0.5, 0.0, 5.0)
    assert e_off[-1] > 30.0 and not over_off.readmissions  # locked out for good
    assert len(over.readmissions) > 2 and e[-20:].max() < 0.25 * e_off[-1]
    ep = over.readmissions[0]
    assert ep["local"] == "gnss" and ep["duration_s"] >= 5.0 and ep["inflation"] > 1.0
    assert ep["nis_per_dof"] > 10.8 and ep["nis_per_dof_after"] == pytest.approx(1.0)
    fault, _ = _drift(0.0, 40.0, 5.0)  # a consistent filter, a jump of 40 sigma
    assert not fault.readmissions
    assert all(iso for t, _, _, _, _, iso in fault.log if t >= 30.0)


def test_validation():
    with pytest.raises(ValueError, match="fdi_readmit_s"):
        FederatedFilter({"a": KalmanFilter(np.zeros(1), np.eye(1))}, fdi_readmit_s=0.0)
    with pytest.raises(ValueError):
        FilterConfig(fdi_readmit_s=-1.0)
    assert FilterConfig(fdi_readmit_s=None).fdi_readmit_s is None
    assert FilterConfig().fdi_readmit_s == 5.0
    assert sorted(k for k, s in SENSORS.items() if s.fixes_position) == ["gnss", "gnss_raw",
                                                                          "sar"]


def test_warning_names_each_episode():
    ep = {"local": "gnss", "t_start_s": 6.0, "t_s": 11.0, "duration_s": 5.0,
          "nis_per_dof": 70.5, "inflation": 58.2, "nis_per_dof_after": 1.0}
    (w,) = readmission_warnings([ep] * 7)
    assert "re-admitted the 'gnss' local filter 7 time(s)" in w
    assert "6.0..11.0 s (NIS/dof 70.5, covariance x58.2)" in w and "2 more" in w
    assert readmission_warnings([]) == []


# --------------------------------------------- the simulated drive, side by side
def _drive(case, seed=1):
    d = car_drive(seed=seed, static_s=10.0)
    imu, gnss, system = d.imu, d.gnss, d.system
    if case == "overconfident":  # the filter's IMU figures 30x too small
        figs = {n: getattr(system.imu, n) / 30.0 for n in FIGURES}
        system = system.model_copy(update={"imu": system.imu.model_copy(update=figs)})
        imu = replace(imu, errors=None)
    else:  # the receiver jumps 200 m east at 50 s and stays there
        lla = gnss.lla.copy()
        lla[gnss.t >= 50.0] = earth.move_enu(lla[gnss.t >= 50.0], np.array([200.0, 0, 0]))
        gnss = replace(gnss, lla=lla, quality={})
    return imu, gnss, d.reference, system


def _fly(imu, gnss, system, readmit, engine="auto", ftype="kf"):
    f = system.filter.model_copy(update={"fdi_alpha": 0.001, "fdi_readmit_s": readmit,
                                         "type": ftype})
    prep = prepare(imu, {"gnss": gnss}, system.model_copy(update={"filter": f}))
    opts = {} if engine == "auto" else {"engine": engine}
    out = prep.feed(prep.navigator(record_rows=True, record_covariance=True,
                                   **opts)).result()
    return out, solution(out, prep, False).forward


def _horizontal(sol, ref, after=50.0):
    m = ref.t > after
    p = np.column_stack([np.interp(ref.t[m], sol.t, sol.lla[:, j]) for j in range(3)])
    d = earth.llh_difference_enu(*p.T, *ref.lla[m].T)
    return np.hypot(d[:, 0], d[:, 1])


def test_overconfident_filter_recovers_and_a_true_fault_stays_isolated():
    """Side by side on the simulated car drive (benchmarks/readmission.py: 30 seeds,
    30/30 recovered, 0/60 true faults re-admitted)."""
    imu, gnss, ref, system = _drive("overconfident")
    out_off, sol_off = _fly(imu, gnss, system, None)
    out, sol = _fly(imu, gnss, system, FilterConfig().fdi_readmit_s)
    assert _horizontal(sol_off, ref).max() > 300.0 and not out_off.readmissions
    assert out.readmissions and _horizontal(sol, ref).max() < 3.0
    f = system.filter.model_copy(update={"fdi_alpha": 0.001})
    said = process(imu, {"gnss": gnss}, system.model_copy(update={"filter": f})).warnings
    assert [w for w in said if "re-admitted the 'gnss' local filter 1 time(s)" in w]
    imu, gnss, ref, system = _drive("jump")
    out_off, sol_off = _fly(imu, gnss, system, None)
    out, sol = _fly(imu, gnss, system, FilterConfig().fdi_readmit_s)
    assert not out.readmissions
    np.testing.assert_array_equal(sol.lla, sol_off.lla)  # the guard changed nothing
    late = [e for e in out.fdi if e[0] >= 55.0]
    assert late and all(e[5] for e in late)  # isolated to the end


@pytest.mark.parametrize("form", ["standard", "square_root"])
@pytest.mark.parametrize("ftype", ["kf", "ukf"])
def test_both_engines_readmit_alike(ftype, form):
    """The same episodes and solution from both engines, in either covariance form (the
    square-root re-admission inflates every factor by sqrt(s))."""
    imu, gnss, ref, system = _drive("overconfident", seed=2)
    system = system.model_copy(update={"filter": system.filter.model_copy(
        update={"form": form})})
    fast, sf = _fly(imu, gnss, system, 5.0, "compiled", ftype)
    slow, ss = _fly(imu, gnss, system, 5.0, "python", ftype)
    assert fast.engine == "compiled" and slow.engine == "python"
    assert len(fast.readmissions) == len(slow.readmissions) > 0
    for a, b in zip(fast.readmissions, slow.readmissions, strict=True):
        assert a["local"] == b["local"] and a["t_s"] == b["t_s"]
        assert a["inflation"] == pytest.approx(b["inflation"], rel=1e-9)
    np.testing.assert_allclose(sf.lla, ss.lla, rtol=0, atol=1e-12)
    assert [e[5] for e in fast.fdi] == [e[5] for e in slow.fdi]


@pytest.mark.skipif(not ROVER.is_dir(), reason="../shared/data not available")
def test_the_rover_with_its_files_figures_is_not_locked_out():
    """The real rover, the file's IMU figures (far too small for its vibration) and
    fdi_alpha 0.001: the GNSS was isolated from 6 s to the end (349 km off at the end);
    re-admitted, the solution stays within ~13 m of the reference."""
    from fednav.io import read_navego_gnss, read_navego_imu, read_navego_reference

    imu = read_navego_imu(ROVER / "imu_planetary.mat")
    gnss = read_navego_gnss(ROVER / "gnss_planetary.mat")
    ref = read_navego_reference(ROVER / "gnss_planetary_r.mat")
    out, sol = _fly(imu, gnss, System(), FilterConfig().fdi_readmit_s)
    h = _horizontal(sol, ref, after=0.0)
    assert h.max() < 30.0 and out.readmissions
    assert np.mean([e[5] for e in out.fdi]) < 0.5


# ------------------------------------ a raw GNSS receiver (tightly coupled), issue 41
# (the flights: benchmarks/readmission.py's tight_case)
def _tight(case, readmit, seed=1):
    if str(ROOT / "benchmarks") not in sys.path:
        sys.path.insert(0, str(ROOT / "benchmarks"))
    import readmission

    return readmission.tight_case(seed, case, readmit)


def test_an_overconfident_tight_filter_is_not_locked_out():
    """The raw GNSS is a position source the guard keeps (its satellites compared one by
    one as they rise and set, :func:`lockout_step`'s keys): without the guard the filter
    isolates every epoch from 151 s on and ends 16.8 km off; with it (three re-admissions,
    the inflation reaching only what the satellites' rows can show) its largest error is
    34 m and it ends within 1 m."""
    h_off, _, off = _tight("overconfident x30", None)
    h, _, on = _tight("overconfident x30", FilterConfig().fdi_readmit_s)
    assert not off.readmissions and h_off[-1] > 1000.0
    assert all(e[5] for e in off.fdi if e[0] > 300.0)  # locked out for good
    assert on.readmissions and all(e["local"] == "gnss_raw" for e in on.readmissions)
    assert h[-50:].max() < 5.0 and h.max() < 0.01 * h_off.max()
    assert np.mean([e[5] for e in on.fdi]) < 0.1
    assert all(np.isfinite(e["inflation"]) and e["inflation"] < 1e6 for e in on.readmissions)

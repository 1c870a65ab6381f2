"""Core speed benchmarks (run by hand: ``python benchmarks/bench_core.py``).

Speeds are reported as absolute times *and* as ratios against baselines measured in the
same run (FilterPy's UKF; a pure-numpy loop), never asserted in tests.
"""

from __future__ import annotations

import subprocess
import sys
import time

import numpy as np


def best_of(fn, repeat=5, number=1):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter() - t0) / number)
    return best


def bench_strapdown():
    from fednav.ins.strapdown import Strapdown
    from fednav.scenarios import paper002

    tr = paper002.load_scenario().trajectory()
    code = ("import time; t0=time.perf_counter(); import numpy as np;"
            "from fednav.ins.strapdown import Strapdown; t1=time.perf_counter();"
            "s=Strapdown([0.6,2.0,0.0],[0,0,0],[0,0,0],0.01);"
            "s.run(np.zeros((10,3)),np.zeros((10,3)));"
            "print(t1-t0, time.perf_counter()-t1)")
    imp, first = map(float, subprocess.run([sys.executable, "-c", code], capture_output=True,
                                           text=True, check=True).stdout.split())

    def run():
        Strapdown(tr.lla[0], tr.vel[0], tr.euler[0], tr.dt).run(tr.dtheta, tr.dv, record=False)

    t = best_of(run, 5)
    n = len(tr.dtheta)
    print(f"strapdown: {t / n * 1e6:.3f} us/sample warm ({n} samples in {t * 1e3:.1f} ms); "
          f"fresh process: import {imp:.2f} s, first call {first:.3f} s (numba cache)")


def bench_transition():
    """The nonlinear 18-state error transition over one 1 s filter interval (paper 002's
    nominal), per point, called from compiled code as the closed loop calls it: all points
    in one call (one column per point) against the same points one call each."""
    import numba

    from fednav.core import units
    from fednav.ins import error_model as em

    @numba.njit
    def together(X, T, nsub, par, C, scale, reps):
        for _ in range(reps):
            em.propagate_points(X, T, nsub, par, C, scale)

    @numba.njit
    def one_each(X, T, nsub, par, C, scale, reps):
        for _ in range(reps):
            for i in range(X.shape[0]):
                em.propagate_points(X[i:i + 1], T, nsub, par, C, scale)

    nom = em.Nominal(lat=units.deg(39.0), h=5000.0, vel=np.array([283.0, 282.0, 15.0]),
                     C=np.eye(3), fn=np.array([0.3, -0.2, 9.8]))
    p = em.ErrorProcess(nom, 1.0, em.ImuNoiseModel(gyro_markov_tau=1800.0), nsub=2)
    rng = np.random.default_rng(1)
    for n_pts in (37, 721):  # UKF sigma points, level-3 sparse grid (n = 18)
        X = rng.normal(size=(n_pts, em.N_STATES))
        args = (X, p.T, p.nsub, p._params, p._C0, em.SCALE)
        reps = 40000 // n_pts
        t_all = best_of(lambda a=args, r=reps: together(*a, r), 5) / reps
        t_one = best_of(lambda a=args, r=reps: one_each(*a, r), 5) / reps
        print(f"error transition, {n_pts:3d} points: {t_all / n_pts * 1e9:.0f} ns/point "
              f"together, {t_one / n_pts * 1e9:.0f} ns/point one call each "
              f"(x{t_one / t_all:.1f})")


def toy_models(n, m, seed, linear_h=None):
    """A batched nonlinear process, a linear measurement, and FilterPy's UKF on the same
    problem with the same sigma-point settings (alpha 1e-3, beta 2, kappa 0)."""
    from filterpy.kalman import MerweScaledSigmaPoints
    from filterpy.kalman import UnscentedKalmanFilter as FPUKF

    from fednav.filters import LinearModel

    rng = np.random.default_rng(seed)
    A = np.eye(n) + 0.01 * rng.standard_normal((n, n))
    H = linear_h if linear_h is not None else rng.standard_normal((m, n))
    Q, R = 1e-3 * np.eye(n), 1e-2 * np.eye(m)
    z = rng.standard_normal(m)

    class Proc:  # batched nonlinear process, as fednav's error model provides
        Phi, Qd = A, Q

        @staticmethod
        def transition(X):
            return X @ A.T + 1e-3 * np.sin(X)

    ref = FPUKF(dim_x=n, dim_z=m, dt=1.0, hx=lambda x: H @ x,
                fx=lambda x, dt: A @ x + 1e-3 * np.sin(x),
                points=MerweScaledSigmaPoints(n, alpha=1e-3, beta=2.0, kappa=0.0))
    ref.Q, ref.R = Q, R

    def step_ref():
        ref.predict()
        ref.update(z)

    return A, H, Q, R, z, Proc, LinearModel(H), step_ref


def bench_ukf(n=16, m=3):
    from fednav.filters import FunctionModel, FunctionProcess, UnscentedKalmanFilter

    A, H, Q, R, z, Proc, Model, step_ref = toy_models(n, m, 0)
    ours = UnscentedKalmanFilter(np.zeros(n), np.eye(n), alpha=1e-3)

    def step_ours():
        ours.predict(Proc)
        ours.update(z, Model, R=R)

    # Per-point Python callbacks (FunctionProcess) for an apples-to-apples comparison too.
    ours_cb = UnscentedKalmanFilter(np.zeros(n), np.eye(n), alpha=1e-3)
    proc_cb = FunctionProcess(lambda x: A @ x + 1e-3 * np.sin(x), A, Q)
    model_cb = FunctionModel(lambda x: H @ x, H)

    def step_cb():
        ours_cb.predict(proc_cb)
        ours_cb.update(z, model_cb, R=R)

    t_ours = best_of(step_ours, 5, 200)
    t_cb = best_of(step_cb, 5, 200)
    t_ref = best_of(step_ref, 5, 200)
    print(f"UKF predict+update, n={n}: fednav batched {t_ours * 1e6:.0f} us, fednav with "
          f"per-point callbacks {t_cb * 1e6:.0f} us, FilterPy {t_ref * 1e6:.0f} us -> "
          f"speed-up x{t_ref / t_ours:.1f} (batched), x{t_ref / t_cb:.1f} (callbacks)")


def bench_quadrature(n=18, m=3):
    """UKF / SGHQF / AASGHQF at paper 002's dimension (fednav's 18 states): points, time per
    cycle (predict + update) batched, and the same filters written FilterPy-style (the
    process and measurement functions called point by point from Python, the moments with
    NumPy; the same Sage-Husa step for AASGHQF) — FilterPy itself for the UKF — in the
    same run."""
    from fednav.filters import (
        AdaptiveSparseGridFilter,
        SparseGridFilter,
        UnscentedKalmanFilter,
    )

    A, H, Q, R, z, Proc, Model, step_ref = toy_models(n, m, 2)
    def fx(x):
        return A @ x + 1e-3 * np.sin(x)

    def per_point(grid, W, adaptive=False):
        from fednav.filters.adaptive import _SageHusa

        x, P = np.zeros(n), np.eye(n)
        sh = _SageHusa()

        def step():
            nonlocal x, P
            L = np.linalg.cholesky(P)
            Y = np.array([fx(x + L @ g) for g in grid])           # one call per point
            x = W @ Y
            D = Y - x
            P = (D * W[:, None]).T @ D + Q
            L = np.linalg.cholesky(P)
            X = np.array([x + L @ g for g in grid])
            Z = np.array([H @ p for p in X])                      # one call per point
            zh = W @ Z
            dZ, dX = Z - zh, X - x
            Ra = sh.adapt("z", R, z - zh, (dZ * W[:, None]).T @ dZ) if adaptive else R
            S = (dZ * W[:, None]).T @ dZ + Ra
            K = np.linalg.solve(S, ((dX * W[:, None]).T @ dZ).T).T
            x = x + K @ (z - zh)
            P = P - K @ S @ K.T
        return step

    rows = []
    for name, f in (("UKF", UnscentedKalmanFilter(np.zeros(n), np.eye(n), alpha=1e-3)),
                    ("SGHQF", SparseGridFilter(np.zeros(n), np.eye(n), level=3)),
                    ("AASGHQF", AdaptiveSparseGridFilter(np.zeros(n), np.eye(n), level=3))):
        def step(f=f):
            f.predict(Proc)
            f.update(z, Model, R=R)
            f.x, f.P = np.zeros(n), np.eye(n)  # keep the toy problem at its start
        t = best_of(step, 5, 50)
        npts = 2 * n + 1 if name == "UKF" else f.n_points
        if name == "UKF":
            t_ref = best_of(step_ref, 5, 50)
            ref = "FilterPy"
        else:
            t_ref = best_of(per_point(f.grid, f.Wm, name == "AASGHQF"), 3, 5)
            ref = "per-point loop"
        rows.append((name, npts, t, t_ref, ref))
    for name, npts, t, t_ref, ref in rows:
        print(f"{name:8s} n={n}: {npts:4d} points, {t * 1e3:6.2f} ms per cycle batched; "
              f"{ref} {t_ref * 1e3:7.2f} ms -> x{t_ref / t:.1f}")


def bench_simplified_ukf(n=15, m=6):
    """Paper 003's simplified UKF (linear measurement update) vs the full UKF and FilterPy,
    at the paper's augmented dimension (15) with a 6-component linear GNSS measurement."""
    from fednav.filters import SimplifiedUKF, UnscentedKalmanFilter

    Hs = np.zeros((m, n))
    Hs[np.arange(m), np.arange(m)] = 1.0
    A, H, Q, R, z, Proc, Model, step_ref = toy_models(n, m, 1, linear_h=Hs)

    def stepper(f):
        def step():
            f.predict(Proc)
            f.update(z, Model, R=R)
        return step

    t_s = best_of(stepper(SimplifiedUKF(np.zeros(n), np.eye(n))), 5, 300)
    t_f = best_of(stepper(UnscentedKalmanFilter(np.zeros(n), np.eye(n))), 5, 300)
    t_r = best_of(step_ref, 5, 100)
    print(f"simplified UKF predict+update, n={n}, m={m}: {t_s * 1e6:.0f} us; full UKF "
          f"{t_f * 1e6:.0f} us (x{t_f / t_s:.2f}); FilterPy {t_r * 1e6:.0f} us "
          f"(x{t_r / t_s:.1f})")


def _time_modes(paper, modes: dict[str, tuple]):
    """Best-of-3 warm wall time of each (aiding, filter type) mode of ``paper``, and of the
    free SINS on the same loop (the baseline)."""
    from fednav.sim.runs import make_run_data, run_mode

    scn = paper.load_scenario()
    data = make_run_data(scn, 1)
    out = {}
    for name, (aid, ft) in {**modes, "SINS": ([], None)}.items():
        run_mode(scn, aid, data, filter_type=ft)  # warm
        out[name] = best_of(lambda aid=aid, ft=ft: run_mode(scn, aid, data, filter_type=ft), 3)
    return out


def bench_full_run():
    from fednav.scenarios import paper002

    t = _time_modes(paper002, {"CNS/SAR": (["star", "sar"], None)})
    print(f"paper-002 SINS/CNS/SAR 1200 s run (120 000 IMU samples, 1200 cycles, two local "
          f"UKFs + master): {t['CNS/SAR']:.2f} s warm; free SINS on the same loop "
          f"{t['SINS']:.2f} s (filter share x{t['CNS/SAR'] / t['SINS']:.1f})")


def bench_paper003_run():
    from fednav.scenarios import paper003

    aid = ["gnss", "star"]
    t = _time_modes(paper003, {"FUKF": (aid, "total-ukf"), "FKF": (aid, "kf")})
    print(f"paper-003 3600 s federated run (180 000 IMU samples, 3600 cycles): FUKF "
          f"{t['FUKF']:.2f} s, FKF {t['FKF']:.2f} s warm; free SINS on the same loop "
          f"{t['SINS']:.2f} s (FUKF x{t['FUKF'] / t['SINS']:.1f})")


if __name__ == "__main__":
    bench_strapdown()
    bench_transition()
    bench_ukf()
    bench_quadrature()
    bench_simplified_ukf()
    bench_full_run()
    bench_paper003_run()

"""Paper-001 speed benchmark (run by hand: ``python benchmarks/bench_pf.py``).

Reports, in one run and on one core (BLAS limited to one thread):

* the LI strapdown per IMU sample over the 500 s ascent;
* the federated EKF per 500 s run;
* the federated PF (1000 particles per local filter) per run, compiled as shipped, beside
  a straightforward NumPy-vectorised version of the same PF — the particle transition, the
  star-sensor likelihood and the systematic resampling written with whole-array NumPy
  operations over the particles (the weighted moments and the Gaussian draws are NumPy in
  both) — on the same data and random numbers
  (the two give the same navigation result, checked here), and their ratio.
"""

from __future__ import annotations

import time

import numpy as np
from threadpoolctl import threadpool_limits

from fednav.core import attitude, earth
from fednav.filters import particle
from fednav.launch import errors, navigate
from fednav.launch.frame import J2, J4
from fednav.launch.strapdown import LaunchStrapdown
from fednav.scenarios import paper001


# --- the NumPy-vectorised reference of the compiled kernels ------------------------------
def _rv2q(r):
    a = np.linalg.norm(r, axis=1, keepdims=True)
    small = a < 1e-6
    k = np.where(small, 0.5 - a * a / 48.0, np.sin(0.5 * a) / np.where(small, 1.0, a))
    c = np.where(small, 1.0 - a * a / 8.0, np.cos(0.5 * a))
    return np.concatenate([c, k * r], axis=1)


def _qmul(p, q):
    return attitude.quat_mul(p, q)


def _q2rv(q):
    return attitude.quat_to_rotvec(q)


def _grav_li(r, r0, Ce, degree):
    e = r0 + r @ Ce.T
    rr = np.linalg.norm(e, axis=1, keepdims=True)
    u = e / rr
    s = u[:, 2:3]
    mu, A = earth.GM, earth.A
    g = -mu / rr**2 * u
    ar = A / rr
    P2, dP2 = 0.5 * (3 * s * s - 1), 3 * s
    c2 = -mu * J2 * ar**2 / rr**2
    ez = np.array([0.0, 0.0, 1.0])
    g = g + c2 * ((-dP2 * s - 3 * P2) * u + dP2 * ez)
    if degree >= 4:
        P4 = (35 * s**4 - 30 * s**2 + 3) / 8
        dP4 = (35 * s**3 - 15 * s) / 2
        c4 = -mu * J4 * ar**4 / rr**2
        g = g + c4 * ((-dP4 * s - 5 * P4) * u + dP4 * ez)
    return g @ Ce


def transition_numpy(X, S, C, dvli, dsli, r_mid, T, r0, Ce, degree):
    eps = X[:, 9:12] * S[9:12]
    u = T * eps @ C.T
    qa = _rv2q(-X[:, 0:3] * S[0:3])
    p1 = _q2rv(_qmul(_rv2q(u), qa))
    Em = attitude.quat_to_dcm(_qmul(_rv2q(0.5 * u), qa))
    f = T * (X[:, 12:15] * S[12:15]) @ C.T
    k = dvli - np.einsum("nji,nj->ni", Em, dvli - f)
    s = dsli - np.einsum("nji,nj->ni", Em, dsli - 0.5 * T * f)
    dg = _grav_li(r_mid[None], r0, Ce, degree) - _grav_li(
        r_mid - X[:, 3:6] - 0.5 * T * X[:, 6:9], r0, Ce, degree)
    out = X.copy()
    out[:, 6:9] = X[:, 6:9] + k + dg * T
    out[:, 3:6] = X[:, 3:6] + T * X[:, 6:9] + s + 0.5 * T * T * dg
    out[:, 0:3] = -p1 / S[0:3]
    return out


def star_loglik_numpy(y, X, S, Rinv):
    qy = _rv2q((-y * S[0:3])[None])
    r = _q2rv(_qmul(_rv2q(X[:, 0:3] * S[0:3]), qy)) / S[0:3]
    return -0.5 * np.einsum("ni,ij,nj->n", r, Rinv, r)


def resample_numpy(w, u0):
    n = len(w)
    c = np.cumsum(w)
    c[-1] = 1.0
    return np.minimum(np.searchsorted(c, (u0 + np.arange(n)) / n), n - 1)


class _NumpyKernels:
    """Swap the compiled kernels for the NumPy ones (restored on exit)."""

    def __enter__(self):
        self.saved = (errors._transition, errors._star_loglik, particle.systematic_resample)
        errors._transition = transition_numpy
        errors._star_loglik = star_loglik_numpy
        particle.systematic_resample = resample_numpy
        return self

    def __exit__(self, *a):
        errors._transition, errors._star_loglik, particle.systematic_resample = self.saved


def best_of(fn, repeat=3):
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main() -> None:
    threadpool_limits(1)
    scn = paper001.load_scenario()
    tr = scn.trajectory()
    data = navigate.make_data(scn, 1)

    def ins():
        s = LaunchStrapdown(tr.frame, attitude.dcm_to_quat(tr.C[0]), tr.v[0], tr.r[0], tr.dt)
        s.interval(tr.dtheta, tr.dv)

    ins()
    t_ins, _ = best_of(ins, 5)
    print(f"LI strapdown: {1e6 * t_ins / len(tr.dv):.3f} us per IMU sample "
          f"({len(tr.dv)} samples, {t_ins * 1e3:.1f} ms)")
    navigate.run(scn, data, "ekf")
    t_ekf, _ = best_of(lambda: navigate.run(scn, data, "ekf"))
    print(f"federated EKF, 500 s flight: {t_ekf:.3f} s per run")
    navigate.run(scn, data, "pf")
    t_pf, r_pf = best_of(lambda: navigate.run(scn, data, "pf"))
    with _NumpyKernels():
        t_np, r_np = best_of(lambda: navigate.run(scn, data, "pf"))
    same = max(abs(a - b) for a, b in zip(r_pf.rms().values(), r_np.rms().values(),
                                             strict=True))
    print(f"federated PF, 1000 particles per local filter, 500 s flight: compiled "
          f"{t_pf:.3f} s per run, NumPy-vectorised {t_np:.3f} s -> x{t_np / t_pf:.1f} "
          f"(largest difference of the nine RMS figures: {same:.2g})")
    # Kernel by kernel, 1000 particles (what compiling buys where it applies; the rest of
    # a cycle is Gaussian draws and small products that both versions share).
    rng = np.random.default_rng(0)
    X = rng.standard_normal((1000, 15)) * np.array([60.0] * 3 + [10.0] * 3 + [0.1] * 3
                                                   + [0.2] * 3 + [0.1] * 3)
    k0 = 10000
    ins2 = LaunchStrapdown(tr.frame, attitude.dcm_to_quat(tr.C[k0]), tr.v[k0], tr.r[k0],
                           tr.dt)
    aux = ins2.interval(tr.dtheta[k0:k0 + 50], tr.dv[k0:k0 + 50])
    proc = errors.LaunchProcess(tr.frame, aux, 1.0, navigate._noise(scn))
    args = (X, errors.SCALE, proc.C, proc.dvli, proc.dsli, proc.r_mid, 1.0, *proc._consts)
    y, Rinv = np.array([10.0, -5.0, 3.0]), np.eye(3) / 21.0**2
    w = rng.random(1000)
    w /= w.sum()
    rows = [("particle transition", lambda: errors._transition(*args),
             lambda: transition_numpy(*args)),
            ("star likelihood", lambda: errors._star_loglik(y, X, errors.SCALE, Rinv),
             lambda: star_loglik_numpy(y, X, errors.SCALE, Rinv)),
            ("systematic resampling", lambda: particle.systematic_resample(w, 0.3),
             lambda: resample_numpy(w, 0.3)),
            ("1000 x 15 Gaussian draws", lambda: rng.standard_normal((1000, 15)), None)]
    assert np.allclose(errors._transition(*args), transition_numpy(*args), atol=1e-9)
    for name, fc, fn in rows:
        tc, _ = best_of(lambda fc=fc: [fc() for _ in range(200)], 3)
        if fn is None:
            print(f"  {name:26s} {tc / 200 * 1e6:8.1f} us (shared by both versions)")
            continue
        tn, _ = best_of(lambda fn=fn: [fn() for _ in range(200)], 3)
        print(f"  {name:26s} compiled {tc / 200 * 1e6:8.1f} us, NumPy {tn / 200 * 1e6:8.1f} us"
              f" -> x{tn / tc:.1f}")


if __name__ == "__main__":
    main()

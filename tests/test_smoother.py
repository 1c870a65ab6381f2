"""RTS smoother of the closed-loop error-state filter equals the textbook RTS smoother."""

import numpy as np

from fednav.filters.smoother import rts_errors


def test_closed_loop_rts_equals_open_loop_rts():
    rng = np.random.default_rng(0)
    n, N = 3, 60
    Phi = np.array([[1, 0.1, 0], [0, 1, 0.1], [0, 0, 0.98]])
    Q = np.diag([1e-4, 1e-3, 1e-2])
    H = np.array([[1.0, 0, 0]])
    R = np.array([[0.5]])
    x = np.zeros(n)
    ys = []
    for k in range(N + 1):
        if k > 0:
            x = Phi @ x + rng.multivariate_normal(np.zeros(n), Q)
        ys.append(H @ x + rng.normal(0, np.sqrt(R[0, 0]), 1))
    measured = [k % 3 == 0 for k in range(N + 1)]  # epochs without measurements too

    def kf_step(m, P, k):
        if k > 0:
            m, P = Phi @ m, Phi @ P @ Phi.T + Q
        mp, Pp = m, P
        if measured[k]:
            K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
            m, P = m + K @ (ys[k] - H @ m), (np.eye(n) - K @ H) @ P
        return mp, Pp, m, P

    # open loop + textbook RTS
    m, P = np.zeros(n), np.eye(n)
    prior, post = [], []
    for k in range(N + 1):
        mp, Pp, m, P = kf_step(m, P, k)
        prior.append((mp, Pp))
        post.append((m, P))
    sm = [post[-1][0]]
    Ps_ref = [post[-1][1]]
    for k in range(N - 1, -1, -1):
        A = post[k][1] @ Phi.T @ np.linalg.inv(prior[k + 1][1])
        sm.insert(0, post[k][0] + A @ (sm[0] - prior[k + 1][0]))
        Ps_ref.insert(0, post[k][1] + A @ (Ps_ref[0] - prior[k + 1][1]) @ A.T)
    # closed loop: the "navigation" carries the estimate, the filter estimates its error
    nav, P = np.zeros(n), np.eye(n)
    navs, Ppost, dxs = [], [], []
    for k in range(N + 1):
        if k > 0:
            nav, P = Phi @ nav, Phi @ P @ Phi.T + Q
        dx = np.zeros(n)
        if measured[k]:
            K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
            dx = K @ (H @ nav - ys[k])
            P = (np.eye(n) - K @ H) @ P
        nav = nav - dx
        navs.append(nav)
        Ppost.append(P)
        dxs.append(dx)
    e, Ps = rts_errors(np.array(Ppost), np.repeat(Phi[None], N + 1, 0),
                       np.repeat(Q[None], N + 1, 0), np.array(dxs))
    np.testing.assert_allclose(np.array(navs) - e, np.array(sm), atol=1e-12)
    np.testing.assert_allclose(Ps, np.array(Ps_ref), atol=1e-12)
    # smoothing never increases the variance
    assert np.all(np.diagonal(Ps, axis1=1, axis2=2) <= np.diagonal(np.array(Ppost), axis1=1,
                                                                    axis2=2) + 1e-12)

"""IMU process noise identified from the recording (fednav.process.identify)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fednav.filters.smoother import noise_moments

ROOT = Path(__file__).resolve().parents[1]


def _closed_loop_cv(q_true, q_model, r, n=4000, T=0.1, seed=3):
    """A constant-velocity track, its position measured, flown by a closed-loop error
    filter written here (not fednav's): what fednav's navigator records."""
    rng = np.random.default_rng(seed)
    Phi = np.array([[1.0, T], [0.0, 1.0]])
    unit = np.array([[T**3 / 3, T**2 / 2], [T**2 / 2, T]])
    L = np.linalg.cholesky(q_true * unit)
    x = np.zeros(2)
    xh = np.zeros(2)
    P = np.eye(2)
    H = np.array([[1.0, 0.0]])
    Ps, Phis, Qs, dxs = [P.copy()], [Phi], [q_model * unit], [np.zeros(2)]
    for _ in range(n):
        x = Phi @ x + L @ rng.standard_normal(2)
        xh = Phi @ xh
        P = Phi @ P @ Phi.T + q_model * unit
        z = x[0] + np.sqrt(r) * rng.standard_normal()
        S = H @ P @ H.T + r
        K = P @ H.T / S
        err = (K * (H @ xh - z)).ravel()  # the error estimate (computed minus true)
        xh = xh - err                     # fed back
        P = (np.eye(2) - K @ H) @ P
        Ps.append(P.copy())
        Phis.append(Phi)
        Qs.append(q_model * unit)
        dxs.append(err)
    return np.array(Ps), np.array(Phis), np.array(Qs), np.array(dxs)


def test_the_smoother_moments_put_the_noise_where_it_is():
    """Shumway–Stoffer's E-step through noise_moments: the mean of tr(Q^-1 W) / m is
    above 1 for a process noise 10x too small, below 1 for one 10x too large, and 1 at
    the true one (EM's fixed point), for a closed-loop filter and data written in the
    test, not fednav's simulator."""
    from scipy.optimize import brentq

    q_true, r = 0.5, 0.04

    def gap(log_q):
        P, Phi, Q, dx = _closed_loop_cv(q_true, float(np.exp(log_q)), r)
        W = noise_moments(P, Phi, Q, dx)
        return float(np.log(np.mean(np.trace(np.linalg.solve(Q[1:], W), axis1=1,
                                             axis2=2) / 2)))

    lo, hi = np.log(q_true / 10), np.log(q_true * 10)
    assert gap(lo) > 0 > gap(hi)
    q = float(np.exp(brentq(gap, lo, hi, xtol=1e-3)))
    assert q == pytest.approx(q_true, rel=0.1)


def _closed_loop_position(q, r_true, r_model, n=4000, T=0.1, seed=5, every=1):
    """A constant-velocity track, its position measured with noise ``r_true``, flown by
    a closed-loop error filter written here that believes ``r_model``: what fednav's
    navigator records (covariances, transitions, corrections, and each measurement's
    innovation record with its ``H`` and epoch)."""
    from types import SimpleNamespace

    from fednav.navigator.record import InnovationRecord

    rng = np.random.default_rng(seed)
    Phi = np.array([[1.0, T], [0.0, 1.0]])
    Q = q * np.array([[T**3 / 3, T**2 / 2], [T**2 / 2, T]])
    L = np.linalg.cholesky(Q)
    H = np.array([[1.0, 0.0]])
    x, xh, P = np.zeros(2), np.zeros(2), np.eye(2)
    Ps, Phis, Qs, dxs, inns = [P.copy()], [Phi], [Q], [np.zeros(2)], []
    for k in range(1, n + 1):
        x = Phi @ x + L @ rng.standard_normal(2)
        xh = Phi @ xh
        P = Phi @ P @ Phi.T + Q
        if k % every:  # (no measurement: nothing fed back)
            Ps.append(P.copy())
            Phis.append(Phi)
            Qs.append(Q)
            dxs.append(np.zeros(2))
            continue
        # innovation against the prediction: H times its error (computed minus true)
        nu = H @ xh - (x[0] + np.sqrt(r_true) * rng.standard_normal())
        S = H @ P @ H.T + r_model
        K = P @ H.T / S
        err = (K @ nu).ravel()
        xh = xh - err
        P = (np.eye(2) - K @ H) @ P
        Ps.append(P.copy())
        Phis.append(Phi)
        Qs.append(Q)
        dxs.append(err)
        inns.append(InnovationRecord("pos", k * T, nu, S, np.array([[r_model]]), 1.0,
                                     True, H, k))
    return SimpleNamespace(P=np.array(Ps), Phi=np.array(Phis), Qd=np.array(Qs),
                           dx=np.array(dxs), innovations=inns, t=T * np.arange(n + 1))


def test_the_smoothed_measurement_noise_is_where_it_is():
    """EM's M-step for R (sigma_factors) on a closed-loop filter and data written in the
    test: the variance factor is above 1 for a sigma 10x too small, below 1 for one 10x
    too large, and its fixed point is the true R."""
    from scipy.optimize import brentq

    from fednav.filters.smoother import rts_smooth
    from fednav.process.identify import SigmaPart, sigma_factors

    q, r_true = 0.5, 0.04
    parts = {"sensors.pos.sigma_m": SigmaPart("pos", 0, (0,), 1.0)}

    def gap(log_r):
        res = _closed_loop_position(q, r_true, float(np.exp(log_r)))
        sm = rts_smooth(res.P, res.Phi, res.Qd, res.dx)
        f = sigma_factors(res, sm, parts, lambda t: np.ones(len(t), dtype=bool))
        return float(np.log(f["sensors.pos.sigma_m"]))

    lo, hi = np.log(r_true / 100), np.log(r_true * 100)
    assert gap(lo) > 0 > gap(hi)
    r = float(np.exp(brentq(gap, lo, hi, xtol=1e-3)))
    assert r == pytest.approx(r_true, rel=0.1)


def test_the_folded_chain_smooths_as_the_whole_one():
    """EM runs on the chain folded to the epochs that took a measurement (a 10 Hz filter
    under fixes every 0.5 s: a fifth of the epochs): its smoothed errors and covariances
    at those epochs are the whole chain's, to rounding."""
    from fednav.filters.smoother import rts_smooth
    from fednav.process.identify import folded

    res = _closed_loop_position(0.5, 0.04, 0.04, n=2000, every=5)
    chain = folded(res)
    assert len(chain.epochs) == 2000 // 5 + 1 and chain.epochs[-1] == 2000
    e, Ps, _ = rts_smooth(res.P, res.Phi, res.Qd, res.dx)
    ef, Psf, _ = rts_smooth(chain.P, chain.Phi, chain.Qd, chain.dx)
    np.testing.assert_allclose(ef, e[chain.epochs], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(Psf, Ps[chain.epochs], rtol=1e-9, atol=1e-15)


def test_a_chain_measured_every_epoch_folds_to_itself():
    """Where every epoch took a measurement (fixes at the filter's rate) the folded chain
    is the recorded one: the short cut gives what the composition gives."""
    from fednav.process.identify import fold

    rng = np.random.default_rng(1)
    N, n = 40, 6
    Phi = np.eye(n) + 0.1 * rng.standard_normal((N + 1, n, n))
    M = rng.standard_normal((N + 1, 2, n, n))
    A, acc = fold(Phi, M, np.arange(1, N + 1))
    np.testing.assert_array_equal(A[1:], Phi[1:])
    np.testing.assert_array_equal(acc[1:], M[1:])
    assert not A[0].any() and not acc[0].any()  # (entry 0 unused: zero, as composed)
    assert not np.shares_memory(A, Phi) and not np.shares_memory(acc, M)
    # the general composition (a last group of two intervals forces it) on the others
    A2, acc2 = fold(Phi, M, np.r_[np.arange(1, N - 1), N])
    np.testing.assert_allclose(A2[:N - 1], A[:N - 1], rtol=0, atol=1e-15)
    np.testing.assert_allclose(acc2[:N - 1], acc[:N - 1], rtol=0, atol=1e-15)
    np.testing.assert_allclose(A2[N - 1], Phi[N] @ Phi[N - 1], rtol=1e-12)


def test_each_figures_folded_part_is_its_intervals_carried_to_the_end():
    """noise_parts (rank-3 terms carried back from each group's end, the driven rows
    only) equals each interval's whole discrete part (the filter's trapezoid) folded
    with the whole transitions (fold), on random transitions and groups."""
    from types import SimpleNamespace

    from fednav.ins.error_model import SCALE
    from fednav.process import identify as ident

    rng = np.random.default_rng(0)
    N, n = 60, 21
    Phi = np.eye(n) + 0.05 * rng.standard_normal((N + 1, n, n))
    t = np.cumsum(np.r_[0.0, rng.uniform(0.04, 0.06, N)])
    ends = np.array([3, 4, 10, 11, 12, 30, 31, 45, 60])
    figs = {"gyro_arw_rad_sqrt_s": 1e-3, "accel_vrw_mps_sqrt_s": 2e-2,
            "gyro_markov_radps": 1e-5, "accel_markov_mps2": 1e-3}
    taus = {"gyro_markov_radps": 300.0, "accel_markov_mps2": 200.0}
    got = ident.noise_parts(SimpleNamespace(Phi=Phi, t=t),
                            SimpleNamespace(epochs=np.r_[0, ends]), figs, taus)
    T = np.r_[0.0, np.diff(t)]
    D = ident.DRIVEN
    for j, (k, v) in enumerate(figs.items()):
        qc = np.zeros(n)
        tau = taus.get(k)
        qc[ident.BLOCKS[k]] = (v**2 if tau is None else 2 * v**2 / tau) / SCALE[
            ident.BLOCKS[k]] ** 2
        B = 0.5 * (Phi @ np.diag(qc) @ np.swapaxes(Phi, 1, 2) + np.diag(qc)) * T[:, None,
                                                                                None]
        want = ident.fold(Phi, B[:, None], ends)[1][1:, 0][:, D][:, :, D]
        np.testing.assert_allclose(got[j], want, rtol=1e-12, atol=1e-14 * np.abs(want).max())


def _drive(tmp: Path, arw_deg_sqrt_h: float, vrw_ug: float, segments: int = 12,
           gnss: dict | None = None):
    """The first ``segments`` of examples/car-drive.yaml with an IMU of this white noise,
    read back from its files, and its true figures (process.yaml)."""
    import yaml

    from fednav import load_system
    from fednav.io import read_gnss_csv, read_imu_csv, read_reference_csv
    from fednav.sim.dataset import load_dataset_config, simulate_dataset, write_csv_dataset

    cfg = load_dataset_config(ROOT / "examples" / "car-drive.yaml")
    cfg = cfg.model_copy(update={
        "segments": cfg.segments[:segments], "seed": 4,
        "imu": cfg.imu.model_copy(update={"gyro_arw_deg_sqrt_h": arw_deg_sqrt_h,
                                          "accel_vrw_ug_sqrt_hz": vrw_ug}),
        "gnss": cfg.gnss.model_copy(update=gnss or {})})
    write_csv_dataset(simulate_dataset(cfg), tmp)
    true = yaml.safe_load((tmp / "process.yaml").read_text())
    system = load_system(true)
    g = system.sensors.gnss
    fixes = read_gnss_csv(tmp / "gnss.csv", g.sigma_pos_enu_m, g.sigma_vel_mps, g.lever_m)
    return (read_imu_csv(tmp / "imu.csv", system.imu.max_bridge_s), fixes,
            read_reference_csv(tmp / "reference.csv"), true)


def _prepared(imu, fixes, true: dict, factor: float):
    """Prepared data with the white-noise figures ``factor`` times the true ones."""
    from fednav import load_system
    from fednav.process.run import prepare

    given = {**true, "imu": {**true["imu"]}}
    for k in ("gyro_arw_rad_sqrt_s", "accel_vrw_mps_sqrt_s"):
        given["imu"][k] = true["imu"][k] * factor
    system = load_system(given)
    return prepare(imu, {"gnss": fixes}, system)


#: A vibrating MEMS IMU (white noise 17 deg/sqrt(h), 5 000 ug/sqrt(Hz)) under RTK fixes
#: (2 cm, 2 cm/s): noise the fixes can see.  The antenna sits at the IMU: with a lever
#: arm, the filter's antenna velocity (the epoch's mean rate times the lever arm) carries
#: the gyro's white noise, which no figure models, and the identified accelerometer
#: noise comes out 17 % high with a 1.6 m arm (docs/real-data.md).
NOISY = {"arw_deg_sqrt_h": 17.0, "vrw_ug": 5000.0,
         "gnss": {"sigma_pos_enu_m": (0.02, 0.02, 0.04), "sigma_vel_mps": (0.02, 0.02, 0.04),
                  "lever_m": (0.0, 0.0, 0.0)}}


@pytest.fixture(scope="module")
def noisy_drive(tmp_path_factory):
    return _drive(tmp_path_factory.mktemp("noisy"), **NOISY)


def test_identification_recovers_the_white_noise_from_figures_10x_too_small(noisy_drive):
    from fednav.process.identify import identify

    imu, fixes, _, true = noisy_drive
    _, rep, _ = identify(imu, _prepared(imu, fixes, true, 0.1))
    assert rep.accepted, rep.why
    assert rep.nis_before["gnss"] > 2.0  # (the given figures were overconfident)
    for k in ("gyro_arw_rad_sqrt_s", "accel_vrw_mps_sqrt_s"):
        assert rep.identified[k] == pytest.approx(true["imu"][k], rel=0.2), k
    # no figure below the given one (the bias instabilities start there)
    assert all(rep.identified[k] >= rep.prior[k] for k in rep.prior)
    assert 0.5 < rep.nis_after["gnss"] < 2.0 and rep.converged


def test_figures_10x_too_large_are_kept_and_said(noisy_drive):
    """Innovations smaller than the figures predict do not lower them: the given
    figures are the floor (a sensor sigma too large is the likelier cause on real
    data), and the report says why."""
    from fednav.process.identify import identify

    imu, fixes, _, true = noisy_drive
    prep = _prepared(imu, fixes, true, 10.0)
    chosen, rep, nav = identify(imu, prep)
    assert chosen is prep and not rep.accepted and rep.passes == 1
    assert nav is not None  # (its first pass: the final one, taken as it is)
    assert rep.identified == rep.prior and rep.nis_before["gnss"] < 0.5
    assert "below 0.5" in rep.why and "never lowered" in rep.why


def test_figures_already_right_are_kept(tmp_path):
    """examples/car-drive.yaml's IMU under its 1.5 m GNSS with the true figures: the
    identification changes nothing that matters (NIS in its band, RMSE within 2 %)."""
    from fednav.process.run import errors_against, process, rmse

    imu, fixes, ref, true = _drive(tmp_path, 2.0, 200.0)
    from fednav import load_system

    system = load_system(true)
    runs = {m: process(imu, {"gnss": fixes}, system.model_copy(update={"noise": m}))
            for m in ("as-given", "identify")}
    rep = runs["identify"].noise
    for k, v in rep.identified.items():
        assert v == pytest.approx(rep.prior[k], rel=0.1), k
    assert 0.5 < runs["identify"].consistency["gnss"]["nis_per_dof"] < 2.0
    before, after = (rmse(errors_against(runs[m].forward, ref)) for m in runs)
    for k in ("east_m", "north_m", "up_m", "ve_mps", "vn_mps", "vu_mps"):
        assert after[k] <= 1.02 * before[k], k
    assert runs["as-given"].noise is None


def test_what_the_identification_does_not_take_is_said(noisy_drive, monkeypatch):
    """Figures 10x too small, but a recording too short to hold a block back, an
    adaptive local filter, or innovations beyond the refusal point without --force: the
    given figures are flown and the report says why."""
    from fednav.process.identify import identify

    imu, fixes, _, true = noisy_drive
    prep = _prepared(imu, fixes, true, 0.1)
    short = type(imu)(imu.source, imu.t[:5000], imu.gyro[:5000], imu.accel[:5000],
                      imu.errors)
    from fednav.process.run import prepare

    cut = prepare(short, {"gnss": fixes}, prep.system)
    _, rep, _ = identify(short, cut)
    assert not rep.accepted and "too short" in rep.why
    adaptive = replace_filter(prep, "aekf")
    _, rep, nav = identify(imu, adaptive)
    assert not rep.accepted and "aekf" in rep.why and nav is None
    import fednav.navigator.health as health

    monkeypatch.setattr(health, "NIS_REFUSE", 3.0)  # (where process refuses the data)
    _, rep, _ = identify(imu, prep)
    assert not rep.accepted and "above 3" in rep.why and "--force" in rep.why
    _, rep, _ = identify(imu, prep, force=True)
    assert rep.accepted and rep.passes > 1


def replace_filter(prep, kind: str):
    from dataclasses import replace

    s = prep.system
    return replace(prep, system=s.model_copy(update={"filter": s.filter.model_copy(
        update={"type": kind})}))


def test_the_compiled_smoother_recursion_is_the_python_one():
    """One source: the RTS backward recursion compiled equals the Python function to
    the bit."""
    from fednav.filters import smoother as sm

    rng = np.random.default_rng(1)
    N, n = 400, 21
    M = 0.1 * rng.standard_normal((N + 1, n, n))
    P = M @ np.swapaxes(M, 1, 2) + np.eye(n)
    Phi = np.eye(n) + 0.01 * rng.standard_normal((N + 1, n, n))
    Q = np.broadcast_to(0.01 * np.eye(n), (N + 1, n, n)).copy()
    dx = rng.standard_normal((N + 1, n))
    e, Ps, A = sm.rts_smooth(P, Phi, Q, dx)
    prior = Phi[1:] @ P[:-1] @ np.swapaxes(Phi[1:], 1, 2) + Q[1:]
    e2, Ps2 = sm.backward(A, P, 0.5 * (prior + np.swapaxes(prior, 1, 2)), dx)
    assert np.array_equal(e, e2) and np.array_equal(Ps, Ps2)


def test_noise_identify_with_the_total_state_navigator_is_named():
    """The total-state navigator has no smoother: a description that asks for the
    identification there is told it does not act."""
    from fednav import load_system
    from fednav.process.checks import ignored_keys

    said = ignored_keys(load_system({"noise": "identify", "filter": {"state": "total"}}))
    assert any(k.startswith("noise (acts with filter.state: error") for k in said)
    assert not any(k.startswith("noise") for k in ignored_keys(load_system({"noise":
                                                                            "identify"})))


def test_a_receiver_sigma_10x_too_small_is_identified(noisy_drive):
    """A GNSS file without sigma columns, flown with position sigmas 10x too small (the
    system description's; the IMU's figures right): the sigmas are identified within
    20 %, the gyro's figure kept within 20 %, NIS/dof back in its band; a sigma given
    by the file is not a figure to identify."""
    import copy

    from fednav import load_system
    from fednav.process.identify import identify, sigma_parts
    from fednav.process.run import prepare

    imu, fixes, _, true = noisy_drive
    assert fixes.sigma_rows is None
    given = copy.deepcopy(true)
    given["noise"] = "identify-all"
    g = given["sensors"]["gnss"]
    g["measures"] = "position"
    g["sigma_pos_enu_m"] = [0.1 * v for v in g["sigma_pos_enu_m"]]
    prep = prepare(imu, {"gnss": fixes}, load_system(given))
    chosen, rep, _ = identify(imu, prep)
    assert rep.accepted, rep.why
    assert rep.nis_before["gnss"] > 10 and 0.5 < rep.nis_after["gnss"] < 2.0
    east, north, up = true["sensors"]["gnss"]["sigma_pos_enu_m"]
    for k, v in {"north_m": north, "east_m": east, "up_m": up}.items():
        assert rep.identified[f"sensors.gnss.sigma_{k}"] == pytest.approx(v, rel=0.2), k
        assert rep.prior[f"sensors.gnss.sigma_{k}"] == pytest.approx(0.1 * v)
    assert rep.identified["gyro_arw_rad_sqrt_s"] == pytest.approx(
        true["imu"]["gyro_arw_rad_sqrt_s"], rel=0.2)
    # the final pass flies them: every fix with the identified sigmas
    flown = chosen.series["gnss"].sigma
    assert flown[0, 0] == pytest.approx(rep.identified["sensors.gnss.sigma_north_m"])
    # a file's own sigmas are the receiver's: kept
    own = fixes.with_sigma(np.full((len(fixes.t), 6), 0.002))
    assert not sigma_parts(prepare(imu, {"gnss": own}, load_system(given)))
    assert "gnss sigma_north_m" in "\n".join(rep.lines())
    # the default identifies the IMU's figures alone
    plain = prepare(imu, {"gnss": fixes}, load_system({**given, "noise": "identify"}))
    _, rep, _ = identify(imu, plain)
    assert not any(k.startswith("sensors.") for k in rep.prior)


def test_innovation_records_carry_h_and_epoch_alike_in_both_engines(tmp_path):
    """The rows' H and the epoch of every innovation record, from the compiled engine
    and the Python loop alike (what the identification of R reads), with a lever arm
    (H's attitude columns)."""
    from test_process import make_flight

    from fednav import load_system
    from fednav.process.run import prepare

    imu, gnss, _ = make_flight()
    prep = prepare(imu, {"gnss": gnss}, load_system({"sensors": {"gnss": {
        "lever_m": [0.3, 1.2, 0.8]}}}))
    out = {e: prep.feed(prep.navigator(innovations=True, engine=e)).result()
           for e in ("compiled", "python")}
    a, b = out["compiled"].innovations, out["python"].innovations
    assert len(a) == len(b) > 10
    for x, y in zip(a, b, strict=True):
        assert x.epoch == y.epoch > 0
        np.testing.assert_allclose(x.H, y.H, rtol=1e-9, atol=1e-12)
    assert np.abs(a[5].H[:, 0:3]).max() > 0  # (the lever arm's attitude coupling)
    t_epoch = out["compiled"].t[a[5].epoch]
    assert 0.0 <= t_epoch - a[5].t < prep.n_per * prep.dt + 1e-9


def test_a_low_nis_where_the_filter_fills_its_innovations_is_said_so():
    """A NIS/dof below the band means a sensor sigma larger than its data's only where the
    measurement noise dominates the innovations' predicted covariance; where the filter's
    own uncertainty fills it (a short recording, an uncertain start) the line says that
    instead.  Both PX4 sample logs are of the first kind (own share 0.14 and 0.09 of the
    GNSS noise in the median: their receivers' sigmas are what is large)."""
    from types import SimpleNamespace

    from fednav.navigator.record import InnovationRecord
    from fednav.navigator.system import System
    from fednav.process.identify import kept_because, own_share

    R = np.eye(3)

    def rec(local, own):
        return InnovationRecord(local, 0.0, np.zeros(3), (1.0 + own) * R, R, 1.0, True)

    out = SimpleNamespace(innovations=[rec("gnss", 4.0), rec("gnss", 2.0), rec("gnss", 3.0),
                                       rec("baro", 0.1)])
    own = own_share(out)
    assert own == pytest.approx({"gnss": 3.0, "baro": 0.1})
    said = kept_because({"gnss": 0.01}, System(), own)
    assert "own uncertainty fills" in said and "gnss 3x its noise" in said
    assert "likelier cause" not in said
    said = kept_because({"gnss": 0.01, "baro": 0.02}, System(), own)
    assert "likelier cause for baro" in said and "innovations of gnss" in said
    assert "likelier cause)" in kept_because({"baro": 0.02}, System(), own)
    assert "consistent" in kept_because({"baro": 1.0}, System(), own)


def test_the_kept_figures_line_has_no_empty_statistics():
    """A filter whose covariance the identification cannot use (a particle filter) keeps
    the given figures: the console's line says why, without an empty ': ;' where the
    NIS would be."""
    from fednav.process.identify import noise_lines

    s = {"prior": {}, "identified": {}, "nis_per_dof_before": {},
         "nis_per_dof_after": {}, "accepted": False, "passes": 1,
         "why_not": "local filter type pf: its covariance is not a Kalman filter's"}
    (line,) = noise_lines(s)
    assert ": ;" not in line and line.endswith("Kalman filter's; noise: as-given skips "
                                               "this check)")
    s["nis_per_dof_before"] = {"gnss": 1.5}
    assert "Kalman filter's: gnss 1.50; noise" in noise_lines(s)[0]

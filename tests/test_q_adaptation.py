"""Online process-noise adaptation (filter.q_adaptation, issue 26 item 4): the white part
of Qd, its scale's rule, the compiled engine equal to the Python loop, and what it does
to a filter whose IMU figures leave out the vehicle's vibration."""

import numpy as np
import pytest

from fednav import load_system
from fednav.ins import error_model as em
from fednav.ins.error_model import ImuNoiseModel, Nominal
from fednav.process import errors_against, process, rmse
from fednav.process.output import consistency
from fednav.sim.drives import car_drive


def test_the_white_part_of_qd_is_what_arw_and_vrw_add():
    """Qd is linear in the noise densities' squares: Qd(figures) - Qd(no ARW/VRW) is
    white_qd, and scaling it by s is Qd with ARW and VRW times sqrt(s)."""
    nom = Nominal(lat=0.8, h=100.0, vel=np.array([10.0, 5.0, 0.3]),
                  C=np.eye(3), fn=np.array([0.3, -0.2, 9.8]))
    full = ImuNoiseModel(gyro_arw=6e-4, accel_vrw=2e-3, gyro_markov_sigma=5e-5,
                         gyro_markov_tau=100.0, accel_markov_sigma=1e-3,
                         accel_markov_tau=100.0)
    quiet = ImuNoiseModel(gyro_markov_sigma=5e-5, gyro_markov_tau=100.0,
                          accel_markov_sigma=1e-3, accel_markov_tau=100.0)
    p, q = em.ErrorProcess(nom, 0.2, full), em.ErrorProcess(nom, 0.2, quiet)
    np.testing.assert_allclose(p.Qd - q.Qd, p.Qd_white, rtol=1e-9, atol=1e-14)
    loud = ImuNoiseModel(gyro_arw=6e-4 * 3.0, accel_vrw=2e-3 * 3.0, gyro_markov_sigma=5e-5,
                         gyro_markov_tau=100.0, accel_markov_sigma=1e-3,
                         accel_markov_tau=100.0)
    np.testing.assert_allclose(p.Qd + 8.0 * p.Qd_white, em.ErrorProcess(nom, 0.2, loud).Qd,
                               rtol=1e-9, atol=1e-14)


@pytest.fixture(scope="module")
def understated():
    """A car drive whose IMU vibrates while moving (0.3 m/s^2 and 0.003 rad/s per 100 Hz
    sample: VRW 0.03 m/s/sqrt(s), 15 times the data sheet's) processed with the data
    sheet's figures, and GNSS velocity precise enough (5 mm/s) to see it."""
    from fednav.io.data import ImuData

    d = car_drive(40.0, 0.0, seed=2, static_s=5.0,
                  gnss={"sigma_pos_enu_m": (0.05, 0.05, 0.1), "sigma_vel_mps": (0.005, 0.005, 0.01),
                        "lever_m": (0.3, -1.0, 1.2)})
    rng = np.random.default_rng(21)
    shake = (np.linalg.norm(d.reference.vel, axis=1) > 0.05)[:, None]
    n = len(d.imu.t)
    imu = ImuData("shaken", d.imu.t, d.imu.gyro + shake * rng.normal(0, 0.003, (n, 3)),
                  d.imu.accel + shake * rng.normal(0, 0.3, (n, 3)), d.imu.errors)
    # (flown as given: the identification of fednav.process.identify would set the
    # figures right before the adaptation has anything to do)
    return d, imu, {**d.system.model_dump(exclude_unset=True), "noise": "as-given"}


def test_adaptation_brings_the_nis_back_and_both_engines_agree(understated, monkeypatch):
    d, imu, cfg = understated
    adapted_cfg = load_system({**cfg, "filter": {"q_adaptation": {"time_constant_s": 20.0,
                                                                  "max_scale": 1e4}}})
    out = {}
    for engine in ("compiled", "python"):
        monkeypatch.setenv("FEDNAV_ENGINE", engine)
        out[engine] = process(imu, {"gnss": d.gnss}, adapted_cfg, smooth=True)
    monkeypatch.setenv("FEDNAV_ENGINE", "compiled")
    plain = process(imu, {"gnss": d.gnss}, load_system(cfg), smooth=True)
    adapted = out["compiled"]
    n0 = consistency(plain.forward)["gnss"]["nis_per_dof"]
    n1 = consistency(adapted.forward)["gnss"]["nis_per_dof"]
    s = adapted.data_quality["q_scale_final"]["gnss"]
    assert n0 > 3.0 and n1 < 0.6 * n0 and 1.0 < s <= 1e4, (n0, n1, s)
    e0 = rmse(errors_against(plain.forward, d.reference))
    e1 = rmse(errors_against(adapted.forward, d.reference))
    assert e1["vn_mps"] < e0["vn_mps"] and e1["ve_mps"] < e0["ve_mps"]
    # the smoother inverts the prior the filter flew (the adapted one): no worse than
    # the forward solution (recording the figures' Qd made it 17 times worse)
    e1s = rmse(errors_against(adapted.smoothed, d.reference))
    assert e1s["east_m"] < e1["east_m"] and e1s["ve_mps"] < e1["ve_mps"], (e1, e1s)
    # the compiled engine flies what the Python loop does
    a, b = out["compiled"], out["python"]
    np.testing.assert_allclose(a.forward.lla, b.forward.lla, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.smoothed.lla, b.smoothed.lla, rtol=0, atol=1e-9)
    assert s == pytest.approx(b.data_quality["q_scale_final"]["gnss"], rel=1e-9)


def test_the_scale_never_falls_below_the_figures(understated):
    """Figures far too large: the NIS stays below 1 and the scale near 1 — never below
    (single innovations above their sigma nudge it up now and then)."""
    d, imu, cfg = understated
    big = {**cfg, "imu": {**cfg["imu"],
                          "gyro_arw_rad_sqrt_s": cfg["imu"]["gyro_arw_rad_sqrt_s"] * 100,
                          "accel_vrw_mps_sqrt_s": cfg["imu"]["accel_vrw_mps_sqrt_s"] * 100},
           "filter": {"q_adaptation": {}}}
    res = process(imu, {"gnss": d.gnss}, load_system(big))
    assert consistency(res.forward)["gnss"]["nis_per_dof"] < 1.0
    assert 1.0 <= res.data_quality["q_scale_final"]["gnss"] < 1.1


def test_q_adaptation_is_refused_with_the_total_state_navigator():
    from fednav.core.config import ConfigError

    with pytest.raises(ConfigError, match="q_adaptation adapts the error-state filters"):
        load_system({"filter": {"state": "total", "q_adaptation": {}}})

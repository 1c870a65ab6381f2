"""NaveGo .mat reader: frame conversion at the boundary and one-line errors."""

import numpy as np
import pytest
import scipy.io

from fednav.core import attitude as att
from fednav.core import units
from fednav.io import (
    FRD_TO_RFU,
    DataError,
    navego_euler_to_fednav,
    read_navego_gnss,
    read_navego_imu,
    read_navego_reference,
    read_navego_visual,
)
from fednav.io.navego import navego_dcm


def test_frd_to_rfu_is_a_proper_rotation_and_its_own_inverse():
    np.testing.assert_allclose(FRD_TO_RFU @ FRD_TO_RFU, np.eye(3))
    assert np.linalg.det(FRD_TO_RFU) == pytest.approx(1.0)
    # forward (FRD x) -> fednav y; right (FRD y) -> fednav x; down -> -up
    np.testing.assert_allclose(FRD_TO_RFU @ [1, 0, 0], [0, 1, 0])
    np.testing.assert_allclose(FRD_TO_RFU @ [0, 1, 0], [1, 0, 0])
    np.testing.assert_allclose(FRD_TO_RFU @ [0, 0, 1], [0, 0, -1])


@pytest.mark.parametrize(("rpy_deg", "expected"), [
    ((0, 0, 90), (0, 0, 90)),      # yaw 90 = nose east = heading 90
    ((0, 10, 0), (10, 0, 0)),      # NaveGo pitch up = fednav pitch up
    ((15, 0, 0), (0, 15, 0)),      # right wing down in both
    ((0, 0, -30), (0, 0, 330)),    # heading wrapped to [0, 360)
])
def test_navego_euler_conversion_single_axes(rpy_deg, expected):
    e = navego_euler_to_fednav(*units.deg(np.array(rpy_deg, dtype=float)))
    np.testing.assert_allclose(units.to_deg(e), expected, atol=1e-9)


def test_navego_euler_conversion_general_maps_vectors_consistently():
    r, p, y = 0.3, -0.2, 2.5
    Cn = navego_dcm(r, p, y)  # FRD -> NED
    Cf = att.euler_to_dcm(navego_euler_to_fednav(r, p, y))  # RFU -> ENU
    v_frd = np.array([1.0, 2.0, -0.5])
    np.testing.assert_allclose(FRD_TO_RFU @ (Cn @ v_frd), Cf @ (FRD_TO_RFU @ v_frd),
                               atol=1e-12)


def _save(tmp_path, name, **fields):
    p = tmp_path / f"{name}.mat"
    scipy.io.savemat(p, {name: fields})
    return p


def _imu_fields(n=50):
    t = np.arange(n) * 0.01
    return dict(t=t, fb=np.tile([0.1, 0.2, -9.8], (n, 1)), wb=np.tile([0.01, 0.02, 0.03], (n, 1)),
                arw=[1e-4] * 3, vrw=[1e-3] * 3, gb_sta=[-0.01, 0.02, 0.03], ab_sta=[-0.1] * 3,
                gb_dyn=[1e-4] * 3, ab_dyn=[1e-3] * 3, gb_corr=[100.0] * 3, ab_corr=[200.0] * 3,
                ini_align=[0.0, 0.0, np.pi / 2], ini_align_err=[0.01, 0.02, 0.1])


def test_read_imu_converts_frames_and_figures(tmp_path):
    imu = read_navego_imu(_save(tmp_path, "imu", **_imu_fields()))
    np.testing.assert_allclose(imu.accel[0], [0.2, 0.1, 9.8])
    np.testing.assert_allclose(imu.gyro[0], [0.02, 0.01, -0.03])
    np.testing.assert_allclose(imu.errors.gyro_bias, [0.02, 0.01, 0.03])  # magnitudes, RFU
    np.testing.assert_allclose(units.to_deg(imu.initial_euler), [0, 0, 90], atol=1e-9)
    np.testing.assert_allclose(imu.initial_euler_sigma, [0.02, 0.01, 0.1])
    assert imu.period() == pytest.approx(0.01)


def test_read_gnss_visual_reference(tmp_path):
    n = 5
    g = read_navego_gnss(_save(tmp_path, "gnss", t=np.arange(n), lat=np.full(n, 0.7),
                               lon=np.full(n, -1.2), h=np.full(n, 20.0),
                               vel=np.tile([1.0, 2.0, 0.5], (n, 1)), stdm=[5, 6, 7],
                               stdv=[0.1, 0.2, 0.3], larm=[1.0, 0.5, -0.2]))
    np.testing.assert_allclose(g.vel[0], [2.0, 1.0, -0.5])  # NED -> ENU
    np.testing.assert_allclose(g.sigma_pos_enu, [6, 5, 7])  # east, north, up (stdm N, E, D)
    np.testing.assert_allclose(g.sigma_vel, [0.2, 0.1, 0.3])  # east, north, up
    np.testing.assert_allclose(g.lever, [0.5, 1.0, 0.2])  # right, forward, up
    cov = np.diag([1.0, 4.0, 9.0]).ravel()
    v = read_navego_visual(_save(tmp_path, "visual", t=np.arange(n) * 0.2,
                                 vel=np.tile([1.0, 2.0, 0.5], (n, 1)), covv=np.tile(cov, (n, 1))))
    np.testing.assert_allclose(np.diag(v.cov[0]), [4.0, 1.0, 9.0])
    r = read_navego_reference(_save(tmp_path, "ref", t=np.arange(n), lat=np.full(n, 0.7),
                                    lon=np.full(n, -1.2), h=np.full(n, 20.0),
                                    vel=np.zeros((n, 3)), roll=np.zeros(n), pitch=np.zeros(n),
                                    yaw=np.full(n, np.pi)))
    np.testing.assert_allclose(units.to_deg(r.euler[:, 2]), 180.0)


@pytest.mark.parametrize(("change", "message"), [
    (lambda f: f.pop("fb"), "missing field 'fb'"),
    (lambda f: f.update(fb=np.ones((50, 2))), "field 'fb' has shape 50x2, expected Nx3"),
    (lambda f: f["wb"].__setitem__((slice(7, 30), 1), np.nan),
     "23 faulty IMU samples in a row (NaN/inf or absurd) from t = 0.070000 s to 0.290000 s"),
    (lambda f: f["t"].__setitem__(10, 0.0), "field 't' is not increasing at row 10"),
    (lambda f: f.update(t=np.arange(40) * 0.01), "field 'fb' has 50 rows but 't' has 40"),
])
def test_bad_imu_files_give_one_line_errors(tmp_path, change, message):
    fields = _imu_fields()
    fields["wb"] = fields["wb"].copy()
    change(fields)
    p = _save(tmp_path, "imu", **fields)
    with pytest.raises(DataError) as e:
        read_navego_imu(p)
    assert message in str(e.value) and str(p) in str(e.value)
    assert "\n" not in str(e.value)


def test_a_faulty_imu_sample_is_bridged_and_counted(tmp_path):
    fields = _imu_fields()
    fields["wb"] = fields["wb"].copy()
    fields["wb"][7, 1] = np.nan
    fields["wb"][9, 0] = 1e30
    imu = read_navego_imu(_save(tmp_path, "imu", **fields))
    assert imu.quality == {"imu_samples_bridged": 2} and np.isfinite(imu.gyro).all()
    np.testing.assert_array_equal(imu.gyro[7], imu.gyro[6])
    np.testing.assert_array_equal(imu.gyro[9], imu.gyro[8])


def test_missing_and_non_mat_files(tmp_path):
    with pytest.raises(DataError, match="not found"):
        read_navego_imu(tmp_path / "nope.mat")
    bad = tmp_path / "bad.mat"
    bad.write_text("hello")
    with pytest.raises(DataError, match="not a MATLAB"):
        read_navego_gnss(bad)


def test_imu_gap_is_reported(tmp_path):
    f = _imu_fields()
    f["t"] = f["t"].copy()
    f["t"][30:] += 0.5
    with pytest.raises(DataError, match=r"IMU sampling has a gap of 0.510000 s between t = "
                                        r"0.290000 s"):
        read_navego_imu(_save(tmp_path, "imu", **f))

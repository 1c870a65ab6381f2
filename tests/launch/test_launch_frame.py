import numpy as np
import pytest

from fednav.core import earth, units
from fednav.launch.frame import (
    J2,
    J4,
    LaunchFrame,
    ecef_to_geodetic,
    enu_axes_ecef,
    gravitation_eci,
)

FRAME = LaunchFrame((units.deg(32.0), units.deg(118.0), 0.0), units.deg(90.0))


def _potential(r, degree=4):
    rr = np.linalg.norm(r)
    s = r[2] / rr
    ar = earth.A / rr
    u = 1.0 - J2 * ar**2 * 0.5 * (3 * s * s - 1)
    if degree == 4:
        u -= J4 * ar**4 * (35 * s**4 - 30 * s**2 + 3) / 8
    return earth.GM / rr * u


@pytest.mark.parametrize("degree", [2, 4])
def test_gravitation_is_gradient_of_potential(degree):
    r = np.array([3.1e6, -2.2e6, 5.0e6])
    num = np.array([(_potential(r + d, degree) - _potential(r - d, degree)) / 2.0
                    for d in np.eye(3)])
    assert np.allclose(gravitation_eci(r, degree), num, atol=1e-7)


@pytest.mark.parametrize("lat", [0.0, 17.0, 32.0, 60.0, 85.0])
def test_gravitation_plus_centrifugal_is_normal_gravity(lat):
    fr = LaunchFrame((units.deg(lat), units.deg(118.0), 0.0), units.deg(90.0))
    g_li = fr.gravity_li(np.zeros(3))
    r_ecef = fr.r0_ecef
    w = np.array([0.0, 0.0, earth.OMEGA_IE])
    g_ecef = fr.C_ecef_li_at(0.0) @ g_li - np.cross(w, np.cross(w, r_ecef))
    # In ENU at the launch point (LI y is the geodetic up at t = 0).
    up = fr.C_ecef_li[:, 1]
    g_up = g_ecef @ up
    horiz = g_ecef - g_up * up
    assert abs(g_up + earth.gravity(units.deg(lat), 0.0)) < 1e-5
    assert np.linalg.norm(horiz) < 1e-5
    # J2 alone misses the J4 term (up to 1.2e-4 m/s^2, near the poles).
    fr2 = LaunchFrame(fr.lla, fr.azimuth, degree=2)
    assert np.linalg.norm(fr2.gravity_li(np.zeros(3)) - g_li) < 1.3e-4


def test_axes_at_launch():
    # Eastward launch: x = east, y = up, z = south (ENU at the pad, t = 0).
    A = enu_axes_ecef(FRAME.lla[0], FRAME.lla[1])  # C_enu^ecef at the pad
    C = FRAME.C_ecef_li_at(0.0).T @ A               # ENU -> LI
    assert np.allclose(C.T, [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-12)
    north = LaunchFrame(FRAME.lla, 0.0).C_ecef_li_at(0.0).T @ A
    assert np.allclose(north.T @ [1, 0, 0], [0, 1, 0], atol=1e-12)  # x = north


def test_round_trips():
    rng = np.random.default_rng(3)
    r_li = rng.normal(0, 4e5, (50, 3))
    t = rng.uniform(0, 600, 50)
    assert np.allclose(FRAME.ecef_to_li(FRAME.li_to_ecef(r_li, t), t), r_li, atol=1e-9, rtol=0)
    lla = FRAME.li_to_geodetic(r_li, t)
    assert np.allclose(FRAME.geodetic_to_li(lla, t), r_li, atol=1e-8, rtol=0)
    r_ecef = earth.llh_to_ecef(lla[:, 0], lla[:, 1], lla[:, 2])
    assert np.allclose(ecef_to_geodetic(r_ecef)[:, 2], lla[:, 2], atol=1e-8)
    assert np.allclose(FRAME.geodetic_to_li(np.array(FRAME.lla), 0.0), 0.0, atol=1e-8)


def test_point_at_rest_traces_a_circle():
    day = 2 * np.pi / earth.OMEGA_IE  # one sidereal day
    t = np.linspace(0.0, day, 400)
    r = FRAME.geodetic_to_li(np.tile(FRAME.lla, (len(t), 1)), t)
    r_eci = FRAME.li_to_eci(r)
    rho = np.hypot(r_eci[:, 0], r_eci[:, 1])
    assert np.ptp(rho) < 1e-6 and np.ptp(r_eci[:, 2]) < 1e-6
    assert np.allclose(r_eci[-1], r_eci[0], atol=1e-3)
    # After a quarter of a day the pad has turned 90 deg about the Earth's axis.
    q = FRAME.geodetic_to_li(np.array(FRAME.lla), day / 4)
    e0, e1 = FRAME.li_to_eci(np.zeros(3)), FRAME.li_to_eci(q)
    c = (e0[:2] @ e1[:2]) / (np.linalg.norm(e0[:2]) * np.linalg.norm(e1[:2]))
    assert abs(c) < 1e-7
    # Its LI velocity at t = 0 is omega x r (eastward, ~394 m/s at 32 deg).
    w = np.array([0.0, 0.0, earth.OMEGA_IE])
    v_li = FRAME.C_eci_li.T @ np.cross(w, FRAME.r0_eci)
    v_eci = FRAME.C_eci_li @ v_li  # Earth-relative: remove omega x r, at t = 0
    v_ecef = FRAME.C_ecef_eci(0.0) @ (v_eci - np.cross(w, FRAME.li_to_eci(np.zeros(3))))
    assert np.linalg.norm(v_ecef) < 1e-9 and np.linalg.norm(v_li) > 390


def test_bad_degree():
    with pytest.raises(ValueError, match="degree"):
        LaunchFrame(FRAME.lla, 0.0, degree=3)

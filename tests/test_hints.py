"""What a run suggests the description could add (ProcessResult.hints): the
non-holonomic constraint for a vehicle that moves like a wheeled one."""

from types import SimpleNamespace

import numpy as np
import pytest

from fednav import load_system
from fednav.core import attitude as att
from fednav.process.checks import WHEELED_MIN_S, wheeled_hint


def _track(speed: float, crab_deg: float = 0.0, seconds: float = 120.0, bob: float = 0.0):
    """A level track turning slowly, its velocity ``crab_deg`` off the body's forward
    axis (heading from north toward east; ENU velocity), vertical body velocity ``bob``
    [m/s RMS]."""
    t = np.arange(0.0, seconds, 0.1)
    heading = np.radians(30.0) + 0.01 * t
    course = heading + np.radians(crab_deg)
    up = bob * np.sqrt(2.0) * np.sin(2 * np.pi * 0.5 * t)
    vel = np.column_stack([speed * np.sin(course), speed * np.cos(course), up])
    euler = np.column_stack([np.zeros_like(t), np.zeros_like(t), heading])
    return SimpleNamespace(t=t, vel=vel, euler=euler)


def test_the_hint_follows_the_velocity_in_body_axes():
    plain = load_system({})
    assert "sensors.nhc" in wheeled_hint(_track(10.0), plain)[0]
    assert not wheeled_hint(_track(10.0, crab_deg=5.0), plain)  # (0.87 m/s sideways)
    assert not wheeled_hint(_track(10.0, bob=0.5), plain)       # (a pitching drone)
    assert not wheeled_hint(_track(2.0), plain)                 # (walking pace)
    assert not wheeled_hint(_track(10.0, seconds=0.5 * WHEELED_MIN_S), plain)
    nhc = load_system({"sensors": {"nhc": {"sigma_mps": [0.1, 0.1]}}})
    assert not wheeled_hint(_track(10.0), nhc)


def test_a_car_drive_is_hinted_and_the_body_frame_is_right():
    """fednav's simulated car: the hint in the result and in summary.json; the body
    velocity it reads (C_b^n' v) is along the forward axis: a sign or transpose error in
    it would put the car's speed sideways."""
    from fednav.process.output import summary
    from fednav.process.run import process
    from fednav.sim.drives import car_drive

    d = car_drive(30.0, 8.0, seed=2)
    res = process(d.imu, {"gnss": d.gnss}, d.system)
    assert any("sensors.nhc" in h for h in res.hints)
    assert summary(res, None, {})["hints"] == res.hints
    sol = res.forward
    vb = np.einsum("nji,nj->ni", att.euler_to_dcm(sol.euler), sol.vel)
    moving = np.hypot(sol.vel[:, 0], sol.vel[:, 1]) > 3.0
    assert np.median(vb[moving, 1]) == pytest.approx(
        np.median(np.hypot(sol.vel[moving, 0], sol.vel[moving, 1])), rel=0.02)

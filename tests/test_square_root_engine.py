"""Square-root local filters (``form: square_root``) in the navigator's compiled engine:
the same solution as the Python loop (which flies :mod:`fednav.filters.square_root`'s
filter objects) on a simulated drive, for each family the engine runs and for a system
that mixes the forms, and the same as the standard form in the engine to rounding."""

import numpy as np
import pytest
from test_navigator_engine import drive  # noqa: F401  (the simulated drive, a fixture)

from fednav import load_system
from fednav.filters import FilterError
from fednav.navigator import engine
from fednav.process.run import prepare
from fednav.sensors.registry import SENSORS

IMU = {"gyro_arw_deg_sqrt_h": 2.0, "accel_vrw_ug_sqrt_hz": 200.0, "gyro_bias_deg_h": 200.0,
       "accel_bias_ug": 2000.0, "gyro_markov_deg_h": 25.0, "gyro_tau_s": 100.0,
       "accel_markov_ug": 200.0, "accel_tau_s": 100.0}

#: name -> the filter section, every filter factored unless said
SYSTEMS = {
    "kf": {"form": "square_root", "fdi_alpha": {"velocity": 0.05}, "fdi_recovery": 3},
    "ekf": {"type": "ekf", "form": "square_root", "sharing": "adaptive", "master": True},
    "ukf": {"type": "ukf", "alpha": 0.5, "form": "square_root", "fdi_alpha": 0.01},
    # the adapted white noise factored each epoch (the Lq of the engine, not the cached one)
    "kf-q": {"form": "square_root", "q_adaptation": {"time_constant_s": 5.0}},
    "sukf": {"type": "sukf", "alpha": 0.5, "form": "square_root", "master": True},
    # standard KF for the GNSS, factored UKF for the velocity sensor, a factored master
    "mixed": {"alpha": 0.5, "form": "square_root", "master": True, "sharing": "adaptive",
              "locals": {"gnss": {"form": "standard"}, "velocity": {"type": "ukf"}},
              "fdi_alpha": 0.01},
}


def _prep(drive, filt):  # noqa: F811
    imu, g, v = drive
    return prepare(imu, {"gnss": g, "velocity": v}, load_system({"imu": IMU, "filter": filt}))


def _standard(filt: dict) -> dict:
    """The same filter section with every filter in the standard form."""
    out = {k: v for k, v in filt.items() if k != "form"}
    if "locals" in out:
        out["locals"] = {a: {k: v for k, v in c.items() if k != "form"}
                         for a, c in out["locals"].items()}
    return out


def _rel(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def _run(prep, name):
    nav = prep.navigator(engine=name)
    return nav, prep.feed(nav).result()


@pytest.mark.parametrize("which", sorted(SYSTEMS))
def test_square_root_engine_equals_python_loop_and_standard_form(drive, which):  # noqa: F811
    filt = SYSTEMS[which]
    prep = _prep(drive, filt)
    nav, fast = _run(prep, "compiled")
    nav_slow, slow = _run(prep, "python")
    forms = [f.form for f in nav.loop.fed.filters.values()]
    if "q_adaptation" in filt:  # adapted, alike
        qa, qb = nav.loop.q_scales(), nav_slow.loop.q_scales()
        assert max(qa.values()) > 1.0 and qa == pytest.approx(qb, rel=1e-10)
    assert fast.engine == "compiled" and slow.engine == "python"
    assert "square_root" in forms and (which != "mixed" or "standard" in forms)
    assert len(fast.t) == len(slow.t) > 500
    for a, b in ((fast.states, slow.states), (fast.P, slow.P),
                 ([e[2] for e in fast.fdi], [e[2] for e in slow.fdi])):
        assert _rel(a, b) <= 1e-10
    assert [(e[1], e[5]) for e in fast.fdi] == [(e[1], e[5]) for e in slow.fdi]
    _, std = _run(_prep(drive, _standard(filt)), "compiled")
    assert _rel(fast.states, std.states) <= 1e-8 and _rel(fast.P, std.P) <= 1e-8
    assert [e[5] for e in fast.fdi] == [e[5] for e in std.fdi]


def test_the_engine_runs_square_root_systems(drive):  # noqa: F811
    """Every family the engine runs, in either form; the others still run in Python."""
    for filt in SYSTEMS.values():
        assert engine.why_not_compiled(_prep(drive, filt).system, ["gnss", "velocity"],
                                       SENSORS) is None
    system = _prep(drive, {"type": "sghqf", "form": "square_root"}).system
    assert engine.why_not_compiled(system, ["gnss", "velocity"], SENSORS) == "'sghqf' filters"


@pytest.mark.parametrize("name", ["compiled", "python"])
def test_square_root_failure_names_the_filter_step_and_why(drive, name):  # noqa: F811
    """A measurement noise that is not positive semi-definite: the factored filter's
    error, from either engine."""
    prep = _prep(drive, SYSTEMS["kf"])
    d = prep.series["velocity"]
    d.cov = d.cov.copy()
    d.cov[40] = -d.cov[40]
    with pytest.raises(FilterError, match=r"kf local 'velocity' update at step \d+: "
                                          r"measurement noise R is not positive "
                                          r"semi-definite"):
        _run(prep, name)

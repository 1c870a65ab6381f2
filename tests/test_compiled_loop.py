"""The compiled closed loop against the general Python loop on the same run data."""

import numpy as np
import pytest

from fednav.filters import FilterError
from fednav.scenarios import paper002
from fednav.sim import compiled_loop
from fednav.sim import runs as simulate

MAX_TIME = 120.0


@pytest.fixture(scope="module")
def scn_data():
    scn = paper002.load_scenario()
    return scn, simulate.make_run_data(scn, 11, MAX_TIME)


def _python_path(monkeypatch, scn, mode, data):
    with monkeypatch.context() as m:
        m.setattr(compiled_loop, "supported", lambda *a, **k: False)
        return simulate.run_configured_mode(scn, mode, data, MAX_TIME)


@pytest.mark.parametrize("sharing", ["adaptive", "equal"])
def test_same_run_as_the_python_loop(monkeypatch, scn_data, sharing):
    scn, data = scn_data
    scn = scn.model_copy(update={"filter": scn.filter.model_copy(update={"sharing": sharing})})
    for mode in scn.modes:
        if not mode.aiding:
            continue
        fast = simulate.run_configured_mode(scn, mode, data, MAX_TIME)
        slow = _python_path(monkeypatch, scn, mode, data)
        for name in ("pos", "vel", "att", "sigma", "euler"):
            np.testing.assert_allclose(getattr(fast, name), getattr(slow, name), rtol=1e-9,
                                       atol=1e-15, err_msg=f"{mode.name} {name}")
        assert fast.beta.keys() == slow.beta.keys()
        for k in fast.beta:
            np.testing.assert_allclose(fast.beta[k], slow.beta[k], rtol=1e-9)
        assert len(fast.fdi) == len(slow.fdi) > 0
        np.testing.assert_allclose(fast.fdi["statistic"], slow.fdi["statistic"], rtol=1e-9)
        assert list(fast.fdi["local"]) == list(slow.fdi["local"])
        np.testing.assert_array_equal(fast.fdi["t"], slow.fdi["t"])


def test_which_modes_take_the_compiled_path(scn_data):
    scn, data = scn_data
    loop = simulate._ClosedLoop(scn, ["star", "sar"], data, "ukf", scn.trajectory(MAX_TIME))
    args = dict(ftype="ukf", aiding=["star", "sar"], timing=loop.timing, central=False,
                constraint=None, fdi_alpha=None, reset=True, incs=None)
    assert compiled_loop.supported(**args)
    for change in ({"ftype": "kf"}, {"ftype": "sghqf"}, {"aiding": ["gnss"]},
                   {"aiding": []}, {"central": True}, {"constraint": "wind"},
                   {"fdi_alpha": 0.01}, {"fdi_alpha": {"star": 0.01, "sar": None}},
                   {"reset": False}, {"incs": object()}):
        assert not compiled_loop.supported(**{**args, **change}), change
    late = {a: tm.model_copy(update={"delay_compensation": "curve_fit"})
            for a, tm in loop.timing.items()}
    assert not compiled_loop.supported(**{**args, "timing": late})


def test_failure_names_the_filter_and_step(scn_data):
    scn, data = scn_data
    bad = simulate.RunData(**{**data.__dict__, "dtheta": data.dtheta.copy()})
    bad.dtheta[250] = np.nan
    mode = next(m for m in scn.modes if m.name == "SINS/SAR")
    with pytest.raises(FilterError, match=r"step 3: navigation state became non-finite"):
        simulate.run_configured_mode(scn, mode, bad, MAX_TIME)


@pytest.mark.parametrize("kind", ["star", "sar"])
def test_residual_and_predicted_are_the_measurement_models(kind):
    """The compiled loop's copies of StarAttitude / SarFix (residual and h) against the
    classes the Python loop calls, on random attitudes (headings across 0 / 2 pi, steep
    pitch), positions and sigma points."""
    from fednav.core import attitude as att
    from fednav.ins.strapdown import STATE_SIZE
    from fednav.sensors import MODELS, NavSnapshot

    rng = np.random.default_rng(5)
    model = MODELS[kind]
    for _ in range(50):
        euler = np.array([rng.uniform(-1.4, 1.4), rng.uniform(-3.1, 3.1),
                          rng.uniform(0.0, 2 * np.pi)])
        C = att.euler_to_dcm(euler)
        state = np.zeros(STATE_SIZE)
        state[0:4] = att.dcm_to_quat(C)
        state[7:10] = [rng.uniform(-1.2, 1.2), rng.uniform(-3.1, 3.1), rng.uniform(0, 9e3)]
        Cq = att.quat_to_dcm(state[0:4])
        nav = NavSnapshot(lla=state[7:10].copy(), vel=np.zeros(3), C=Cq)
        if kind == "star":
            z = att.dcm_to_euler(Cq) + rng.normal(0, 1e-4, 3)
        else:
            z = np.r_[state[7:9] + rng.normal(0, 1e-6, 2), (euler[2] + rng.normal(0, 0.01))
                      % (2 * np.pi)]
        y = np.empty(3)
        compiled_loop._residual(compiled_loop.KINDS[kind], state, Cq, z, y)
        np.testing.assert_allclose(y, model.residual(nav, z), rtol=1e-12, atol=1e-9)
        X = rng.normal(0, 30.0, (37, 18))  # filter units: arcmin, m/s, m, ...
        np.testing.assert_allclose(compiled_loop._predicted(compiled_loop.KINDS[kind], Cq, X),
                                   model.h(X, nav), rtol=1e-12, atol=1e-12)

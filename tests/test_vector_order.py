"""One order for every vector (issue 29, item 5; docs/conventions.md "Vector keys and
columns"): ENU, body right-forward-up or [pitch, roll, heading].  The renamed keys are
read with a FutureWarning and converted (a run with the old key equals one with the new
one), both at once is an error naming both, and each order is pinned so that a swap of
two components fails."""

from __future__ import annotations

import re
import typing
import warnings
from pathlib import Path

import numpy as np
import pytest
from pydantic import BaseModel

from fednav import load_system
from fednav.core import earth
from fednav.core.config import ConfigError
from fednav.io import GnssData, read_gnss_csv
from fednav.sensors import GnssConfig

ROOT = Path(__file__).resolve().parents[1]


# -- the system description's sensors.gnss.sigma_pos_m -> sigma_pos_enu_m


def test_old_gnss_key_is_read_reordered_with_a_warning():
    with pytest.warns(FutureWarning, match=r"sensors\.gnss\.sigma_pos_m \[north, east, up\] "
                                           r"is now sensors\.gnss\.sigma_pos_enu_m \[east, "
                                           r"north, up\]"):
        old = load_system({"sensors": {"gnss": {"sigma_pos_m": [1.0, 2.0, 3.0]}}})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        new = load_system({"sensors": {"gnss": {"sigma_pos_enu_m": [2.0, 1.0, 3.0]}}})
    assert old == new and new.sensors.gnss.sigma_pos_enu_m == (2.0, 1.0, 3.0)
    with pytest.warns(FutureWarning):  # one value: the same, but the name is the old one
        assert load_system({"sensors": {"gnss": {"sigma_pos_m": 4.0}}}).sensors.gnss \
            .sigma_pos_enu_m == 4.0
    # fednav 0.1's flat key goes the same way, in one warning that says the order
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        flat = load_system({"gnss_sigma_pos_m": [1.0, 2.0, 3.0]})
    assert flat.sensors.gnss.sigma_pos_enu_m == (2.0, 1.0, 3.0)
    assert [str(w.message) for w in seen] == [
        "processing-config keys of fednav 0.1 (gnss_sigma_pos_m -> "
        "sensors.gnss.sigma_pos_enu_m, reordered [north, east, up] -> [east, north, up]) "
        "are read for one more release"]


def test_old_and_new_gnss_key_together_is_one_error_naming_both():
    with pytest.raises(ConfigError, match=r"key 'sensors\.gnss': 'sigma_pos_m' \(\[north, "
                                          r"east, up\]\) and 'sigma_pos_enu_m' \(\[east, "
                                          r"north, up\]\) are the same setting"):
        load_system({"sensors": {"gnss": {"sigma_pos_m": 1.0, "sigma_pos_enu_m": 1.0}}})


def test_dataset_old_keys_are_read_reordered_and_simulate_the_same(tmp_path):
    from fednav.sim.dataset import GnssSimConfig, load_dataset_config, simulate_dataset

    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        old = GnssSimConfig.model_validate({"sigma_pos_m": [0.5, 1.0, 2.0],
                                            "markov_sigma_m": [0.3, 0.0, 0.1]})
    said = sorted(str(w.message) for w in seen if w.category is FutureWarning)
    assert len(said) == 2 and re.match(r"gnss\.markov_sigma_m .* gnss\.markov_sigma_enu_m",
                                       said[0])
    assert re.match(r"gnss\.sigma_pos_m .* gnss\.sigma_pos_enu_m", said[1])
    new = GnssSimConfig(sigma_pos_enu_m=(1.0, 0.5, 2.0), markov_sigma_enu_m=(0.0, 0.3, 0.1))
    assert old == new
    with pytest.raises(ValueError, match="'sigma_pos_m' .* and 'sigma_pos_enu_m' .* same"):
        GnssSimConfig.model_validate({"sigma_pos_m": 1.0, "sigma_pos_enu_m": [1, 1, 1]})
    cfg = load_dataset_config(ROOT / "examples" / "car-drive.yaml")
    cfg = cfg.model_copy(update={"segments": cfg.segments[:2], "velocity": None})
    a = simulate_dataset(cfg.model_copy(update={"gnss": old}))
    b = simulate_dataset(cfg.model_copy(update={"gnss": new}))
    np.testing.assert_array_equal(a.gnss_lla, b.gnss_lla)


def test_a_run_with_the_old_key_equals_one_with_the_new_key():
    from fednav.process.run import process
    from fednav.sim.drives import car_drive

    d = car_drive(30.0, 0.0, seed=5)
    data = d.system.model_dump(exclude_unset=True, mode="json")
    gnss = data["sensors"]["gnss"]
    gnss.pop("sigma_pos_enu_m")
    gnss["sigma_pos_m"] = [0.8, 1.6, 3.0]                     # north, east, up
    with pytest.warns(FutureWarning):
        old = load_system(data)
    gnss.pop("sigma_pos_m")
    gnss["sigma_pos_enu_m"] = [1.6, 0.8, 3.0]                 # east, north, up
    new = load_system(data)
    a = process(d.imu, {"gnss": d.gnss}, old).forward
    b = process(d.imu, {"gnss": d.gnss}, new).forward
    np.testing.assert_array_equal(a.lla, b.lla)
    np.testing.assert_array_equal(a.sigma, b.sigma)


# -- the Python API: read_gnss_csv(sigma_pos=) and GnssData(sigma_pos=)


def _gnss_file(tmp_path) -> Path:
    p = tmp_path / "gnss.csv"
    p.write_text("t_s,lat_deg,lon_deg,h_m,vE_mps,vN_mps,vU_mps\n"
                 "0.0,45.0,7.0,100.0,1.0,0.0,0.0\n1.0,45.0,7.00001,100.0,1.0,0.0,0.0\n")
    return p


def test_read_gnss_csv_takes_enu_and_the_old_keyword_with_a_warning(tmp_path):
    p = _gnss_file(tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        new = read_gnss_csv(p, (2.0, 1.0, 3.0))
        assert read_gnss_csv(p, sigma_pos_enu=(2.0, 1.0, 3.0)).sigma_pos_enu.tolist() == \
            [2.0, 1.0, 3.0]
    with pytest.warns(FutureWarning, match=r"read_gnss_csv\(sigma_pos=\[north, east, up\]\) "
                                           r"is now read_gnss_csv\(sigma_pos_enu=\[east, "
                                           r"north, up\]\)") as seen:
        old = read_gnss_csv(p, sigma_pos=(1.0, 2.0, 3.0))
    assert len(seen) == 1 and seen[0].filename == __file__  # one warning, at the call
    np.testing.assert_array_equal(old.sigma_pos_enu, new.sigma_pos_enu)
    np.testing.assert_array_equal(new.sigma_pos_enu, [2.0, 1.0, 3.0])
    with pytest.warns(FutureWarning, match=r"GnssData\.sigma_pos \[north, east, up\]"):
        np.testing.assert_array_equal(new.sigma_pos, [1.0, 2.0, 3.0])  # the old attribute
    with pytest.raises(TypeError, match="sigma_pos .* and sigma_pos_enu .* same setting"):
        read_gnss_csv(p, (2.0, 1.0, 3.0), sigma_pos=(1.0, 2.0, 3.0))


def test_gnssdata_old_keyword_is_reordered_with_a_warning():
    t, lla = np.array([0.0, 1.0]), np.array([[0.7, 0.1, 5.0], [0.7, 0.1, 5.0]])
    with pytest.warns(FutureWarning, match="GnssData.sigma_pos_enu"):
        old = GnssData("g", t, lla, None, sigma_pos=[1.0, 2.0, 3.0], sigma_vel=np.ones(3),
                       lever=np.zeros(3))
    np.testing.assert_array_equal(old.sigma_pos_enu, [2.0, 1.0, 3.0])
    with pytest.raises(TypeError, match="same setting"):
        GnssData("g", t, lla, None, np.ones(3), np.ones(3), np.zeros(3), sigma_pos=np.ones(3))


# -- each order pinned: a swap of two components fails


def test_gnss_sigma_east_is_applied_to_east():
    from fednav.sensors.gnss import Gnss
    from fednav.sim.trajectory import Segment, generate

    gc = GnssConfig(sigma_pos_enu_m=(1.0, 2.0, 3.0), sigma_vel_mps=(0.1, 0.2, 0.3))
    model = gc.model()
    R = np.diag(model.R(gc.sigma()))
    # the residual rows are [dE, dN, dU, dvE, dvN, dvU]
    np.testing.assert_array_equal(R, np.square([1.0, 2.0, 3.0, 0.1, 0.2, 0.3]))
    # the simulator draws east noise with the east sigma
    tr = generate([0.6, 2.0, 100.0], 20.0, [0, 0, 0.5], [Segment(3000.0)], 0.1)
    g = Gnss((0.5, 4.0, 1.0), 0.1, 1.0).simulate(tr, np.random.default_rng(2))
    d = earth.llh_difference_enu(g.z[:, 0], g.z[:, 1], g.z[:, 2], *tr.at(g.t)["lla"].T)
    np.testing.assert_allclose(d.std(axis=0), [0.5, 4.0, 1.0], rtol=0.06)


def test_dataset_sigma_east_is_applied_to_east():
    from fednav.sim.dataset import GnssSimConfig, load_dataset_config, simulate_dataset

    cfg = load_dataset_config(ROOT / "examples" / "car-drive.yaml")
    cfg = cfg.model_copy(update={"velocity": None, "gnss": GnssSimConfig(
        sigma_pos_enu_m=(0.2, 3.0, 0.5), lever_m=(0.0, 0.0, 0.0))})
    ds = simulate_dataset(cfg)
    k = ds.gnss_t <= ds.t[-1]  # (a fix at the last sample's end: past the reference)
    i = np.searchsorted(ds.t, ds.gnss_t[k])
    assert np.allclose(ds.t[i], ds.gnss_t[k], rtol=0, atol=1e-9)
    r = ds.ref_lla[i]
    d = earth.llh_difference_enu(*ds.gnss_lla[k].T, *r.T)
    np.testing.assert_allclose(d.std(axis=0), [0.2, 3.0, 0.5], rtol=0.1)


def test_navego_stdm_north_east_down_is_read_into_enu(tmp_path):
    import scipy.io

    from fednav.io import read_navego_gnss

    t = np.arange(3.0)
    scipy.io.savemat(tmp_path / "gnss.mat", {"gnss": {
        "t": t, "lat": np.full(3, 0.7), "lon": np.full(3, 0.1), "h": np.full(3, 5.0),
        "vel": np.zeros((3, 3)), "stdm": np.array([1.0, 2.0, 3.0]),
        "stdv": np.array([0.1, 0.2, 0.3]), "larm": np.zeros(3)}})
    g = read_navego_gnss(tmp_path / "gnss.mat")
    np.testing.assert_array_equal(g.sigma_pos_enu, [2.0, 1.0, 3.0])
    np.testing.assert_array_equal(g.sigma_vel, [0.2, 0.1, 0.3])


def test_errors_are_enu_like_the_solution():
    """A solution 1 m east, 2 m north and 3 m above the reference, moving 0.1 / 0.2 /
    0.3 m/s faster: east_m 1, north_m 2, up_m 3 (not its negative)."""
    from fednav.io import Reference
    from fednav.navigator.solution import Solution
    from fednav.process.output import RMSE_KEYS
    from fednav.process.run import errors_against, rmse

    n = 5
    t = np.arange(n, dtype=float)
    ref_lla = np.tile([0.7, 0.1, 50.0], (n, 1))
    lla = earth.move_enu(ref_lla, np.array([1.0, 2.0, 3.0]))
    sol = Solution(t, lla, np.tile([0.1, 0.2, 0.3], (n, 1)), np.zeros((n, 3)),
                   np.ones((n, 9)), np.ones((n, 3)), np.zeros((n, 3)))
    e = errors_against(sol, Reference("ref", t, ref_lla, np.zeros((n, 3)), np.zeros((n, 3))))
    for k, v in {"east_m": 1.0, "north_m": 2.0, "up_m": 3.0, "ve_mps": 0.1, "vn_mps": 0.2,
                 "vu_mps": 0.3}.items():
        np.testing.assert_allclose(e[k], v, atol=1e-6, err_msg=k)
    r = rmse(e)
    assert list(r) == list(RMSE_KEYS)
    with pytest.warns(FutureWarning, match="error key 'down_m' is now 'up_m'"):
        np.testing.assert_allclose(e["down_m"], -3.0, atol=1e-6)
    with pytest.warns(FutureWarning, match="'vd_mps' is now 'vu_mps'"):
        assert r["vd_mps"] == r["vu_mps"]
    with pytest.raises(KeyError):
        e["nonsense"]
    assert "down_m" in e and "nonsense" not in e  # .get and `in` as [] does
    with pytest.warns(FutureWarning, match="error key 'down_m' is now 'up_m'"):
        np.testing.assert_allclose(e.get("down_m"), -3.0, atol=1e-6)
    assert e.get("nonsense", 7) == 7


def test_tune_figures_and_config_carry_the_new_key_in_enu(tmp_path):
    """tune's written config: the user's old key moved to the new one (not both)."""
    import yaml

    from fednav.process.tuning import Evaluation, Figure, TuneResult, config_yaml

    cfg = load_system({"sensors": {"gnss": {"sigma_pos_enu_m": [2.0, 1.0, 3.0]}}})
    ev = Evaluation(0.0, {}, {})
    res = TuneResult(cfg, [Figure("sensors.gnss.sigma_pos_enu_m", [1.0, 1.0, 1.0],
                                  [2.0, 1.0, 3.0], "innovation covariance matching")],
                     ev, ev, 1, 0.0)
    text = config_yaml(res, {"sensors": {"gnss": {"sigma_pos_m": [1.0, 2.0, 3.0]}}})
    gnss = yaml.safe_load(text)["sensors"]["gnss"]
    assert gnss == {"sigma_pos_enu_m": [2.0, 1.0, 3.0]}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert load_system(yaml.safe_load(text)).sensors.gnss.sigma_pos_enu_m == (2.0, 1.0,
                                                                                  3.0)


# -- the table of docs/conventions.md names every vector key of the configuration


def _vector_fields(model: type[BaseModel], seen=None):
    """(name, annotation) of every field of ``model`` and its nested models that holds a
    tuple of floats."""
    seen = set() if seen is None else seen
    if model in seen:
        return
    seen.add(model)
    for name, f in model.model_fields.items():
        args = [f.annotation]
        while args:
            a = args.pop()
            if isinstance(a, type) and issubclass(a, BaseModel):
                yield from _vector_fields(a, seen)
            elif typing.get_origin(a) is tuple and all(x is float for x in typing.get_args(a)):
                yield name
            else:
                args += list(typing.get_args(a))


def test_the_conventions_table_names_every_vector_key():
    from fednav.launch.scenario import LaunchScenario
    from fednav.navigator.system import System
    from fednav.sensors.registry import SENSORS
    from fednav.sim.dataset import DatasetConfig
    from fednav.sim.scenario import Scenario

    doc = (ROOT / "docs" / "conventions.md").read_text()
    table = doc.split("## Vector keys and columns")[1].split("\n## ")[0]
    keys = set()
    for m in (System, Scenario, DatasetConfig, LaunchScenario,
              *(s.config for s in SENSORS.values())):
        keys |= set(_vector_fields(m))
    keys = {k for k in keys if k != "outages_s" and "_range_" not in k}  # [from, to]
    missing = sorted(k for k in keys if not re.search(rf"\b{k}\b", table))
    assert not missing, f"vector keys not in docs/conventions.md's table: {missing}"


def test_gnss_simulator_old_keyword_is_reordered_with_a_warning():
    from fednav.sensors import Gnss

    with pytest.warns(FutureWarning, match=r"Gnss\.sigma_pos \[north, east, up\] is now "
                                           r"Gnss\.sigma_pos_enu"):
        old = Gnss(sigma_pos=(1.0, 2.0, 3.0), sigma_vel=0.1, period=1.0)
    assert old == Gnss((2.0, 1.0, 3.0), 0.1, 1.0)
    with pytest.warns(FutureWarning, match=r"Gnss\.sigma_pos \[north, east, up\]"):
        assert old.sigma_pos == (1.0, 2.0, 3.0)
    with pytest.raises(TypeError, match="same setting"):
        Gnss(1.0, 0.1, 1.0, sigma_pos=1.0)

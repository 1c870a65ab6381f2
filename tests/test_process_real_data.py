"""The real rover dataset (../shared/data/canada-planetary), against NaveGo's published
figures on the same files.  Skipped when ../shared is absent."""

from pathlib import Path

import pytest

from fednav import System, load_system
from fednav.io import (
    read_navego_gnss,
    read_navego_imu,
    read_navego_reference,
    read_navego_visual,
)
from fednav.process import errors_against, process, rmse

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "canada-planetary"
pytestmark = pytest.mark.skipif(not DATA.is_dir(), reason="../shared/data not available")

KEYS = ("north_m", "east_m", "up_m", "vn_mps", "ve_mps", "vu_mps")  # (the order)
#: NaveGo's VISUAL/INS/GNSS example on these files (the issue's figures).
NAVEGO_GNSS = dict(zip(KEYS, (0.45, 0.41, 5.27, 0.64, 0.59, 0.39), strict=True))
NAVEGO_VISUAL = dict(zip(KEYS, (1.52, 1.30, 1.00, 0.057, 0.055, 0.042), strict=True))
TARGET_VISUAL = dict(zip(KEYS, (0.45, 0.41, 1.00, 0.057, 0.055, 0.042), strict=True))
MARGIN = 0.9  # fednav must beat each figure by at least 10 %
#: ... except the target's velocities, met within the spread the initial heading alone
#: makes: started anywhere in 290..10 deg (sigma 10 deg) the visual run's vE is
#: 0.048..0.050 m/s (docs/recorded-data.md, "Alignment"); target and NaveGo: 0.055.
MARGIN_TARGET_VELOCITY = 0.95


@pytest.fixture(scope="module")
def data():
    return {"imu": read_navego_imu(DATA / "imu_planetary.mat"),
            "gnss": read_navego_gnss(DATA / "gnss_planetary.mat"),
            "visual": read_navego_visual(DATA / "visual_planetary.mat"),
            "ref": read_navego_reference(DATA / "gnss_planetary_r.mat")}


def _rmse(res, ref):
    return rmse(errors_against(res, ref))


def test_imu_gnss_with_the_files_noise_figures_beats_navego(data):
    res = process(data["imu"], {"gnss": data["gnss"]}, System())
    r = _rmse(res.forward, data["ref"])
    for k in KEYS:
        assert r[k] < MARGIN * NAVEGO_GNSS[k], (k, r[k])


def test_imu_gnss_visual_reaches_the_target_with_the_example_config(data):
    cfg = load_system(ROOT / "examples" / "canada-planetary.yaml")
    res = process(data["imu"], {"gnss": data["gnss"], "velocity": data["visual"]}, cfg, smooth=True)
    r = _rmse(res.forward, data["ref"])
    for k in KEYS:
        margin = MARGIN_TARGET_VELOCITY if k.endswith("mps") else MARGIN
        assert r[k] < margin * TARGET_VISUAL[k], (k, r[k])
        assert r[k] < margin * NAVEGO_VISUAL[k], (k, r[k])
    s = _rmse(res.smoothed, data["ref"])
    assert all(s[k] < r[k] for k in KEYS)


def test_visual_aiding_bounds_the_drift_through_the_gnss_outage(data):
    """The sparse GNSS file has no fixes between 100 s and 200 s."""
    import numpy as np

    cfg = load_system(ROOT / "examples" / "canada-planetary.yaml")
    g = read_navego_gnss(DATA / "gnss_sparse_planetary.mat")
    drift = {}
    for name, vis in (("gnss", None), ("visual", data["visual"])):
        e = errors_against(process(data["imu"], {"gnss": g, "velocity": vis}, cfg).forward,
                           data["ref"])
        m = (e["t"] > 100) & (e["t"] < 200)
        drift[name] = float(np.hypot(e["north_m"][m], e["east_m"][m]).max())
    assert drift["visual"] < 0.2 * drift["gnss"]


@pytest.mark.slow
def test_corrected_visual_data_is_consistent_and_bounds_the_outage(data):
    """examples/canada-planetary.yaml exchanges the visual east/north and shifts its clock by
    7.5 s: its innovations become consistent (NIS/dof near 1 instead of ~60) and the drift
    through the sparse file's GNSS outage (100-200 s) falls from ~35 m (as filed) to a few m."""
    import numpy as np

    from fednav.process.output import consistency

    cfg = load_system(ROOT / "examples" / "canada-planetary.yaml")
    as_filed = cfg.model_copy(update={"sensors": cfg.sensors.replace(velocity=None)})
    res = process(data["imu"], {"gnss": data["gnss"], "velocity": data["visual"]}, cfg)
    c = consistency(res.forward)["velocity"]
    assert 0.7 < c["nis_per_dof"] < 1.5 and c["isolated_fraction"] < 0.15
    g = read_navego_gnss(DATA / "gnss_sparse_planetary.mat")
    drift = {}
    for name, c in (("fixed", cfg), ("as filed", as_filed)):
        e = errors_against(process(data["imu"], {"gnss": g, "velocity": data["visual"]},
                                   c).forward, data["ref"])
        m = (e["t"] > 100) & (e["t"] < 200)
        drift[name] = float(np.hypot(e["north_m"][m], e["east_m"][m]).max())
    assert drift["fixed"] < 6.0 and drift["fixed"] < 0.3 * drift["as filed"]

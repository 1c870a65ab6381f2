"""The solution exported for Google Earth, GPS tools and a GIS (``--export``), each file
opened back with a reader of its format and compared with the solution it came from."""

import json
import xml.etree.ElementTree as ET
from dataclasses import replace

import numpy as np
import pytest
from test_process import make_flight

from fednav import load_system
from fednav.core import units
from fednav.process import process
from fednav.process.export import SIGMA_BINS_M, check_exports, write_exports
from fednav.process.output import decimate

KML = "{http://www.opengis.net/kml/2.2}"


@pytest.fixture(scope="module")
def run():
    imu, gnss, _ = make_flight()
    cfg = load_system({"sensors": {"gnss": {"outages_s": [[100.0, 130.0]]}}})
    res = process(imu, {"gnss": gnss}, cfg)
    return decimate(res.forward, 1.0), res.outages


def test_kml_track_coloured_by_sigma_with_the_outage_apart(run, tmp_path):
    sol, outages = run
    (p,) = write_exports(tmp_path, sol, ("kml",), outages)
    root = ET.parse(p).getroot()
    folders = {f.find(f"{KML}name").text: f for f in root.iter(f"{KML}Folder")}
    track = folders["track, coloured by horizontal 1-sigma"]
    lines = track.findall(f".//{KML}LineString/{KML}coordinates")
    pts = [tuple(map(float, c.split(","))) for ln in lines for c in ln.text.split()]
    lon, lat = units.to_deg(sol.lla[:, 1]), units.to_deg(sol.lla[:, 0])
    # every row once, and each run's last point again as the next run's first
    assert len(pts) == len(sol.t) + len(lines) - 1
    np.testing.assert_allclose(pts[0][:2], [lon[0], lat[0]], atol=1e-9)
    np.testing.assert_allclose(pts[-1][:2], [lon[-1], lat[-1]], atol=1e-9)
    s = np.hypot(sol.sigma[:, 6], sol.sigma[:, 7])
    assert len(lines) == 1 + np.count_nonzero(np.diff(np.digitize(s, SIGMA_BINS_M)))
    names = [m.find(f"{KML}name").text for m in folders["outages"].iter(f"{KML}Placemark")]
    assert names == ["gnss outage 100-130 s"]
    assert all(a.text == "clampToGround" for a in root.iter(f"{KML}altitudeMode"))


def test_gpx_points_and_their_times(run, tmp_path):
    import gpxpy

    sol, _ = run
    (p,) = write_exports(tmp_path, sol, ("gpx",))
    g = gpxpy.parse(p.read_text())
    pts = g.tracks[0].segments[0].points
    assert len(pts) == len(sol.t) and pts[0].time is None  # (t from 0: not absolute)
    np.testing.assert_allclose([pts[5].latitude, pts[5].longitude, pts[5].elevation],
                               [*units.to_deg(sol.lla[5, :2]), sol.lla[5, 2]], atol=1e-6)
    # seconds since 1970 (an RTKLIB clock): date-times
    late = replace(sol, t=sol.t + 1752003258.5)
    (p,) = write_exports(tmp_path, late, ("gpx",))
    pts = gpxpy.parse(p.read_text()).tracks[0].segments[0].points
    assert pts[0].time.timestamp() == pytest.approx(late.t[0], abs=1e-6)  # (2025-07-08)
    assert (pts[1].time - pts[0].time).total_seconds() == pytest.approx(sol.t[1] - sol.t[0])


def test_geojson_is_lon_lat_h_with_the_outage(run, tmp_path):
    import geojson

    sol, outages = run
    (p,) = write_exports(tmp_path, sol, ("geojson",), outages)
    fc = geojson.loads(p.read_text())
    assert fc.is_valid and len(fc["features"]) == 2
    line = fc["features"][0]
    c = np.array(line["geometry"]["coordinates"])
    np.testing.assert_allclose(c[:, 0], units.to_deg(sol.lla[:, 1]), atol=1e-8)  # lon first
    np.testing.assert_allclose(c[:, 2], sol.lla[:, 2], atol=1e-8)
    assert len(line["properties"]["t_s"]) == len(sol.t)
    assert json.loads(p.read_text())["features"][1]["properties"]["outage_s"] == [100, 130]


def test_export_requests_are_checked_first():
    assert check_exports("KML, gpx,kml") == ("kml", "gpx")
    assert check_exports(None) == ()
    with pytest.raises(ValueError, match=r"--export shp: must be one or more of kml, gpx, "
                                         r"geojson"):
        check_exports("kml,shp")


def write_short_flight(folder, n: int = 3000, velocity: bool = True) -> None:
    """The first ``n`` IMU samples of the test flight and its fixes over them as fednav
    CSV files ``imu.csv`` and ``gnss.csv`` in ``folder`` (17 significant digits)."""
    from fednav.io.csvdata import write_csv

    imu, gnss, _ = make_flight()
    write_csv(folder / "imu.csv", {"t_s": imu.t[:n], **{
        f"{k}_{a}_{u}": v[:n, i] for k, v, u in (("gyro", imu.gyro, "radps"),
                                                 ("accel", imu.accel, "mps2"))
        for i, a in enumerate("xyz")}}, significant=17)
    g = gnss.t < imu.t[n - 1]
    cols = {"t_s": gnss.t[g], "lat_deg": units.to_deg(gnss.lla[g, 0]),
            "lon_deg": units.to_deg(gnss.lla[g, 1]), "h_m": gnss.lla[g, 2]}
    if velocity:
        cols.update({"vE_mps": gnss.vel[g, 0], "vN_mps": gnss.vel[g, 1],
                     "vU_mps": gnss.vel[g, 2]})
    write_csv(folder / "gnss.csv", cols, significant=17)


def test_cli_writes_the_exports_beside_the_solution(tmp_path):
    from typer.testing import CliRunner

    from fednav.cli import app

    write_short_flight(tmp_path)
    args = ["process", "csv", "--imu", str(tmp_path / "imu.csv"), "--gnss",
            str(tmp_path / "gnss.csv"), "--out", str(tmp_path / "out")]
    r = CliRunner().invoke(app, [*args, "--export", "kml,gpx,geojson"])
    assert r.exit_code == 0, r.output
    for k in ("kml", "gpx", "geojson"):
        assert (tmp_path / "out" / f"solution.{k}").stat().st_size > 1000
    r = CliRunner().invoke(app, [*args, "--export", "shp"])
    assert r.exit_code == 2 and "--export shp" in r.output and "Traceback" not in r.output

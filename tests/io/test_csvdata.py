"""fednav CSV layout: round trip, units at the edge and one-line errors."""

import numpy as np
import pytest

from fednav.core import units
from fednav.io import DataError, read_gnss_csv, read_imu_csv, read_reference_csv
from fednav.io.csvdata import IMU_COLUMNS, write_csv


def _imu_cols(n=20):
    t = np.arange(n) * 0.01
    cols = {"t_s": t}
    for i, c in enumerate(IMU_COLUMNS[1:]):
        cols[c] = np.full(n, 0.1 * (i + 1))
    return cols


def test_imu_round_trip(tmp_path):
    p = write_csv(tmp_path / "imu.csv", _imu_cols())
    imu = read_imu_csv(p)
    np.testing.assert_allclose(imu.gyro[0], [0.1, 0.2, 0.3])
    np.testing.assert_allclose(imu.accel[0], [0.4, 0.5, 0.6])
    assert imu.errors is None


def test_gnss_and_reference_degrees_in_radians_inside(tmp_path):
    n = 4
    p = write_csv(tmp_path / "g.csv", {"t_s": np.arange(n), "lat_deg": np.full(n, 45.0),
                                       "lon_deg": np.full(n, -73.0), "h_m": np.full(n, 10.0)})
    g = read_gnss_csv(p)
    assert g.lla[0, 0] == pytest.approx(units.deg(45.0)) and g.vel is None
    p = write_csv(tmp_path / "r.csv", {"t_s": np.arange(n), "lat_deg": np.full(n, 45.0),
                                       "lon_deg": np.full(n, -73.0), "h_m": np.full(n, 10.0),
                                       "vE_mps": np.ones(n), "vN_mps": np.zeros(n),
                                       "vU_mps": np.zeros(n), "pitch_deg": np.zeros(n),
                                       "roll_deg": np.zeros(n), "heading_deg": np.full(n, 90.0)})
    r = read_reference_csv(p)
    assert r.euler[0, 2] == pytest.approx(np.pi / 2)


def test_missing_column_and_bad_value(tmp_path):
    cols = _imu_cols()
    del cols["accel_z_mps2"]
    p = write_csv(tmp_path / "imu.csv", cols)
    with pytest.raises(DataError, match="missing column.*accel_z_mps2"):
        read_imu_csv(p)
    p = tmp_path / "imu2.csv"
    lines = write_csv(p, _imu_cols()).read_text().splitlines()
    lines[5] = lines[5].replace("0.4", "abc", 1)
    p.write_text("\n".join(lines))
    with pytest.raises(DataError, match="column 'accel_x_mps2' has a non-numeric value "
                                        "'abc' at data row 5"):
        read_imu_csv(p)


def test_time_going_backwards(tmp_path):
    cols = _imu_cols()
    cols["t_s"][7] = cols["t_s"][5]
    with pytest.raises(DataError, match="'t_s' is not increasing at row 7"):
        read_imu_csv(write_csv(tmp_path / "imu.csv", cols))

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


def test_pyarrow_and_pandas_read_a_file_alike(tmp_path):
    """The fast reader (pyarrow) and the explaining one (pandas) give the same columns:
    a byte-order mark, spaces after the commas, empty cells, nan and inf, a text column
    beside the numbers."""
    from fednav.io import csvdata

    p = tmp_path / "g.csv"
    p.write_text("\ufefft_s, lat_deg, lon_deg,h_m,note\n"
                 "0.0, 45.1, 7.25,,a\n0.2,nan,7.3,inf,b\n0.4, 45.2 , -7.3e-1,-inf,\n",
                 encoding="utf-8")
    numbers = {"t_s", "lat_deg", "lon_deg", "h_m"}
    fast = csvdata._arrow_columns(p, numbers)
    slow = csvdata._pandas_columns(p, str(p), numbers)
    assert fast is not None and fast.names == slow.names
    assert fast.names == ["t_s", "lat_deg", "lon_deg", "h_m", "note"]
    assert fast.rows == slow.rows == 3
    for c in numbers:
        np.testing.assert_array_equal(fast.column(c), slow.column(c))
    np.testing.assert_array_equal(fast.column("h_m"), [np.nan, np.inf, -np.inf])
    assert "note" not in fast and "note" not in slow  # (named, not held)


def test_text_in_a_number_column_is_explained_by_pandas(tmp_path):
    from fednav.io import csvdata

    p = tmp_path / "imu.csv"
    p.write_text("t_s,gyro_x_radps\n0.0,0.1\n0.01,zero\n")
    assert csvdata._arrow_columns(p, {"t_s", "gyro_x_radps"}) is None
    with pytest.raises(DataError, match=r"column 'gyro_x_radps' has a non-numeric value "
                                        r"'zero' at data row 2"):
        csvdata._read(p, "IMU", ("t_s",), ("gyro_x_radps",))


def test_reading_csv_files_leaves_pandas_unimported(tmp_path):
    """pyarrow reads the files; pandas (0.3 s of a command's start) is not imported."""
    import subprocess
    import sys

    p = tmp_path / "imu.csv"
    p.write_text("t_s,gyro_x_radps,gyro_y_radps,gyro_z_radps,accel_x_mps2,accel_y_mps2,"
                 "accel_z_mps2\n" + "".join(f"{0.01 * i},0,0,0,0,0,9.8\n" for i in range(50)))
    code = ("import sys; from fednav.io import read_imu_csv; "
            f"imu = read_imu_csv({str(p)!r}); assert len(imu.t) == 50; "
            "print('pandas' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["False"]

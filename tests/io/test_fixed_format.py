"""Compiled fixed-decimal CSV formatting (fednav.io.fixed_format) and write_csv's use of it."""

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from fednav.io.csvdata import write_csv
from fednav.io.fixed_format import format_rows


def parse(text: bytes) -> np.ndarray:
    return np.array([[float(v) for v in line.split(",")] for line in text.decode().splitlines()])


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-1e6, 1e6, allow_nan=False), min_size=4, max_size=40),
       st.integers(0, 9))
def test_values_read_back_within_half_a_unit_of_the_last_decimal(values, d):
    X = np.array(values, dtype=float).reshape(-1, 1).repeat(2, axis=1)
    X[:, 1] *= -1.0
    back = parse(format_rows(X, [d, d]))
    assert back.shape == X.shape
    assert np.all(np.abs(back - X) <= 0.5 * 10.0**-d * (1 + 1e-9) + 1e-9 * np.abs(X))


def test_rounding_signs_and_non_finite_values():
    X = np.array([[np.nan, -np.inf, np.inf, -1e-7, 0.5, -2.5, 1e5, 51.0512345678]])
    out = format_rows(X, [3, 3, 3, 3, 0, 0, 2, 9]).decode()
    assert out == "nan,-inf,inf,0.000,1,-3,100000.00,51.051234568\n"


def test_too_large_for_the_decimals_falls_back_to_g_format(tmp_path):
    assert format_rows(np.array([[1e12]]), [9]) is None
    p = write_csv(tmp_path / "x.csv", {"a": np.array([1e12, 2.0]), "b": np.array([1.25, 3.0])},
                  {"a": 9, "b": 2})
    f = pd.read_csv(p)
    assert list(f.columns) == ["a", "b"] and f.a.tolist() == [1e12, 2.0]


def test_write_csv_with_decimals(tmp_path):
    t = 0.005 * np.arange(1000)
    p = write_csv(tmp_path / "s.csv", {"t_s": t, "v": np.sin(t)}, {"t_s": 6, "v": 5})
    f = pd.read_csv(p)
    np.testing.assert_allclose(f.t_s, t, atol=5e-7)
    np.testing.assert_allclose(f.v, np.sin(t), atol=5e-6)
    assert p.read_text().splitlines()[3] == "0.010000,0.01000"

import numpy as np
import pytest

from fednav.core import units as u


def test_round_trips():
    assert u.to_deg(u.deg(30.0)) == pytest.approx(30.0)
    assert u.to_arcsec(u.arcsec(3.0)) == pytest.approx(3.0)
    assert u.to_deg_per_h(u.deg_per_h(0.01)) == pytest.approx(0.01)
    assert u.to_micro_g(u.micro_g(100.0)) == pytest.approx(100.0)


def test_values():
    assert u.deg(180.0) == pytest.approx(np.pi)
    assert u.arcsec(3600.0) == pytest.approx(np.pi / 180)
    assert u.deg_per_h(1.0) == pytest.approx(np.pi / 180 / 3600)
    assert u.deg_per_sqrt_h(1.0) == pytest.approx(np.pi / 180 / 60)
    assert u.micro_g(1e6) == pytest.approx(9.80665)
    np.testing.assert_allclose(u.deg([0.0, 90.0]), [0.0, np.pi / 2])

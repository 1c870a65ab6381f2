"""How a human table prints a number: three significant figures, attitude figures in
degrees or, below :data:`ARCSEC_BELOW_DEG`, arc-seconds.  The one place of these rules
(``fednav process``'s console tables, the designs', the papers' and the HTML report's);
numpy only, so a command that prints a table does not import the campaign reports'
pandas."""

from __future__ import annotations

import re

import numpy as np

from ..core import units


def format_number(x: float | None) -> str:
    """A table number with 3 significant figures (whole numbers from 100 up); "–" for
    a missing or non-finite value."""
    if x is None or not np.isfinite(x):
        return "–"
    a = abs(x)
    if a >= 100:
        return f"{x:.0f}"
    if a >= 10:
        return f"{x:.1f}"
    if a >= 1:
        return f"{x:.2f}"
    return f"{x:.3g}"


#: Attitude figures below this magnitude [deg] are printed in arc-seconds.
ARCSEC_BELOW_DEG = 0.01
#: Table keys of attitude errors in degrees (designs, paper 003, ``fednav process``).
_ATTITUDE_DEG = re.compile(r"(pitch|roll|yaw|heading)_deg")


def is_attitude_deg(key) -> bool:
    """Whether a table key is an attitude error in degrees (``pitch_deg``, ``roll_deg``,
    ``yaw_deg``, ``heading_deg``): the keys :func:`format_attitude` prints."""
    return bool(_ATTITUDE_DEG.fullmatch(str(key)))


def attitude_unit(value_deg) -> tuple[float, str]:
    """The unit a human table prints an attitude figure [deg] in, as (factor from
    degrees, suffix): arc-seconds ``(3600, "″")`` when its magnitude is below
    :data:`ARCSEC_BELOW_DEG` (a star sensor's 0.0034° reads 12.2″, not 0.003 or 0.000),
    else ``(1, "")`` (degrees, the column's unit).  The one place of this rule; machine
    outputs (JSON, CSV) keep degrees."""
    if value_deg is None or not np.isfinite(value_deg) or abs(value_deg) >= ARCSEC_BELOW_DEG:
        return 1.0, ""
    return float(units.to_arcsec(units.DEG)), "″"


def format_attitude(value_deg, unit_of=None, fmt=format_number) -> str:
    """An attitude figure [deg] for a human table (:func:`attitude_unit`): ``fmt`` of the
    number in its unit, with ``″`` when that is arc-seconds; "–" for a missing or
    non-finite value.  ``unit_of`` [deg]: take the unit of this figure instead (a
    confidence interval is printed in its value's unit)."""
    if value_deg is None or not np.isfinite(value_deg):
        return "–"
    k, suffix = attitude_unit(value_deg if unit_of is None else unit_of)
    return f"{fmt(value_deg * k)}{suffix}"

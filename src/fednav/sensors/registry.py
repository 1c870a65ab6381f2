"""The sensor registry: every aiding sensor fednav knows, by name.

Adding a sensor is one module (its :class:`~fednav.sensors.spec.SensorConfig`, simulator,
measurement model and file columns, see :mod:`fednav.sensors.star` for the shape) and one
line in :data:`SENSORS`.  The system description's ``sensors:`` section, the names a
mode's ``aiding`` list and a fault accept, the CLI's sensor-file options and the docs
table are read from here; :func:`register` adds a sensor at run time (a plug-in, or a
test's toy sensor).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping

from pydantic import ValidationError
from pydantic_core import core_schema

from ..core.config import nested_error, nested_validation_error
from . import airdata, baro, bodyvel, gnss, gnss_raw, mag, sar, sarvel, star, velocity, zaru
from .spec import SensorConfig, SensorSpec

#: name -> spec of every registered sensor, in the order a simulation draws their noise
#: from a run's generator (so seeded runs reproduce: new sensors go at the end).
SENSORS: dict[str, SensorSpec] = {s.name: s for s in (
    star.SPEC, sar.SPEC, gnss.SPEC, baro.SPEC, sarvel.SPEC, airdata.SPEC, velocity.SPEC,
    bodyvel.ODOMETER, bodyvel.DVL, bodyvel.ZUPT, mag.SPEC, bodyvel.NHC, zaru.SPEC,
    gnss_raw.SPEC,
)}


def register(spec: SensorSpec) -> None:
    """Add a sensor (its name must be new)."""
    if spec.name in SENSORS:
        raise ValueError(f"a sensor called '{spec.name}' is registered already")
    SENSORS[spec.name] = spec


def unregister(name: str) -> None:
    """Remove a sensor added by :func:`register`."""
    SENSORS.pop(name, None)


def names(aiding: bool | None = None) -> list[str]:
    """Registered names (only those that can aid, or only those that cannot)."""
    return [n for n, s in SENSORS.items() if aiding is None or s.aiding == aiding]


def spec(name: str) -> SensorSpec:
    """The spec of sensor ``name``; a one-line error naming the registered ones."""
    try:
        return SENSORS[name]
    except KeyError:
        raise ValueError(f"unknown sensor '{name}'; registered: "
                         f"{', '.join(sorted(SENSORS))}") from None


def fix_sensor(names=None) -> str | None:
    """The first of ``names`` (default: every registered sensor) whose fixes start a
    recording (:attr:`SensorSpec.fixes`: the GNSS), or None."""
    return next((n for n in (SENSORS if names is None else names)
                 if n in SENSORS and SENSORS[n].fixes), None)


def start_sensor(names) -> str | None:
    """The first of ``names`` whose recording can start a run without a fix sensor's
    fixes (:attr:`SensorSpec.start`: the raw GNSS's single-point solutions), or None."""
    return next((n for n in names if n in SENSORS and SENSORS[n].start is not None), None)


def label(name: str | None) -> str:
    """How messages name sensor ``name`` (its spec's ``label``, else the name; None:
    the sensor whose fixes start a run, :func:`fix_sensor`)."""
    name = fix_sensor() if name is None else name
    return (SENSORS[name].label or name) if name in SENSORS else str(name)


def total_models() -> dict:
    """The total-state navigator's measurement model of each sensor that has one."""
    return {n: s.total for n, s in SENSORS.items() if s.total is not None}


def check_names(values, what: str = "sensor", aiding: bool = False) -> list[str]:
    """``values`` (sensor names) checked against the registry."""
    ok = names(True) if aiding else list(SENSORS)
    for v in values:
        if v not in ok:
            raise ValueError(f"unknown {what} '{v}'; registered: {', '.join(sorted(ok))}")
    return list(values)


def markdown_table() -> str:
    """The registry as a Markdown table (``docs/architecture.md`` holds its output)."""
    rows = ["| sensor | what it measures | file columns (after `t_s`) | local filter | "
            "compiled |", "|---|---|---|---|---|"]
    for s in SENSORS.values():
        cols = s.columns_doc or ", ".join(f"`{c.name}`" for c in s.columns)
        rows.append(f"| `{s.name}` | {s.summary} | {cols} | "
                    f"{'yes' if s.aiding else 'no (constraint)'} | "
                    f"{'yes' if s.compiled else 'Python loop'} |")
    return "\n".join(rows)


class SensorSet(Mapping):
    """The ``sensors:`` section: registered sensor name -> its config.

    Read like the section: ``sensors.gnss`` (None when the system has no GNSS),
    ``sensors["star"]``, ``for name in sensors``.  Validated against the registry at the
    time it is read, so a sensor registered at run time is accepted."""

    def __init__(self, configs: Mapping[str, SensorConfig] | None = None):
        self._d = dict(configs or {})

    def __getattr__(self, name: str):
        if name.startswith("_"):
            raise AttributeError(name)
        if name in SENSORS or name in self._d:
            return self._d.get(name)
        raise AttributeError(f"no sensor '{name}' is registered")

    def __getitem__(self, name: str) -> SensorConfig:
        return self._d[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._d)

    def __len__(self) -> int:
        return len(self._d)

    def __eq__(self, other) -> bool:
        return isinstance(other, SensorSet) and self._d == other._d

    def __hash__(self) -> int:
        return hash(tuple(self._d.items()))

    def __repr__(self) -> str:
        return f"SensorSet({self._d!r})"

    def replace(self, **changes) -> SensorSet:
        """A copy with some sections replaced (a value None removes the sensor)."""
        d = {**self._d, **changes}
        return SensorSet({k: v for k, v in d.items() if v is not None})

    @classmethod
    def validate(cls, value, info=None) -> SensorSet:
        """``value`` (a mapping of sensor name -> its section) as a :class:`SensorSet`;
        ``info``: pydantic's validation info, whose context (the description's
        ``folder``) each section is validated with."""
        context = getattr(info, "context", None)
        if isinstance(value, SensorSet):
            return value
        if value is None:
            return cls()
        if not isinstance(value, Mapping):
            raise nested_error([], "expected a mapping of sensor name -> its settings")
        out = {}
        for name, cfg in value.items():
            if name not in SENSORS:
                raise nested_error([name], f"unknown sensor (registered: "
                                           f"{', '.join(sorted(SENSORS))})")
            if cfg is None:
                continue
            model = SENSORS[name].config
            if isinstance(cfg, model):
                out[name] = cfg
            else:
                try:
                    out[name] = model.model_validate(cfg, context=context)
                except ValidationError as e:
                    raise nested_validation_error([name], e) from None
            why = SENSORS[name].check_geometry(out[name])
            if why is not None:
                key, _, text = why.partition(": ")
                raise nested_error([name, key], text)
        return cls(out)

    def dump(self) -> dict:
        return {k: v.model_dump(mode="json") for k, v in self._d.items()}

    @classmethod
    def __get_pydantic_core_schema__(cls, source, handler):
        return core_schema.with_info_plain_validator_function(
            cls.validate, serialization=core_schema.plain_serializer_function_ser_schema(
                lambda v: v.dump()))

"""YAML files validated by pydantic: the one-line errors every fednav file reader gives.

Keys carry their unit in the name (``_deg``, ``_arcsec``, ``_deg_h``, ``_ug``, ``_m``,
``_s`` ...).  An unknown key, a wrong type or a missing value is reported in one line
naming the key and the file (:class:`ConfigError`).
"""

from __future__ import annotations

from pathlib import Path

import yaml
from pydantic import BaseModel, ConfigDict, ValidationError
from pydantic_core import PydanticCustomError

from .errors import FednavError


class ConfigError(FednavError, ValueError):
    """A scenario file that cannot be used; the message names the file and the key."""


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


def simulation_only(why: str) -> dict:
    """A field's ``json_schema_extra`` saying that processing recorded data does not use
    it, and why (``fednav process`` names such a key when a config sets it:
    :func:`fednav.process.checks.ignored_keys`)."""
    return {"simulation_only": why}


def recording_only(why: str) -> dict:
    """A field's ``json_schema_extra`` saying that only processing a recording uses it
    (``fednav process``), and what it acts on (``fednav run`` names such a key when a
    design sets it: :meth:`fednav.campaign.design.Design.load_scenario`)."""
    return {"recording_only": why}


def recording_only_keys(model) -> list[str]:
    """The top-level keys ``model`` sets that are :func:`recording_only`, each with what
    it acts on."""
    out = []
    for key in sorted(model.model_fields_set):
        extra = type(model).model_fields[key].json_schema_extra
        if isinstance(extra, dict) and extra.get("recording_only"):
            out.append(f"{key} ({extra['recording_only']})")
    return out


def nested_error(path: list, message: str) -> PydanticCustomError:
    """An error found inside a value that a validator checks by hand (a section whose
    keys depend on a registry): reported as ``key 'outer.path': message``."""
    return PydanticCustomError("nested", "{message}",
                               {"path": ".".join(str(p) for p in path), "message": message})


def nested_validation_error(path: list, e: ValidationError) -> PydanticCustomError:
    """:func:`nested_error` for the first error of ``e`` (a section validated by hand)."""
    errs = sorted(e.errors(), key=lambda x: x["type"] != "extra_forbidden")
    inner = _format_error(errs[0])
    key, _, msg = inner.partition("': ")
    key = key.removeprefix("key '")
    return nested_error([*path, key] if key != "(top level)" else path, msg)


def _format_error(e: dict) -> str:
    loc = ".".join(str(p) for p in e["loc"]) or "(top level)"
    msg = e["msg"]
    if e["type"] == "nested":
        ctx = e["ctx"]
        loc = ".".join(p for p in (loc if e["loc"] else "", ctx["path"]) if p)
        return f"key '{loc}': {ctx['message']}"
    msg = msg.removeprefix("Value error, ")
    if e["type"] == "extra_forbidden":
        msg = "unknown key"
    elif e["type"] == "missing":
        msg = "missing value"
    elif "input" in e and not isinstance(e["input"], dict | list):
        got = repr(e["input"])
        msg = f"{msg} (got {got if len(got) <= 40 else got[:37] + '...'})"
    return f"key '{loc}': {msg}"


def read_text_file(path: Path, what: str) -> str:
    """The text of a UTF-8 file (a byte-order mark is accepted), or a one-line
    :class:`ConfigError` naming the file and why it cannot be read."""
    try:
        return path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        why = "not found"
    except IsADirectoryError:
        why = "is a folder, not a file"
    except UnicodeDecodeError:
        why = "not a UTF-8 text file"
    except OSError as e:
        why = f"cannot be read ({e.strerror or e})"
    raise ConfigError(f"{what} file {path}: {why}")


class _UniqueKeyLoader(yaml.SafeLoader):
    """YAML's safe loader, refusing a key given twice in one mapping (PyYAML keeps the
    last one silently: a config's second ``sigma_mps`` would win unseen)."""


def _unique_mapping(loader, node, deep=False):
    seen = {}
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"key '{key}' given twice (lines {seen[key] + 1} and "
                f"{key_node.start_mark.line + 1})", key_node.start_mark)
        seen[key] = key_node.start_mark.line
    return loader.construct_mapping(node, deep=deep)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG,
                                 _unique_mapping)


def parse_yaml(text: str):
    """YAML ``text`` parsed safely, a key given twice in one mapping refused
    (``yaml.YAMLError``)."""
    return yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 (a SafeLoader subclass)


def read_mapping(path: str | Path, what: str = "scenario") -> dict:
    """The top-level mapping of a YAML file (errors: :class:`ConfigError`, one line; a key
    given twice is one)."""
    path = Path(path)
    text = read_text_file(path, what)
    try:
        data = parse_yaml(text)
    except yaml.YAMLError as e:
        raise ConfigError(f"{what} file {path}: not valid YAML ({str(e).splitlines()[0]})") \
            from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{what} file {path}: expected a mapping at the top level")
    return data


def validate(data: dict, model: type[BaseModel], where: str, folder: Path | None = None):
    """``data`` validated as ``model``; a :class:`ConfigError` of one line, ``where``
    (the file, or what the mapping is) first, naming the key.  ``folder``: the file's
    (the validation context's ``folder``: what a path key is relative to)."""
    try:
        return model.model_validate(data, context=None if folder is None else
                                    {"folder": Path(folder)})
    except ValidationError as e:
        # An unknown key is usually a misspelt one: report it before the "missing" it causes.
        errs = sorted(e.errors(), key=lambda x: x["type"] != "extra_forbidden")
        more = f" (and {len(errs) - 1} more)" if len(errs) > 1 else ""
        raise ConfigError(f"{where}: {_format_error(errs[0])}{more}") from None


def load_model(path: str | Path, model: type[BaseModel], what: str = "scenario"):
    """Read a YAML file into the pydantic ``model`` (errors: :class:`ConfigError`, one line
    naming the file and the key)."""
    return validate(read_mapping(path, what), model, f"{what} file {path}", Path(path).parent)

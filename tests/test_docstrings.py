"""Every name exported from ``fednav`` (``fednav.__all__``, docs/api.md) has a numpydoc
docstring: a summary, ``Parameters`` naming exactly the signature's parameters (a class:
its constructor's, under ``Parameters`` or, for a result a caller receives, ``Attributes``)
and ``Returns`` for a function that returns something; every entry has a type and a
description (``*args``/``**kwargs`` need no type), and every number or array says its
unit in brackets (``[m]``, ``[rad]``, ``[s]``, ``[-]`` for none) — the frame with it.
A class's public methods are held to the same rules; its properties need a docstring.

A small parser of numpydoc's layout (section title, dashes, ``name : type`` entries with
indented descriptions) — no dependency beyond the standard library."""

from __future__ import annotations

import inspect
import re
import textwrap

import pytest

import fednav

_TITLE = re.compile(r"^([A-Z][A-Za-z ]+)\n-{3,}[ \t]*$", re.M)
_UNIT = re.compile(r"\[[^\]]+\]")
#: types whose entries must name a unit
_NUMERIC = re.compile(r"\b(float|ndarray|array|int)\b")


def sections(doc: str) -> tuple[str, dict[str, str]]:
    """(summary, {section title: body}) of a numpydoc docstring."""
    doc = inspect.cleandoc(doc)
    parts = _TITLE.split(doc)
    out = {}
    for title, body in zip(parts[1::2], parts[2::2], strict=True):
        out[title.strip()] = body
    return parts[0].strip(), out


def entries(body: str) -> list[tuple[str, str, str]]:
    """[(name, type, description)] of a Parameters/Returns/Attributes body."""
    body = textwrap.dedent(body.strip("\n"))
    out: list[list[str]] = []
    for line in body.splitlines():
        if not line.strip():
            if out:
                out[-1][2] += "\n"
            continue
        if not line[0].isspace():
            name, _, typ = line.partition(" : ")
            out.append([name.strip(), typ.strip(), ""])
        elif out:
            out[-1][2] += line.strip() + " "
    return [(n, t, d.strip()) for n, t, d in out]


def _params(obj) -> list[str]:
    names = []
    for p in inspect.signature(obj).parameters.values():
        if p.name in ("self", "cls"):
            continue
        names.append({p.VAR_POSITIONAL: "*", p.VAR_KEYWORD: "**"}.get(p.kind, "") + p.name)
    return names


def problems(obj, where: str, *, is_class: bool = False) -> list[str]:
    """What the docstring of ``obj`` (a function, method or class) lacks."""
    doc = inspect.getdoc(obj) if is_class else obj.__doc__
    if not doc or not doc.strip():
        return [f"{where}: no docstring"]
    summary, secs = sections(doc)
    out = []
    if not summary:
        out.append(f"{where}: no summary line")
    expected = _params(obj)
    title = "Parameters"
    if is_class and "Parameters" not in secs and "Attributes" in secs:
        title = "Attributes"
    documented = entries(secs.get(title, ""))
    names = [n for n, _, _ in documented]
    if expected and title not in secs:
        out.append(f"{where}: no Parameters section ({', '.join(expected)})")
    else:
        missing = [n for n in expected if n not in names]
        extra = [n for n in names if n not in expected]
        if missing:
            out.append(f"{where}: {title} lacks {', '.join(missing)}")
        if extra:
            out.append(f"{where}: {title} names {', '.join(extra)}, not in the signature")
    returned = []
    if not is_class:
        ret = inspect.signature(obj).return_annotation
        if ret not in (None, "None", inspect.Signature.empty) or "Returns" in secs:
            if "Returns" not in secs:
                out.append(f"{where}: no Returns section")
            returned = entries(secs.get("Returns", ""))
            if "Returns" in secs and not returned:
                out.append(f"{where}: an empty Returns section")
    for kind, items in ((title, documented), ("Returns", returned)):
        for name, typ, desc in items:
            if not typ and kind != "Returns" and not name.startswith("*"):
                out.append(f"{where}: {kind} entry '{name}' has no type")
            if not desc:
                out.append(f"{where}: {kind} entry '{name}' has no description")
            elif _NUMERIC.search(typ or name) and not _UNIT.search(desc):
                out.append(f"{where}: {kind} entry '{name}' ({typ}) names no unit in "
                           f"brackets ([m], [rad], [s], [-] ...)")
    return out


def _members(cls) -> list[tuple[str, object]]:
    """The public methods and properties a class defines itself."""
    out = []
    for name, v in vars(cls).items():
        if name.startswith("_"):
            continue
        if inspect.isfunction(v) or isinstance(v, property | staticmethod | classmethod) \
                or type(v).__name__ == "cached_property":
            out.append((name, v))
    return out


def _cases():
    for name in fednav.__all__:
        obj = getattr(fednav, name)
        yield pytest.param(name, obj, id=name)


@pytest.mark.parametrize(("name", "obj"), list(_cases()))
def test_exported_names_have_numpydoc_docstrings(name, obj):
    if inspect.isclass(obj):
        found = problems(obj, name, is_class=True)
        for member, v in _members(obj):
            where = f"{name}.{member}"
            if isinstance(v, property) or type(v).__name__ == "cached_property":
                doc = (v.fget if isinstance(v, property) else v.func).__doc__
                if not doc or not doc.strip():
                    found.append(f"{where}: no docstring")
            else:
                found += problems(getattr(obj, member), where)
    else:
        found = problems(obj, name)
    assert not found, "\n".join(found)


def test_the_parser_reads_numpydoc():
    def f(x, *args, y=1.0, **kw) -> float:
        """Sum.

        Parameters
        ----------
        x : float
            A length [m],
            on two lines.
        *args : float
            More lengths [m].
        y : float
            Scale.
        **kw
            Ignored.

        Returns
        -------
        float
            The sum [m].
        """

    assert problems(f, "f") == ["f: Parameters entry 'y' (float) names no unit in brackets "
                                "([m], [rad], [s], [-] ...)"]  # (**kw: no type, as usual)
    summary, secs = sections(f.__doc__)
    assert summary == "Sum." and set(secs) == {"Parameters", "Returns"}
    assert entries(secs["Parameters"])[0] == ("x", "float", "A length [m], on two lines.")

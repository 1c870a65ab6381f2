"""Output files that are complete or absent.

Every result file is written under a temporary name in its folder and renamed onto its
final name when complete (``os.replace`` is atomic on POSIX and Windows), so a run
killed at any moment leaves either the previous complete file or none — never a
truncated one.  ``summary.json`` is written last: its presence means the run finished.
:func:`clear_results` removes a previous run's ``summary.json`` and ``report.html``
when a new run starts, so a run that fails never leaves an older result looking like
its own.

A file that cannot be written (a full disk, a read-only folder, a quota) raises
:class:`OutputError`, whose one-line message names the file and the reason; the earlier
complete files stay as they are and the one being written keeps its previous content.
"""

from __future__ import annotations

import errno
import json
import math
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from .errors import FednavError

#: Files that mark a finished run (removed when a new run starts in the folder).
RESULT_MARKERS = ("summary.json", "report.html")


class OutputError(FednavError, OSError):
    """A result file that cannot be written: one line naming the file and why (a full
    disk, no permission ...); ``errno`` and ``filename`` as the :class:`OSError` it
    replaces."""

    def __init__(self, message: str, errno_: int | None = None, filename=None):
        super().__init__(message)
        self.message = message
        self.errno, self.filename = errno_, None if filename is None else str(filename)

    def __str__(self) -> str:
        return self.message


#: What a failed write most likely means, by errno (the system's text otherwise).
_WHY = {errno.ENOSPC: "no space left on the device (the disk is full)",
        errno.EDQUOT: "disk quota exceeded",
        errno.EACCES: "permission denied", errno.EPERM: "permission denied",
        errno.EROFS: "read-only file system"}


def output_error(path, err: OSError, doing: str = "write") -> OutputError:
    """The :class:`OutputError` for ``err``, raised while ``doing`` (write, remove,
    create) ``path``."""
    why = _WHY.get(err.errno) or err.strerror or str(err)
    return OutputError(f"cannot {doing} {path}: {why}", err.errno, path)


@contextmanager
def replacing(path) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (hidden, ending in ``.tmp`` so no reader
    globbing ``*.nc`` or ``*.csv`` takes it for a result); it replaces ``path`` when the
    block ends without an exception and is removed otherwise.

    Raises
    ------
    OutputError
        When the block or the rename fails with an :class:`OSError` (a full disk, a
        read-only folder): one line naming ``path``; ``path`` is left as it was.
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        yield tmp
        os.replace(tmp, path)
    except OutputError:
        raise
    except OSError as e:
        raise output_error(path, e) from e
    finally:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:
            pass  # (a folder that refused the file refuses its removal: nothing is there)


def write_text(path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    with replacing(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def json_safe(obj, nulls: list | None = None, _at: tuple = ()):
    """``obj`` with every non-finite float replaced by None (JSON has no NaN or
    Infinity: a strict reader refuses them) and numpy scalars as Python's.

    Parameters
    ----------
    obj
        Dicts, lists, tuples, numpy arrays and scalars, numbers, strings, None.
    nulls
        If given, ``(path, value)`` is appended for each replaced number: ``path`` the
        keys and indices leading to it, ``value`` the float replaced.

    Returns
    -------
    object
        The same structure, every float finite or None.
    """
    if isinstance(obj, dict):
        return {str(k): json_safe(v, nulls, (*_at, str(k))) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [json_safe(v, nulls, (*_at, i)) for i, v in enumerate(obj)]
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist(), nulls, _at)
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        if nulls is not None:
            nulls.append((_at, obj))
        return None
    return obj


#: Key of the list that says why numbers of a JSON output are null (:func:`write_json`).
NULLS_KEY = "null_values"


def _pointer(path: tuple) -> str:
    """``path`` as a JSON Pointer (RFC 6901: ``~`` as ``~0``, ``/`` as ``~1``)."""
    return "".join("/" + str(p).replace("~", "~0").replace("/", "~1") for p in path)


def _nulls_block(nulls: list, why: dict | None) -> list[dict]:
    """The replaced numbers grouped by reason: ``[{why, was, paths}]``."""
    groups: dict = {}
    for path, value in nulls:
        was = "NaN" if math.isnan(value) else "Infinity" if value > 0 else "-Infinity"
        key = next((k for k in reversed(path) if isinstance(k, str)), None)
        reason = (why or {}).get(key) or (
            "not a number: nothing to compute it from (no finite data)" if was == "NaN"
            else "infinite: a division by zero or an overflow")
        groups.setdefault((reason, was), []).append(_pointer(path))
    return [{"why": r, "was": w, "paths": p} for (r, w), p in groups.items()]


def write_json(path, obj, indent: int = 2, why: dict | None = None) -> Path:
    """Write ``obj`` as strict JSON to ``path`` atomically.

    Every non-finite number is written as null (:func:`json_safe`); when ``obj`` is a
    dict, its key :data:`NULLS_KEY` then says why: a list of ``{"why": reason, "was":
    "NaN" | "Infinity" | "-Infinity", "paths": [JSON Pointers]}``.

    Parameters
    ----------
    path
        The file to write.
    obj
        The content (see :func:`json_safe`).
    indent
        JSON indentation.
    why
        Reason by key: a number under key ``k`` (its nearest key) that is not finite is
        explained by ``why[k]``; others by a generic reason (no finite data; infinite).

    Returns
    -------
    Path
        ``path``.
    """
    nulls: list = []
    safe = json_safe(obj, nulls)
    if nulls and isinstance(safe, dict):
        safe[NULLS_KEY] = _nulls_block(nulls, why)
    return write_text(path, json.dumps(safe, indent=indent, allow_nan=False))


def write_bytes(path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically."""
    with replacing(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_frame(frame, path, **to_csv) -> Path:
    """``frame.to_csv(path, index=False, **to_csv)`` atomically."""
    with replacing(path) as tmp:
        frame.to_csv(tmp, index=False, **to_csv)
    return Path(path)


def save_figure(fig, path, dpi: int = 110) -> Path:
    """``fig.savefig(path)`` atomically (format from the final name's suffix)."""
    path = Path(path)
    with replacing(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip(".") or "png")
    return path


def clear_results(folder) -> None:
    """Remove the files that mark a finished run from ``folder`` (if it exists)."""
    for name in RESULT_MARKERS:
        p = Path(folder) / name
        try:
            p.unlink(missing_ok=True)
        except OSError as e:
            raise output_error(p, e, "remove") from e

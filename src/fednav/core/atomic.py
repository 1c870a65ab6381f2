"""Output files that are complete or absent.

Every result file is written under a temporary name in its folder and renamed onto its
final name when complete (``os.replace`` is atomic on POSIX and Windows), so a run
killed at any moment leaves either the previous complete file or none — never a
truncated one.  ``summary.json`` is written last: its presence means the run finished.
:func:`clear_results` removes a previous run's ``summary.json`` and ``report.html``
when a new run starts, so a run that fails never leaves an older result looking like
its own.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

#: Files that mark a finished run (removed when a new run starts in the folder).
RESULT_MARKERS = ("summary.json", "report.html")


@contextmanager
def replacing(path) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (hidden, ending in ``.tmp`` so no reader
    globbing ``*.nc`` or ``*.csv`` takes it for a result); it replaces ``path`` when the
    block ends without an exception and is removed otherwise."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_text(path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    with replacing(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def json_safe(obj):
    """``obj`` with every non-finite float replaced by None (JSON has no NaN or
    Infinity: a strict reader refuses them) and numpy scalars as Python's."""
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    return obj


def write_json(path, obj, indent: int = 2) -> Path:
    """Write ``obj`` as strict JSON (non-finite numbers as null, :func:`json_safe`) to
    ``path`` atomically."""
    return write_text(path, json.dumps(json_safe(obj), indent=indent, allow_nan=False))


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
        (Path(folder) / name).unlink(missing_ok=True)

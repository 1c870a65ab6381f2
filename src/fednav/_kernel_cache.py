"""Where numba keeps fednav's compiled kernels: one folder per version of the sources.

numba's on-disk cache (``cache=True``) checks only the file that defines a kernel: a
kernel that inlines another module's kernels — the navigator's compiled engine inlines
the measurement rows, the strapdown, the filters' updates — would load stale machine code
after one of those modules changed while its own file did not (a ``git pull`` on an
editable install), and compute with the old code silently.  fednav therefore points
numba's cache at a folder named by a hash of all its sources, so that any change of any
module compiles afresh (once, ~20-40 s) and an unchanged tree reuses its kernels.  The
folder lives under the user's cache (``$XDG_CACHE_HOME/fednav/kernels`` or
``~/.cache/fednav/kernels``); the few most recently used versions are kept.  A
``NUMBA_CACHE_DIR`` set by the user is respected.
"""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

#: How many source versions' kernel folders are kept.
KEEP = 4


def source_hash(root: Path) -> str:
    """A hash of the content of every ``.py`` file below ``root`` (with their paths)."""
    h = hashlib.sha1()
    for p in sorted(root.rglob("*.py")):
        h.update(str(p.relative_to(root)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def cache_root() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "fednav" / "kernels"


def install(version: str) -> Path | None:
    """Set numba's cache folder for this source tree (before any kernel is compiled or
    loaded); returns it, or None when the user set ``NUMBA_CACHE_DIR`` or no cache
    folder can be made (numba then keeps its default)."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return None
    folder = cache_root() / f"{version}-{source_hash(Path(__file__).parent)}"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        os.utime(folder)  # (most recently used: kept by the pruning below)
    except OSError:
        return None
    os.environ["NUMBA_CACHE_DIR"] = str(folder)  # worker processes inherit it
    import sys

    if "numba" in sys.modules:  # (imported already: tell its config too)
        sys.modules["numba"].config.CACHE_DIR = str(folder)
    _prune(folder.parent)
    return folder


def _prune(root: Path) -> None:
    """Remove all but the :data:`KEEP` most recently used kernel folders."""
    try:
        folders = sorted((p for p in root.iterdir() if p.is_dir()),
                         key=lambda p: p.stat().st_mtime, reverse=True)
    except OSError:
        return
    for old in folders[KEEP:]:
        shutil.rmtree(old, ignore_errors=True)

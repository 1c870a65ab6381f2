"""Where numba keeps fednav's compiled kernels: one folder per version of the sources.

numba's on-disk cache (``cache=True``) checks only the file that defines a kernel: a
kernel that inlines another module's kernels — the navigator's compiled engine inlines
the measurement rows, the strapdown, the filters' updates — would load stale machine code
after one of those modules changed while its own file did not (a ``git pull`` on an
editable install), and compute with the old code silently.  fednav therefore points
numba's cache at a folder named by a hash of all its sources, so that any change of any
module compiles afresh (once, a minute or two) and an unchanged tree reuses its kernels.  The
folder lives under the user's cache (``$XDG_CACHE_HOME/fednav/kernels`` or
``~/.cache/fednav/kernels``); the few most recently used versions are kept.  A
``NUMBA_CACHE_DIR`` set by the user is respected.

The kernels are compiled at LLVM's optimisation level :data:`OPT_LEVEL` (numba's
``NUMBA_OPT``; numba's own default is 3): level 1 compiles a fresh install's kernels in
three quarters of the time, and they run as fast (docs/architecture.md, "Compiling").
The level is set in the environment, so it holds for every kernel the process and its
children compile — other packages' and the user's too — unless the user sets one
(``NUMBA_OPT``, a ``.numba_config.yaml`` in the working folder, or numba imported before
fednav); ``NUMBA_OPT=3`` restores numba's.
"""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

#: How many source versions' kernel folders are kept.
KEEP = 4
#: LLVM's optimisation level for the kernels (``NUMBA_OPT``) when the user sets none:
#: ``fednav reproduce 002`` on a fresh install compiled for 62.9 s at level 1 against
#: 86.5 s at numba's default 3, its warm run 10.6 s against 10.9 s (docs/architecture.md).
OPT_LEVEL = "1"
#: The folder :func:`install` chose for this source tree (None: not installed, the
#: user's ``NUMBA_CACHE_DIR``, or none could be made).
FOLDER: Path | None = None


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
    loaded) and its optimisation level (:data:`OPT_LEVEL`, unless the user set
    ``NUMBA_OPT`` or numba was imported first); returns the folder, or None when the user
    set ``NUMBA_CACHE_DIR`` or no cache folder can be made (numba then keeps its
    default)."""
    global FOLDER
    import sys

    if "numba" not in sys.modules and not Path(".numba_config.yaml").is_file():
        # (numba reads NUMBA_* at each compile: for every kernel compiled in this process
        # and its children, the user's too; a user who set the level — NUMBA_OPT, a
        # .numba_config.yaml here, or numba imported first — keeps it)
        os.environ.setdefault("NUMBA_OPT", OPT_LEVEL)
    if os.environ.get("NUMBA_CACHE_DIR"):
        return None
    folder = cache_root() / f"{version}-{source_hash(Path(__file__).parent)}"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        os.utime(folder)  # (most recently used: kept by the pruning below)
    except OSError:
        return None
    os.environ["NUMBA_CACHE_DIR"] = str(folder)  # worker processes inherit it
    if "numba" in sys.modules:  # (imported already: tell its config too)
        sys.modules["numba"].config.CACHE_DIR = str(folder)
    _prune(folder.parent)
    FOLDER = folder
    return folder


def remembered(name: str, make):
    """``make()`` (a JSON value), kept in this source tree's folder as ``name`` and read
    back by later processes: what the same sources always give, which start-up would
    otherwise import half the package for (the command line's sensor options).  Without
    a folder (:data:`FOLDER` None) or a readable file: ``make()``."""
    import json

    path = None if FOLDER is None else FOLDER / name
    if path is not None and path.is_file():
        try:
            return json.loads(path.read_text())
        except (OSError, ValueError):
            pass
    value = make()
    if path is not None:
        tmp = path.with_name(f".{name}.{os.getpid()}.tmp")
        try:
            tmp.write_text(json.dumps(value))
            os.replace(tmp, path)
        except OSError:
            tmp.unlink(missing_ok=True)
    return value


def _prune(root: Path) -> None:
    """Remove all but the :data:`KEEP` most recently used kernel folders."""
    try:
        folders = sorted((p for p in root.iterdir() if p.is_dir()),
                         key=lambda p: p.stat().st_mtime, reverse=True)
    except OSError:
        return
    for old in folders[KEEP:]:
        shutil.rmtree(old, ignore_errors=True)



#: What a command says on stderr before numba compiles fednav's kernels (a cold cache: a
#: fresh install, or sources that changed since the last run).
NOTICE = "compiling fast kernels once (a minute or two)"


class _Watch:
    """What the compile listener keeps: the seconds compiled and who to tell first."""

    def __init__(self, announce):
        self.announce = announce
        self.seconds = 0.0
        self.depth = 0
        self.t0 = 0.0


_watch: _Watch | None = None


def watch_compiles(announce=None) -> None:
    """Count numba's compile time from now on in this process (:func:`compile_seconds`)
    and, with ``announce`` (a callable taking one line, e.g. a print on stderr), say
    :data:`NOTICE` once, just before the first kernel is actually compiled.

    Only the outermost compilations are timed (a kernel compiling the kernels it inlines
    counts once); a kernel loaded from the on-disk cache fires no compile event, so a warm
    cache says nothing and adds nothing.  Idempotent: a second call changes nothing."""
    global _watch
    if _watch is not None:
        return
    import time

    from numba.core import event

    watch = _Watch(announce)

    class Listener(event.Listener):
        def on_start(self, ev):
            if watch.depth == 0:
                if watch.announce is not None:
                    say, watch.announce = watch.announce, None
                    say(NOTICE)
                watch.t0 = time.perf_counter()
            watch.depth += 1

        def on_end(self, ev):
            watch.depth -= 1
            if watch.depth == 0:
                watch.seconds += time.perf_counter() - watch.t0

    event.register("numba:compile", Listener())
    _watch = watch


def compile_seconds() -> float:
    """Seconds spent compiling kernels in this process since :func:`watch_compiles`
    (0.0 when it was not called)."""
    return 0.0 if _watch is None else _watch.seconds


def announced() -> None:
    """Mark :data:`NOTICE` as said (by a caller that said it itself, e.g. before handing
    the work to other processes), so that the watch does not say it again."""
    if _watch is not None:
        _watch.announce = None


def cold() -> bool:
    """Whether numba's cache folder for this source tree holds no compiled kernel yet (a
    first run: the kernels will be compiled); False when the folder is not known."""
    folder = os.environ.get("NUMBA_CACHE_DIR")
    if not folder or not Path(folder).is_dir():
        return False
    return not any(Path(folder).rglob("*.nbi"))

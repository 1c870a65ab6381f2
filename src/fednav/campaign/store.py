"""Monte Carlo campaigns: a result folder that fills up run by run, resumable, on Dask.

A campaign folder ``DIR`` holds

* ``DIR/campaign.json`` — the manifest: paper, scenario content hash, first seed, fednav
  version and creation time.  Running the same reproduction again with the same ``DIR``
  reuses every unit of work already stored; a different paper, scenario or seed is refused
  with a one-line :class:`CampaignError` (``--fresh`` starts over);
* ``DIR/runs/<key>.nc`` — one NetCDF file per unit of work (a Monte Carlo run of a paper,
  one run of a sweep, or an analysis such as paper 002's Table 1): the per-run statistics
  tables and the error time series of every mode at the statistics epochs (1 Hz in the
  papers).  ``<key>`` is a hash of the work
  function and its arguments (scenario content, seed, options), so a larger ``--runs``
  only adds keys.  Each file is written to a temporary name and renamed: a campaign killed
  at any moment never leaves a half-written file that would later be read as complete.

**Why NetCDF.**  One self-contained file per run makes "write, then rename" atomic and
resumption a directory listing; xarray, pandas, MATLAB, Julia and ``ncdump`` read it; and
SciPy's NetCDF-3 writer, already a dependency, is enough (no HDF5 or Zarr library).  A
Zarr store would suit one growing array better, but renaming its directory of chunks is
no simpler and adds a dependency.

:func:`open_runs` gives the whole campaign as an :class:`xarray.Dataset` with dimensions
``run``, ``mode``, ``time``, ``axis`` (errors ``pos`` [m], ``vel`` [m/s], ``att`` [rad],
computed minus true) and ``run``, ``mode`` (every numeric per-run statistic).

**Engines.**  ``jobs = 1``: in this process.  ``jobs > 1``: a local Dask cluster of worker
processes (one thread each, BLAS single-threaded).  ``address``: an existing Dask
distributed scheduler (``tcp://host:port``), whose workers may be on other machines.
Results depend only on each unit's arguments, so every engine gives the same files and
tables.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import fields, is_dataclass
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from ..core.atomic import output_error, write_bytes, write_json
from ..core.errors import FednavError, check_stop
from . import kernel_plan


class CampaignError(FednavError, ValueError):
    """A campaign folder that cannot be used as asked (one line: the folder and why)."""


# --------------------------------------------------------------------- keys and manifest
def _canonical(obj) -> str:
    """A stable text form of a work unit's arguments (pydantic models by content)."""
    if hasattr(obj, "model_dump_json"):
        return obj.model_dump_json()
    if isinstance(obj, tuple | list):
        return "[" + ",".join(_canonical(o) for o in obj) + "]"
    if isinstance(obj, float):
        return repr(obj)
    return json.dumps(obj, default=str, sort_keys=True)


def work_key(fn: Callable, args) -> str:
    h = hashlib.sha256(f"{fn.__module__}.{fn.__qualname__}|{_canonical(args)}".encode())
    return h.hexdigest()[:20]


def scenario_hash(scn) -> str:
    return hashlib.sha256(_canonical(scn).encode()).hexdigest()[:16]


class Campaign:
    """The campaign folder ``out`` of ``paper`` with scenario ``scn`` and first ``seed``."""

    def __init__(self, out: Path, paper: str, scn, seed: int, fresh: bool = False,
                 address: str | None = None):
        from .. import __version__

        self.out = Path(out)
        if self.out.exists() and not self.out.is_dir():
            raise CampaignError(f"campaign folder {self.out}: exists and is not a folder")
        if address is not None:
            _check_listening(address)  # (before anything is written or shown)
        self.runs_dir = self.out / "runs"
        manifest = {"paper": paper, "scenario_hash": scenario_hash(scn), "seed": int(seed),
                    "fednav_version": __version__}
        path = self.out / "campaign.json"
        if fresh and self.runs_dir.exists():
            # the run files (and temporary ones a kill left): nothing else put there
            for f in [*self.runs_dir.glob("*.nc"), *self.runs_dir.glob(".*.tmp")]:
                try:
                    f.unlink()
                except OSError as e:
                    raise output_error(f, e, "remove") from e
        if path.exists() and not fresh:
            old = _read_manifest(self.out)
            for k in ("paper", "scenario_hash", "seed", "fednav_version"):
                if old.get(k) != manifest[k] and (k != "fednav_version" or k in old):
                    raise CampaignError(
                        f"campaign folder {self.out}: made with {k} {old.get(k)}, not "
                        f"{manifest[k]} (use another --out, or --fresh to start over)")
            manifest["created"] = old.get("created")
        else:
            manifest["created"] = datetime.now(UTC).isoformat(timespec="seconds")
        try:
            self.runs_dir.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise output_error(self.runs_dir, e, "create") from e
        probe = self.runs_dir / f".fednav-write-test.{os.getpid()}.tmp"
        try:  # a folder it cannot write in: said now, not after the first run's work
            probe.write_bytes(b"")
            probe.unlink()
        except OSError as e:
            raise output_error(self.runs_dir, e, "write in") from e
        write_json(path, manifest)
        self.manifest = manifest
        self.address = address
        self.computed = 0
        self.reused = 0
        self.engine = "in-process"
        self._client = None
        self._cluster = None

    def client(self, jobs: int):
        """The campaign's Dask client, started once and kept for all its work."""
        if self._client is None:
            self._client, self._cluster, self.engine = _start_client(self.address, jobs)
        return self._client

    def close(self) -> None:
        """Stop the Dask client (and the local cluster it started)."""
        if self._client is not None:
            self._client.close()
            if self._cluster is not None:
                self._cluster.close()
            self._client = self._cluster = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def path(self, key: str) -> Path:
        return self.runs_dir / f"{key}.nc"

    def load(self, key: str):
        return _read_unit(self.path(key), self.out, key,
                          {"fednav_scenario_hash": self.manifest["scenario_hash"],
                           "fednav_version": self.manifest["fednav_version"]})

    def save(self, key: str, result) -> None:
        # Encoded to bytes, not to a path: xarray would take a Dask-distributed write lock
        # (two scheduler round trips per variable) whenever a Dask client is active.
        ds = encode(result)
        # what the run is: verified when it is read back (a file copied in from another
        # campaign, another seed or scenario, is refused, not used)
        ds.attrs.update({"fednav_work_key": key,
                         "fednav_scenario_hash": self.manifest["scenario_hash"],
                         "fednav_version": self.manifest["fednav_version"]})
        data = ds.to_netcdf(engine="scipy")
        write_bytes(self.path(key), bytes(data))

    def summary(self) -> dict:
        return {"runs_total": self.computed + self.reused, "runs_computed": self.computed,
                "runs_reused": self.reused, "engine": self.engine}


# ----------------------------------------------------------------------------- engines
def _single_threaded() -> None:
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)


def run_units(fn: Callable, args: list, jobs: int = 1, progress: Callable | None = None,
              campaign: Campaign | None = None, plan: str | None = None) -> list:
    """``[fn(a) for a in args]`` in order; units already in ``campaign`` are read back,
    the others computed (in this process, on a local Dask cluster of ``jobs`` worker
    processes, or on the campaign's Dask scheduler) and stored as they finish;
    ``progress()`` after each unit, reused or computed.  ``fn`` may be a list, one
    function per unit (units are submitted in order: put the long ones first).
    ``plan``: the name of the units' kernel plan (:mod:`fednav.campaign.kernel_plan`): on a first
    run with local workers, one of them compiles it from the leaves up while another
    flies the first unit, instead of both compiling the same kernels at once."""
    fns = list(fn) if isinstance(fn, list | tuple) else [fn] * len(args)
    keys = [work_key(f, a) for f, a in zip(fns, args, strict=True)]
    out: list = [None] * len(args)
    todo = []
    for i, k in enumerate(keys):
        if campaign is not None and campaign.path(k).exists():
            out[i] = campaign.load(k)
            campaign.reused += 1
            if progress:
                progress()
        else:
            todo.append(i)

    def done(i, result):
        out[i] = result
        if campaign is not None:
            campaign.save(keys[i], result)
            campaign.computed += 1
        if progress:
            progress()
        check_stop()  # (a stop signal whose interrupt a library swallowed)

    address = campaign.address if campaign is not None else None
    if not todo:
        return out
    if address is None and (jobs <= 1 or len(todo) == 1):
        for i in todo:
            done(i, fns[i](args[i]))
        return out
    from distributed import as_completed

    if campaign is not None:
        client, own = campaign.client(jobs), None
    else:
        client, cluster, _ = _start_client(None, jobs)
        own = (client, cluster)
    stop = warm = None  # (the future held: one let go is cancelled)
    try:
        if plan and address is None and kernel_plan.needed():  # (local workers: 2 or more)
            from uuid import uuid4

            from distributed import Event

            stop = Event(f"kernel-plan-{plan}-{uuid4().hex}", client=client)
            warm = client.submit(_compile_plan, plan, stop.name, key=stop.name, pure=False,
                                 priority=1)
        futs = {client.submit(fns[i], args[i], key=f"{fns[i].__name__}-{keys[i]}",
                              pure=False): i for i in todo}
        for fut in as_completed(futs):
            done(futs[fut], fut.result())
    finally:
        if stop is not None:  # (the plan given up at its next kernel, if still going)
            stop.set()
            del warm
        if own is not None:
            own[0].close()
            own[1].close()
    return out


def _compile_plan(plan: str, stop: str) -> int:
    """A worker's :func:`fednav.campaign.kernel_plan.compile_plan`, given up when the Dask
    event ``stop`` is set (the units done)."""
    from distributed import Event

    return kernel_plan.compile_plan(plan, stop=Event(stop).is_set)


#: Signals a terminal, a job manager or ``kill`` sends to stop a campaign: the local
#: workers leave them to this process, which stops the workers in order.
_STOP_SIGNALS = ("SIGINT", "SIGTERM", "SIGHUP")


@contextmanager
def _no_sigint():
    """While the local workers start (forked), Ctrl-C, SIGTERM and SIGHUP reach only
    this process: the workers inherit a handler that ignores them (otherwise a signal
    sent to the process group kills each worker, or makes it print its own traceback,
    and the nanny restarts it), and one that arrives for this process meanwhile is
    delivered to it when the workers have started, not lost."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    me = os.getpid()
    pending: list[int] = []

    def hold(signum, frame):
        if os.getpid() == me:  # (a forked worker ignores it)
            pending.append(signum)

    sigs = [getattr(signal, n) for n in _STOP_SIGNALS if hasattr(signal, n)]
    old = {s: signal.signal(s, hold) for s in sigs}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        if pending:
            signal.raise_signal(pending[0])


class _ExitWithParent:
    """Dask worker plugin: a local worker exits at once when the process that started
    it is gone (killed with SIGKILL, say); Dask's own pipe for that is held open by the
    worker forked after it, so the workers would outlive it."""

    name = "fednav-exit-with-parent"

    def __init__(self, parent: int, every_s: float = 0.5):
        self.parent = parent
        self.every_s = every_s

    def setup(self, worker=None) -> None:
        """Start the watch (a daemon thread) in the worker process."""
        import threading

        if os.getppid() != self.parent:
            return  # not a child of the campaign process: nothing to watch

        def watch():
            import time

            while os.getppid() == self.parent:
                time.sleep(self.every_s)
            os._exit(1)

        threading.Thread(target=watch, name="fednav exit with parent", daemon=True).start()

    def teardown(self, worker=None) -> None:
        """Nothing to release (the thread ends with the process)."""


#: Seconds a Dask scheduler has to send its handshake after a connect.
HANDSHAKE_S = 5.0


def _check_listening(address: str) -> None:
    """Refuse at once a TCP scheduler address where nothing listens or whose host does not
    resolve (Dask would retry for its whole 30 s connect timeout), and within
    :data:`HANDSHAKE_S` one where something listens that is not a Dask scheduler: a
    scheduler sends its handshake as soon as a connection is made; an HTTP server (the
    dashboard's port) or a silent one sends nothing, and Dask would wait for it forever;
    a server that greets in text (SSH) is not Dask either.  Anything else (a malformed
    address, a host that does not answer) is left to Dask's own connect."""
    import socket

    from distributed.comm import parse_address
    from distributed.comm.addressing import parse_host_port

    try:
        scheme, loc = parse_address(address)
        host, port = parse_host_port(loc)
    except ValueError:
        return
    if scheme not in ("tcp", "tls"):
        return
    try:
        conn = socket.create_connection((host, port), timeout=5.0)
    except ConnectionRefusedError:
        raise CampaignError(f"Dask scheduler {address}: cannot connect (nothing listens on "
                            f"{host} port {port}; start one with 'dask scheduler')") from None
    except socket.gaierror as e:
        raise CampaignError(f"Dask scheduler {address}: cannot connect (host {host!r}: "
                            f"{e.strerror})") from None
    except OSError:
        return
    with conn:
        conn.settimeout(HANDSHAKE_S)
        try:
            first = conn.recv(8)
        except TimeoutError:
            first = None
        except OSError:
            return
    if not first or first[:4] in (b"SSH-", b"HTTP") or first.isascii() and first.isalpha():
        what = ("sent nothing" if first is None else "closed the connection" if not first
                else f"greeted with {first!r}")
        raise CampaignError(f"Dask scheduler {address}: what listens there is not a Dask "
                            f"scheduler (it {what} within {HANDSHAKE_S:g} s; the "
                            f"scheduler's port is usually 8786, its dashboard's 8787)")


def _start_client(address: str | None, jobs: int):
    """(client, local cluster or None, engine description)."""
    from distributed import Client, LocalCluster

    if address is not None:
        _check_listening(address)
        try:
            client = Client(address, timeout="10s")
        except ValueError as e:
            raise CampaignError(f"Dask scheduler address {address!r}: {e} (expected "
                                f"tcp://HOST:PORT)") from None
        except OSError as e:  # a timeout or a refused connection
            raise CampaignError(f"Dask scheduler {address}: cannot connect ({e})") from None
        cluster, engine = None, f"dask {address}"
    else:
        import sys

        import dask

        # fork (Linux): workers inherit the parent's imported modules and loaded numba
        # functions instead of re-importing them (spawn costs ~2 s per worker).  The
        # statistical profiler, the system monitor's disk counters and the fast
        # monitoring ticks feed a dashboard this cluster does not have; slowed down they
        # give the runs back about 4 % of the CPU (a 100-run paper-002 campaign on 2
        # cores: parent 9.5 -> 8.2 s of CPU, workers 58.2 -> 56.4 s).
        method = "fork" if sys.platform.startswith("linux") else "spawn"
        with dask.config.set({"distributed.worker.multiprocessing-method": method,
                              "distributed.worker.profile.enabled": False,
                              "distributed.admin.system-monitor.disk": False,
                              "distributed.admin.system-monitor.interval": "5s",
                              "distributed.admin.tick.interval": "500ms",
                              "distributed.worker.memory.monitor-interval": "1s"}), \
                _no_sigint():
            # (workers log only CRITICAL: a task's error comes back through its future,
            # and a Ctrl-C must not print their heartbeat tracebacks as the scheduler goes;
            # the scheduler's HTTP routes, served without a dashboard too, on a free local
            # port: on 8787 taken it warned "Port 8787 is already in use")
            cluster = LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=50,
                                   scheduler_kwargs={"dashboard_address": "127.0.0.1:0"})
        client, engine = Client(cluster), f"dask local, {jobs} worker processes"
        from distributed.diagnostics.plugin import WorkerPlugin

        # (a WorkerPlugin subclass made here: distributed is imported only when used)
        plugin = type("ExitWithParent", (_ExitWithParent, WorkerPlugin), {})
        client.register_plugin(plugin(os.getpid()))
    client.run(_single_threaded)
    return client, cluster, engine


# ------------------------------------------------------------------------------- codec
def _table_vars(prefix: str, rows: list[dict], data: dict, meta: dict) -> None:
    """A table (list of dicts, the union of their keys as columns) as one variable per
    column; its column names and types in ``meta``."""
    cols: list[str] = []
    for r in rows:
        cols += [c for c in r if c not in cols]
    _columns_vars(prefix, {c: [r.get(c) for r in rows] for c in cols}, len(rows), data, meta)


def _frame_vars(prefix: str, frame, data: dict, meta: dict) -> None:
    """A pandas DataFrame as :func:`_table_vars` stores its ``to_dict("records")``, taken
    column by column (boolean, integer and float columns without a pass over the rows)."""
    cols = {}
    for c in frame.columns:
        v = frame[c].to_numpy()
        cols[c] = v if v.dtype.kind in "biuf" else v.tolist()
    _columns_vars(prefix, cols, len(frame), data, meta)


def _columns_vars(prefix: str, columns: dict, n: int, data: dict, meta: dict) -> None:
    dim = f"{prefix}_row"
    types = {}
    for j, (c, vals) in enumerate(columns.items()):
        name = f"{prefix}_c{j}"
        if isinstance(vals, np.ndarray):
            types[c] = {"b": "bool", "i": "int", "u": "int"}.get(vals.dtype.kind, "float")
            data[name] = ((dim,), vals.astype(float))
            continue
        kinds = {type(v).__name__ for v in vals if v is not None}
        absent = [i for i, v in enumerate(vals) if v is None]
        if absent:  # (rows without the key: left out of them again when read)
            meta.setdefault("absent", {})[c] = absent
        if kinds <= {"str"}:
            types[c] = "str"
            data[name] = ((dim,), np.array(["" if v is None else v for v in vals],
                                           dtype=object))
        else:
            types[c] = "bool" if kinds <= {"bool", "bool_"} else \
                "int" if kinds <= {"int", "int64", "int32"} else "float"
            data[name] = ((dim,), np.array([np.nan if v is None else float(v)
                                            for v in vals], dtype=float))
    meta.update({"kind": "table", "columns": list(columns), "types": types, "n": n})


def _table_from(ds, prefix: str, meta: dict) -> list[dict]:
    """The rows of :func:`_table_vars`: a key a row did not have (rows of different kinds
    in one table, e.g. paper 003's fault cases; ``meta["absent"]``, or an integer or
    boolean cell stored as NaN) is left out of it again."""
    conv = {"str": str, "int": lambda v: int(v), "bool": lambda v: bool(v), "float": float}
    absent = {c: set(ix) for c, ix in meta.get("absent", {}).items()}
    cols = [(c, ds[f"{prefix}_c{j}"].values, conv[meta["types"][c]],
             meta["types"][c] in ("int", "bool"), absent.get(c, ()))
            for j, c in enumerate(meta["columns"])]
    return [{c: f(v[i]) for c, v, f, whole, out in cols
             if i not in out and not (whole and v[i] != v[i])} for i in range(meta["n"])]


def _frame_from(ds, prefix: str, meta: dict):
    """The DataFrame :func:`_frame_vars` stored (the same columns, values and dtypes as
    ``pandas.DataFrame(records)`` of its rows)."""
    import pandas as pd

    if not meta["n"]:
        return pd.DataFrame([], columns=meta["columns"])
    cols = {}
    for j, c in enumerate(meta["columns"]):
        v = ds[f"{prefix}_c{j}"].values
        kind = meta["types"][c]
        cols[c] = (v.astype(np.int64) if kind == "int" else v.astype(bool) if kind == "bool"
                   else [str(s) for s in v] if kind == "str" else v.astype(float))
    return pd.DataFrame(cols, columns=meta["columns"])


def _result_vars(prefix: str, obj, data: dict) -> dict:
    """One result object (RunResult, LaunchResult, ...): arrays as variables, scalars and
    None in the metadata."""
    meta = {"class": f"{type(obj).__module__}:{type(obj).__qualname__}", "fields": {}}
    for f in fields(obj):
        v = getattr(obj, f.name)
        name = f"{prefix}_{f.name}"
        if v is None:
            meta["fields"][f.name] = {"kind": "none"}
        elif isinstance(v, np.ndarray):
            dims = tuple(f"{name}_d{k}" for k in range(v.ndim))
            data[name] = (dims, v)
            meta["fields"][f.name] = {"kind": "array"}
        elif isinstance(v, dict):
            keys = list(v)
            for k, a in enumerate(keys):
                data[f"{name}_k{k}"] = ((f"{name}_k{k}_d0",), np.asarray(v[a], dtype=float))
            meta["fields"][f.name] = {"kind": "dict", "keys": keys}
        elif hasattr(v, "to_dict") and hasattr(v, "columns"):  # pandas DataFrame
            sub: dict = {}
            _frame_vars(name, v, data, sub)
            meta["fields"][f.name] = {**sub, "kind": "frame"}
        else:
            meta["fields"][f.name] = {"kind": "scalar", "value": v if not isinstance(
                v, np.generic) else v.item()}
    return meta


def _result_from(ds, prefix: str, meta: dict):
    import importlib

    mod, qual = meta["class"].split(":")
    cls = getattr(importlib.import_module(mod), qual)
    kw = {}
    for name, m in meta["fields"].items():
        key = f"{prefix}_{name}"
        if m["kind"] == "none":
            kw[name] = None
        elif m["kind"] == "array":
            kw[name] = ds[key].values
        elif m["kind"] == "dict":
            kw[name] = {a: ds[f"{key}_k{k}"].values for k, a in enumerate(m["keys"])}
        elif m["kind"] == "frame":
            kw[name] = _frame_from(ds, key, m)
        else:
            kw[name] = m["value"]
    return cls(**kw)


def encode(result):
    """A unit's result — a table (list of dicts), a dict of result dataclasses, a dict of
    JSON values (kept in the attributes), None, or a tuple of those — as an
    :class:`xarray.Dataset` (exact round trip with :func:`decode`)."""
    import xarray as xr

    parts = list(result) if isinstance(result, tuple) else [result]
    data: dict = {}
    metas = []
    for i, part in enumerate(parts):
        p = f"p{i}"
        if part is None:
            metas.append({"kind": "none"})
        elif isinstance(part, list):
            meta: dict = {}
            _table_vars(p, part, data, meta)
            metas.append(meta)
        elif isinstance(part, dict) and all(is_dataclass(v) for v in part.values()):
            names = list(part)
            metas.append({"kind": "series", "names": names,
                          "items": [_result_vars(f"{p}_s{j}", part[n], data)
                                    for j, n in enumerate(names)]})
        elif isinstance(part, dict):  # plain numbers and names (e.g. an analysis table)
            metas.append({"kind": "json", "value": part})
        else:
            raise TypeError(f"campaign: cannot store a result part of type {type(part)}")
    attrs = {"fednav_structure": json.dumps({"tuple": isinstance(result, tuple),
                                             "parts": metas})}
    return xr.Dataset({k: xr.Variable(d, v) for k, (d, v) in data.items()}, attrs=attrs)


def decode(ds):
    s = json.loads(ds.attrs["fednav_structure"])
    parts = []
    for i, m in enumerate(s["parts"]):
        p = f"p{i}"
        if m["kind"] == "none":
            parts.append(None)
        elif m["kind"] == "table":
            parts.append(_table_from(ds, p, m))
        elif m["kind"] == "json":
            parts.append(m["value"])
        else:
            parts.append({n: _result_from(ds, f"{p}_s{j}", it)
                          for j, (n, it) in enumerate(zip(m["names"], m["items"],
                                                          strict=True))})
    return tuple(parts) if s["tuple"] else parts[0]


def _read_manifest(folder: Path) -> dict:
    """``folder/campaign.json`` as a dict, or a one-line :class:`CampaignError` when it is
    not a manifest (damaged, overwritten, unreadable)."""
    path = folder / "campaign.json"
    try:
        old = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        old = e
    if not isinstance(old, dict):
        raise CampaignError(f"campaign folder {folder}: {path.name} is not a fednav campaign "
                            f"manifest (use another --out, or --fresh to start over)")
    return old


def _read_unit(path: Path, folder, key: str | None = None,
               expect: dict | None = None) -> object:
    """The unit of work stored in ``path`` (decoded), or a one-line :class:`CampaignError`
    when the file is damaged or, its stored work key not ``key``, another run's, or its
    stored scenario hash or fednav version not those of ``expect`` (attribute -> value; a
    file written before an attribute was stored is read as it is)."""
    import xarray as xr

    try:
        with xr.open_dataset(path, engine="scipy") as ds:
            ds = ds.load()
    except Exception as e:  # any damage: truncated, overwritten, not written by fednav
        raise CampaignError(
            f"campaign folder {folder}: stored run {path.name} cannot be read "
            f"({type(e).__name__}); delete it to compute that run again") from None
    stored = ds.attrs.get("fednav_work_key")
    if key is not None and stored is not None and stored != key:
        raise CampaignError(
            f"campaign folder {folder}: stored run {path.name} is another run's (made for "
            f"{stored}: another seed, scenario or campaign); delete it to compute that run "
            f"again")
    for attr, want in (expect or {}).items():
        got = ds.attrs.get(attr)
        if got is not None and got != want:
            what = attr.removeprefix("fednav_").replace("_", " ")
            raise CampaignError(
                f"campaign folder {folder}: stored run {path.name} was made with {what} "
                f"{got}, this campaign's is {want}; delete it (or use --fresh) to compute "
                f"that run again")
    try:
        return decode(ds)
    except Exception as e:
        raise CampaignError(
            f"campaign folder {folder}: stored run {path.name} cannot be read "
            f"({type(e).__name__}); delete it to compute that run again") from None


def stored_runs(campaign: Campaign, units_for: Callable[[int], list], asked: int) -> int:
    """How many Monte Carlo runs ``campaign`` holds whole: the largest ``n >= asked`` for
    which every unit of ``units_for(n)`` (a paper's ``units`` with ``n`` runs) is stored,
    or ``asked`` when no more are.  A folder that holds 10 runs reports on 10 when asked
    for 2 (``--fresh`` starts over).  The units of ``n`` runs are those of ``n - 1`` and
    more, so a binary search finds ``n`` in a few key computations."""
    stored = {p.stem for p in campaign.runs_dir.glob("*.nc")}

    def whole(n: int) -> bool:
        return all(work_key(u.fn, u.args) in stored for u in units_for(n))

    lo, hi = asked, max(asked, len(stored))  # a run is at least one stored unit
    if hi == lo or not whole(lo + 1):
        return asked
    lo += 1
    while lo < hi:  # whole(lo) holds; the answer is in [lo, hi]
        mid = (lo + hi + 1) // 2
        if whole(mid):
            lo = mid
        else:
            hi = mid - 1
    return lo


# ---------------------------------------------------------------------------- analysis
def open_runs(path) -> xarray.Dataset:  # noqa: F821
    """The campaign in ``path`` as one :class:`xarray.Dataset`.

    Dimensions ``run`` (one per stored Monte Carlo run that has error series, by seed),
    ``mode``, ``time`` [s], ``axis``; variables ``pos``, ``vel``, ``att`` (errors, computed
    minus true; NaN where a mode has no sample) and every numeric column of the run's
    statistics table as ``stat_<column>`` (``run``, ``mode``).
    """
    import xarray as xr

    runs_dir = Path(path) / "runs"
    if not runs_dir.is_dir():
        raise CampaignError(f"campaign folder {path}: no runs/ folder (not a campaign)")
    per_run = []
    for f in sorted(runs_dir.glob("*.nc")):
        res = _read_unit(f, path)
        parts = list(res) if isinstance(res, tuple) else [res]
        table = next((p for p in parts if isinstance(p, list)), None)
        series = next((p for p in parts if isinstance(p, dict)), None)
        if not series or not table:
            continue
        seed = table[0].get("seed")
        per_run.append((seed, table, series))
    if not per_run:
        raise CampaignError(f"campaign folder {path}: no stored run has error series")
    per_run.sort(key=lambda r: (r[0] is None, r[0]))
    modes = list(dict.fromkeys(m for _, _, s in per_run for m in s))
    times = np.unique(np.concatenate([np.round(r.t, 6) for _, _, s in per_run
                                      for r in s.values()]))
    shape = (len(per_run), len(modes), len(times), 3)
    out = {k: np.full(shape, np.nan) for k in ("pos", "vel", "att")}
    stat_cols = [c for c, v in per_run[0][1][0].items()
                 if isinstance(v, float | int) and not isinstance(v, bool) and c != "seed"]
    stats = {c: np.full(shape[:2], np.nan) for c in stat_cols}
    for i, (_, table, series) in enumerate(per_run):
        for j, m in enumerate(modes):
            r = series.get(m)
            if r is None:
                continue
            idx = np.searchsorted(times, np.round(r.t, 6))
            for k in out:
                out[k][i, j, idx] = getattr(r, k)
        for row in table:
            if row.get("mode") in modes:
                j = modes.index(row["mode"])
                for c in stat_cols:
                    if c in row:
                        stats[c][i, j] = row[c]
    dims4 = ("run", "mode", "time", "axis")
    ds = xr.Dataset({k: (dims4, v) for k, v in out.items()},
                    coords={"run": [r[0] for r in per_run], "mode": modes, "time": times,
                            "axis": ["x", "y", "z"]})
    for c, v in stats.items():
        ds[f"stat_{c}"] = (("run", "mode"), v)
    if (Path(path) / "campaign.json").exists():
        ds.attrs.update({k: str(v) for k, v in _read_manifest(Path(path)).items()})
    return ds

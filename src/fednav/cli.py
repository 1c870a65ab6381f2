"""Command line: ``fednav reproduce 002``, ``fednav process navego`` and friends."""

from __future__ import annotations

import contextlib
import functools
import json
import os
import time
from pathlib import Path

import typer

from . import __version__, _kernel_cache
from .core.console import PipeConsole
from .core.errors import STOPS, FednavError, Interrupted  # noqa: F401  (cli.Interrupted)

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="fednav — federated multi-sensor integrated navigation.")
console = PipeConsole()  # full-width tables when piped (fednav.core.console)
_state = {"debug": False}


def _print_version(value: bool) -> None:
    if value:
        typer.echo(f"fednav {__version__}")
        raise typer.Exit()


@app.callback()
def _options(debug: bool = typer.Option(False, "--debug",
                                        help="show the traceback of an error"),
             version: bool = typer.Option(False, "--version", is_eager=True,
                                          callback=_print_version,
                                          help="print the version and exit")) -> None:
    _state["debug"] = debug


def _say_on_stderr(line: str) -> None:
    typer.echo(line, err=True)


def _compiled_note(seconds: float) -> str:
    """What a timing line adds when numba compiled kernels meanwhile (not counted in it)."""
    return f" (+ {seconds:.1f} s compiling fast kernels, once)" if seconds >= 0.05 else ""


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning as one line on stderr (not Python's file:line form)."""
    typer.echo(f"warning: {message}", err=True)


#: Signals that stop a command as Ctrl-C does (their exit status is 128 + the signal's
#: number, as a shell reports a process the signal killed: 143, 129; Ctrl-C's 130).
STOP_SIGNALS = ("SIGTERM", "SIGHUP")


#: Packages whose Python functions C code calls back (ctypes callbacks): an exception
#: raised in one is printed and dropped by ctypes, and the C caller goes on with an
#: unset result (llvmlite's object cache, reached while numba compiles or loads a kernel,
#: then crashes the process with SIGSEGV instead of stopping it).
C_CALLBACK_PACKAGES = ("llvmlite",)
_RESEND_S = 0.02


def _in_c_callback(frame) -> bool:
    """Whether the interrupted Python stack runs inside one of :data:`C_CALLBACK_PACKAGES`
    or inside code whose exceptions Python itself prints and drops: a garbage-collector
    callback (``gc.callbacks``: Dask's GC diagnostics, in the scheduler this process
    runs) or a finalizer (``__del__``). Raised there, the stop would be lost and a
    traceback printed."""
    import gc

    dropped = {getattr(getattr(c, "__func__", c), "__code__", None) for c in gc.callbacks}
    while frame is not None:
        code = frame.f_code
        if code in dropped or code.co_name == "__del__":
            return True
        if any(p in Path(code.co_filename).parts for p in C_CALLBACK_PACKAGES):
            return True
        frame = frame.f_back
    return False


@contextlib.contextmanager
def _stop_signals_interrupt():
    """While the block runs (in the main thread), SIGTERM and SIGHUP (and Ctrl-C, where
    Python's own handler has it) raise :class:`Interrupted`, each recorded for
    :func:`~fednav.core.errors.check_stop`; after the first, all are ignored while the
    command stops. One that lands inside a C library's callback is sent again 20 ms
    later, until it lands in fednav's or another pure-Python frame."""
    import signal
    import threading

    sigs = [getattr(signal, n) for n in STOP_SIGNALS if hasattr(signal, n)]
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        sigs.append(signal.SIGINT)  # (Ctrl-C too: recorded for check_stop)
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(signum, frame):
        if _in_c_callback(frame):             # raised there, C would go on with garbage
            again = threading.Timer(_RESEND_S, signal.pthread_kill,  # (a segfault):
                                    (threading.main_thread().ident, signum))  # the same
            again.daemon = True               # signal again once Python holds the stack
            again.start()
            return
        for s in sigs:
            signal.signal(s, signal.SIG_IGN)  # stopping already: a second one must not
        STOPS.append(signum)                  # break the stop of the workers; (checked
        raise Interrupted(signum)             # again where a library caught this one)

    old = {s: signal.signal(s, stop) for s in sigs}
    try:
        yield
    finally:
        STOPS.clear()
        for s, h in old.items():
            signal.signal(s, h)


def _interruption(e: KeyboardInterrupt) -> tuple[str, int]:
    """(what stopped the command: 'Ctrl-C', 'SIGTERM' ..., its exit status 128 + N)."""
    import signal

    signum = getattr(e, "signum", signal.SIGINT)
    name = "Ctrl-C" if signum == signal.SIGINT else signal.Signals(signum).name
    return name, 128 + int(signum)


def _one_line_errors(command):
    """fednav's own errors end a command with their one-line message and exit status 2
    (the traceback only with ``--debug``), and so does an :class:`OSError` naming a file
    (a full disk, no permission) that no fednav error caught; Ctrl-C, SIGTERM and SIGHUP
    end it with one line and 128 + the signal's number; warnings are one line each."""
    @functools.wraps(command)
    def run(*args, **kwargs):
        import warnings

        # "compiling fast kernels once" on stderr before numba's first actual compilation
        # (a cold cache), and the compile time counted apart from the timing lines
        _kernel_cache.watch_compiles(_say_on_stderr)
        try:
            with warnings.catch_warnings(), _stop_signals_interrupt():
                warnings.simplefilter("default", FutureWarning)
                if not _state["debug"]:
                    warnings.showwarning = _show_warning
                return command(*args, **kwargs)
        except FednavError as e:
            if _state["debug"]:
                raise
            typer.echo(f"error: {e}", err=True)
            raise typer.Exit(2) from None
        except OSError as e:
            if _state["debug"] or e.filename is None:
                raise
            typer.echo(f"error: {e.filename}: {e.strerror or e}", err=True)
            raise typer.Exit(2) from None
        except KeyboardInterrupt as e:
            if _state["debug"]:
                raise
            name, status = _interruption(e)
            typer.echo(f"interrupted ({name})", err=True)
            raise typer.Exit(status) from None
    return run


#: Shortest ``--max-time`` [s]: a shorter flight has no filter epochs to tabulate (paper
#: 002's observability table needs its first 10 s segment and says so itself).
MIN_MAX_TIME_S = 1.0


#: Largest seed: numpy's generators take any non-negative integer, the stored runs'
#: files an int64.
MAX_SEED = 2**63 - 1


def _check_counts(runs: int = 1, jobs: int = 1, max_time: float | None = None,
                  seed: int | None = None) -> None:
    """End with a one-line error for ``--runs`` or ``--jobs`` below 1, a ``--max-time``
    shorter than :data:`MIN_MAX_TIME_S`, or seeds (``seed`` .. ``seed + runs - 1``)
    outside 0 .. :data:`MAX_SEED`."""
    if seed is not None and not 0 <= seed <= MAX_SEED - max(runs - 1, 0):
        last = f" (its runs use {seed} .. {seed + runs - 1})" if runs > 1 else ""
        typer.echo(f"error: --seed must be 0 .. 2^63-1, got {seed}{last}", err=True)
        raise typer.Exit(2)
    for opt, value in (("--runs", runs), ("--jobs", jobs)):
        if value < 1:
            typer.echo(f"error: {opt} must be at least 1, got {value}", err=True)
            raise typer.Exit(2)
    if max_time is not None and not max_time >= MIN_MAX_TIME_S:
        typer.echo(f"error: --max-time must be at least {MIN_MAX_TIME_S:g} s, got {max_time}",
                   err=True)
        raise typer.Exit(2)


def _paper_module(paper: str):
    from .scenarios import ALIASES, paper_module

    mod = paper_module(paper)
    if mod is not None:
        return mod
    known = ", ".join(a for aliases in ALIASES.values() for a in aliases)
    typer.echo(f"error: unknown paper '{paper}'; available: {known}", err=True)
    raise typer.Exit(2)


@app.command()
@_one_line_errors
def reproduce(
    paper: str = typer.Argument(..., help="paper number or alias: 000 / airship, "
                                          "001 / launch-frame, 002 / cruise-missile, "
                                          "003 / federated-ukf, 004 / sar-delay"),
    runs: int = typer.Option(10, help="Monte Carlo runs (at least 1)"),
    seed: int = typer.Option(1, help="seed of the first run (run i uses seed + i)"),
    out: Path = typer.Option(None, help="output folder",
                             show_default="results/<paper>"),
    jobs: int = typer.Option(min(2, os.cpu_count() or 1), help="worker processes (at least 1)"),
    scenario: Path = typer.Option(None, help="alternative scenario YAML"),
    max_time: float = typer.Option(None, help="truncate the flight (smoke runs only)"),
    particles: int = typer.Option(None, help="particles per local particle filter "
                                             "(paper 001; default from the scenario)"),
    t4_runs: int = typer.Option(None, "--t4-runs", help="Monte Carlo runs of Table 4 "
                                                         "(paper 002; default min(runs, 3))"),
    fresh: bool = typer.Option(False, "--fresh", help="discard the runs stored in --out"),
    dask: str = typer.Option(None, "--dask", help="Dask scheduler address (tcp://HOST:PORT) "
                                                  "to run on instead of local processes"),
) -> None:
    """Reproduce a paper's experiment and print its tables beside the paper's."""
    _check_counts(runs=runs, jobs=jobs, max_time=max_time, seed=seed)
    mod = _paper_module(paper)
    exp = mod.EXPERIMENT
    extra = {}
    for opt, value, low in (("--particles", particles, 10), ("--t4-runs", t4_runs, 1)):
        if value is None:
            continue
        name = opt.strip("-").replace("-", "_")
        if name not in exp.options:
            from .scenarios import papers

            owners = [m.PAPER for m in papers() if name in m.EXPERIMENT.options]
            typer.echo(f"error: {opt} applies to paper {', '.join(owners)} only, not "
                       f"{exp.number}", err=True)
            raise typer.Exit(2)
        if value < low:
            typer.echo(f"error: {opt} must be at least {low}, got {value}", err=True)
            raise typer.Exit(2)
        extra[name] = value
    out = out or Path("results") / exp.number
    _refuse_writing_over(out, {"scenario": scenario}, _campaign_writes)
    out = _output_folder(out)
    scn = exp.load_scenario(scenario)
    if getattr(scn, "integrity", None) is not None:
        typer.echo(f"error: scenario file {scenario}: key 'integrity': a paper's "
                   f"reproduction computes no protection levels; fednav run (a design) and "
                   f"fednav process do (docs/integrity.md)", err=True)
        raise typer.Exit(2)
    _campaign(exp, scn, exp.number, f"paper {exp.number}: {scn.name}", "units of work", out,
              runs, seed, jobs, max_time, fresh, dask, extra)


def _campaign(exp, scn, identity: str, label: str, unit: str, out: Path, runs: int,
              seed: int, jobs: int, max_time, fresh: bool, dask, extra: dict) -> None:
    """Run (or resume) experiment ``exp``'s campaign of ``scn`` in ``out`` with a progress
    bar, print its tables, write its outputs and report.html (``reproduce``, ``run``)."""
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from .campaign.html_report import write_report
    from .campaign.store import Campaign, stored_runs
    from .core.atomic import OutputError, clear_results

    camp = Campaign(out, identity, scn, seed, fresh, dask)
    if not fresh:  # a folder holding more runs than asked reports on all of them
        held = stored_runs(camp, lambda n: exp.units(scn, n, seed, max_time, **extra), runs)
        if held > runs:
            typer.echo(f"note: {out} holds {held} Monte Carlo runs, more than --runs {runs}: "
                       f"the tables are of all {held} (to have {runs} only, start over with "
                       f"--fresh --runs {runs})", err=True)
            runs = held
    clear_results(out)
    cold = _kernel_cache.cold()  # (the workers compile: said here, once)
    if cold:
        _say_on_stderr(_kernel_cache.NOTICE)
    _kernel_cache.announced()  # (not again by each forked worker)
    t0 = time.perf_counter()
    total = len(exp.units(scn, runs, seed, max_time, **extra))
    with Progress("[progress.description]{task.description}", BarColumn(),
                  MofNCompleteColumn(), TimeElapsedColumn(), TimeRemainingColumn(),
                  console=console, transient=False) as prog:
        task = prog.add_task(label, total=total)

        def stored() -> str:
            return (f"{camp.computed + camp.reused} of {total} {unit} are stored in {out}; "
                    f"the same command computes the others")
        try:
            with camp:
                rep = exp.reproduce(scn, runs, seed, jobs, max_time,
                                    progress=lambda: prog.advance(task), campaign=camp,
                                    **extra)
        except KeyboardInterrupt as e:  # Ctrl-C, SIGTERM, SIGHUP (Interrupted)
            prog.stop()
            if _state["debug"]:
                raise
            name, status = _interruption(e)
            typer.echo(f"interrupted{'' if name == 'Ctrl-C' else f' ({name})'}: "
                       f"{stored()}", err=True)
            raise typer.Exit(status) from None
        except OutputError as e:  # a full disk: what is stored is kept
            prog.stop()
            if _state["debug"]:
                raise
            typer.echo(f"error: {e}; {stored()}", err=True)
            raise typer.Exit(2) from None
    rep["summary"]["campaign"] = camp.summary()
    exp.print_summary(rep["summary"], console)
    c = camp.summary()
    console.print(f"campaign {out}: {c['runs_computed']} {unit} computed, "
                  f"{c['runs_reused']} reused ({c['engine']})")
    files = exp.write_outputs(out, rep)
    files.append(write_report(out, exp.titles))
    console.print(f"wrote {', '.join(str(f) for f in files)} "
                  f"in {time.perf_counter() - t0:.1f} s"
                  + (" (compiling fast kernels included: the next run is quicker)"
                     if cold else ""))


process_app = typer.Typer(no_args_is_help=True,
                          help="Process real sensor data (INS/GNSS, optional velocity aiding, "
                               "smoother).")
app.add_typer(process_app, name="process")


def _output_folder(out: Path) -> Path:
    """Create the output folder, or end with a one-line error if that is impossible.

    Once the inputs are validated and a run starts, the commands remove the previous
    run's result markers (:func:`fednav.core.atomic.clear_results`), so a run that fails never
    leaves an older summary.json looking like its own result; input refused before that
    leaves the previous result as it was."""
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".fednav-write-test.{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except FileExistsError:
        typer.echo(f"error: output folder {out}: a file of that name exists", err=True)
        raise typer.Exit(2) from None
    except OSError as e:
        typer.echo(f"error: output folder {out}: {e.strerror or e}", err=True)
        raise typer.Exit(2) from None
    return out


def _refuse_writing_over(out: Path, inputs: dict, writes) -> None:
    """End with a one-line error when writing a command's outputs into folder ``out``
    would replace one of its ``inputs`` (``{what: path or None}``); ``writes(rel)``
    says whether the command writes the path ``rel`` (relative to ``out``)."""
    root = Path(out).resolve()
    for what, p in inputs.items():
        if p is None:
            continue
        path = Path(p).resolve()
        if path.is_relative_to(root) and writes(path.relative_to(root)):
            typer.echo(f"error: --out {out}: writing there would overwrite the {what} file "
                       f"{p}, an input; choose another output folder", err=True)
            raise typer.Exit(2)


#: The file in which ``fednav simulate`` lists what it wrote into a folder (so that it
#: replaces those files again, and never a user's own).
SIMULATED = ".fednav-simulated.json"


def _refuse_foreign_files(out: Path) -> None:
    """End with a one-line error when folder ``out`` holds a file ``simulate`` would write
    that an earlier ``simulate`` did not write there (a user's own recording)."""
    out = Path(out)
    if not out.is_dir():
        return
    mine = set()
    if (out / SIMULATED).is_file():
        try:
            mine = set(json.loads((out / SIMULATED).read_text()))
        except (ValueError, OSError):
            mine = set()
    foreign = sorted(p.name for p in out.iterdir()
                     if p.is_file() and _simulate_writes(Path(p.name)) and p.name not in mine)
    if foreign:
        typer.echo(f"error: --out {out}: it holds {', '.join(foreign[:3])}"
                   f"{' ...' if len(foreign) > 3 else ''}, which fednav simulate did not write "
                   f"there and would replace; choose an empty folder", err=True)
        raise typer.Exit(2)


def _mark_simulated(out: Path, files) -> None:
    """List ``files`` (written into ``out``) as ``simulate``'s own."""
    from .core.atomic import write_json

    old = []
    if (Path(out) / SIMULATED).is_file():
        try:
            old = json.loads((Path(out) / SIMULATED).read_text())
        except (ValueError, OSError):
            old = []
    write_json(Path(out) / SIMULATED, sorted(set(old) | {Path(f).name for f in files}))


def _campaign_writes(rel: Path) -> bool:
    """Whether a campaign (``reproduce``, ``run``) writes ``rel`` in its folder: run files
    (and ``--fresh`` removes them), tables, plots, summaries."""
    return (rel.parts[0] == "runs" and len(rel.parts) > 1) or rel.suffix in (".csv", ".png") \
        or rel.name in ("summary.json", "report.html", "campaign.json", "tables.md")


def _simulate_writes(rel: Path) -> bool:
    """Whether ``simulate`` writes ``rel`` in its folder (a sensor CSV or .mat each, the
    reference, the config it writes)."""
    return len(rel.parts) == 1 and (rel.suffix in (".csv", ".mat", ".txt", ".nav", ".obs")
                                    or rel.name in ("process.yaml", "system.yaml",
                                                    "kf-gins.yaml"))


def _noise_option(cfg, noise: str):
    """``cfg`` with ``--noise``'s choice (one line for a word it does not know)."""
    if noise not in ("identify", "identify-all", "as-given"):
        raise ValueError(f"--noise {noise}: not identify, identify-all or as-given")
    return cfg.model_copy(update={"noise": noise})


def _run_process(read, imu, gnss, velocity, ref, smooth, out, config, output_rate,
                 files: dict | None = None, force: bool = False, fmt: str = "csv",
                 export: str | None = None, noise: str | None = None) -> None:
    from .campaign import kernel_plan
    from .core.drawer import Drawer

    out = _output_folder(out)
    # forked first: it loads matplotlib and the plots' modules while the data are read;
    # on a first run a second process compiles the kernels from the leaves up
    with Drawer(preload=("fednav.process.output",)) as drawer, \
            kernel_plan.beside("process-csv"):
        from .core.atomic import clear_results
        from .core.config import load_model
        from .navigator.system import System
        from .process import output as process_output
        from .process.run import process

        def refuse_overwrite(paths: dict) -> None:
            for name, p in paths.items():
                if p is not None and process_output.would_overwrite(out, Path(p)):
                    raise ValueError(f"--out {out}: writing there would overwrite the "
                                     f"{name} file {p}, an input; choose another "
                                     f"output folder")

        try:
            refuse_overwrite({"imu": imu, "gnss": gnss, "velocity": velocity,
                              **(files or {}), "reference": ref, "config": config})
            fmt = process_output.check_format(fmt)  # (before the work: a missing extra)
            from .process.export import check_exports, write_exports

            kinds = check_exports(export)
            rate = process_output.parse_rate(output_rate)
            cfg = (System() if config is None
                   else load_model(config, System, "processing config"))
            if rate is None and cfg.output_rate_hz is not None:
                rate = cfg.output_rate_hz
            data = read(cfg)
            cfg = data.get("system", cfg)  # (a reader that completes the description)
            if noise is not None:
                cfg = _noise_option(cfg, noise)
            # the files read (the options', else those the description lists)
            paths = {"imu": imu, "gnss": gnss, "velocity": velocity, **(files or {}),
                     "reference": ref, **data.get("paths", {})}
            refuse_overwrite(paths)  # (and the files the description lists)
            clear_results(out)
            since = _kernel_cache.compile_seconds()
            res = process(data["imu"], _series(data), cfg, smooth=smooth, force=force)
            compiled = _less_compile(res, since)
            res.warnings[:0] = data.get("warnings", [])
            files = process_output.write(out, res, data["ref"], {
                **{n: None if f is None else str(f) for n, f in paths.items()},
                "config": None if config is None else str(config), "smooth": smooth,
                "output_rate_hz": (process_output.DEFAULT_OUTPUT_RATE_HZ if rate is None
                                   else rate),
                "format": fmt}, rate, data["sensors"].get("gnss"), data.get("others"), fmt,
                drawer)
            if kinds:  # (before summary.json, the last file)
                files[-1:-1] = write_exports(out,
                                             process_output.decimate(res.forward, rate),
                                             kinds, res.outages)
        except (FednavError, ValueError) as e:
            if _state["debug"]:
                raise
            typer.echo(f"error: {e}", err=True)
            raise typer.Exit(2) from None
        s = json.loads(files[-1].read_text())
        _print_process(s, compiled)
        console.print(f"wrote {', '.join(str(f) for f in files)}")


def _ulog_reader(log: Path):
    """``read(cfg)`` of a PX4 ULog: the IMU, GNSS, baro and magnetometer, the reference
    (the log's ground truth, else none) and PX4's own estimate to compare with; the
    description completed from the log (:mod:`fednav.process.flight_log`)."""
    def read(cfg):
        from .io import DataError, read_ulog
        from .process.flight_log import ulog_system

        rec = read_ulog(log, cfg.imu.max_bridge_s, cfg.imu.mounting)
        if rec.gnss is None and cfg.initial is None:
            why = [n for n in rec.notes if "gnss" in n.lower() or "gps" in n.lower()]
            raise DataError(f"{log}: no GNSS fix to start from"
                            + (f" ({why[0]})" if why else "")
                            + "; give the initial state in --config (initial:)")
        system, warnings = ulog_system(rec, cfg)
        truth = rec.truth
        if truth is not None and rec.quality.get("truth_height") == "unset":
            warnings.append(f"{log}: the ground truth has no height (0 in every row): "
                            f"not used as the reference")
            truth = None
        warnings += [f"{log}: {note}" for note in rec.notes]
        return {"imu": rec.imu, "ref": truth, "sensors": rec.series,
                "system": system, "warnings": warnings,
                "others": {} if rec.px4 is None else {"px4": rec.px4},
                "paths": {"ulog": log}}
    return read


def _rosbag_reader(bag: Path, topics: dict, time: str):
    """``read(cfg)`` of a ROS 1 or ROS 2 bag (:func:`fednav.io.read_rosbag`): the IMU and
    the sensors found by message type (or on the topics given); the GNSS's 1-sigma for
    fixes without a covariance and its lever arm from ``sensors.gnss`` when given; a
    sensor the bag has but the description has no section for (and whose messages give
    no noise) left out with a warning."""
    def read(cfg):
        from dataclasses import replace

        import numpy as np
        from pydantic import ValidationError

        from .io import read_rosbag
        from .sensors import registry

        rec = read_rosbag(bag, topics=topics, time=time, max_bridge_s=cfg.imu.max_bridge_s,
                          mounting=cfg.imu.mounting)
        warnings = [f"{bag}: {note}" for note in rec.notes]
        sensors = dict(rec.series)
        g, gc = sensors.get("gnss"), cfg.sensors.gnss
        if g is not None and gc is not None:
            given = {k: np.broadcast_to(np.asarray(v, dtype=float), (3,)).copy()
                     for k, v in (("sigma_pos_enu", gc.sigma_pos_enu_m), ("lever", gc.lever_m))
                     if v is not None}
            if given:
                quality = dict(g.quality)
                sensors["gnss"] = replace(g, quality={}, **given)
                sensors["gnss"].quality = quality
        for name, d in list(sensors.items()):
            if name in cfg.sensors or d.sigma is not None or d.cov is not None:
                continue
            try:
                registry.spec(name).config()
            except ValidationError:
                del sensors[name]
                warnings.append(f"{d.source}: not used: the system description has no "
                                f"sensors.{name} section (its noise figure)")
        return {"imu": rec.imu, "sensors": sensors, "ref": None, "warnings": warnings,
                "paths": {"bag": bag}}
    return read


def _gnss_ins_sim_reader(folder: Path, run: int):
    """``read(cfg)`` of a gnss-ins-sim output folder (run ``run``): the IMU, the GPS (and
    the magnetometer and odometer when the description configures them), the simulator's
    true trajectory as the reference; the description completed from the folder
    (:func:`fednav.process.gnss_ins_sim.gnss_ins_sim_system`)."""
    def read(cfg):
        from .io import DataError, read_gnss_ins_sim
        from .process.gnss_ins_sim import gnss_ins_sim_system

        rec = read_gnss_ins_sim(folder, run=run, max_bridge_s=cfg.imu.max_bridge_s,
                                mounting=cfg.imu.mounting)
        if rec.gnss is None and cfg.initial is None:
            raise DataError(f"{folder}: no GPS fix to start from (no gps-{run}.csv or no "
                            f"visible epoch); give the initial state in --config (initial:)")
        system, series, warnings = gnss_ins_sim_system(rec, cfg)
        return {"imu": rec.imu, "ref": rec.ref, "sensors": series, "system": system,
                "warnings": warnings, "paths": {"gnss-ins-sim": folder}}
    return read


def _series(data: dict) -> dict:
    """Every sensor's series a reader gave, by registered name (those it has no file
    for left out)."""
    return {n: d for n, d in data["sensors"].items() if d is not None}


def _less_compile(res, since: float) -> float:
    """The kernels' compile time [s] since ``since`` (:func:`_kernel_cache.compile_seconds`),
    taken out of ``res.run_time_s`` (what is left: the filter's own time)."""
    compiled = _kernel_cache.compile_seconds() - since
    res.run_time_s = max(0.0, res.run_time_s - compiled)
    return compiled


def _print_process(s: dict, compiled_s: float = 0.0) -> None:
    from rich.table import Table

    console.print(f"{s['epochs']} filter epochs in {s['run_time_s']:.2f} s"
                  + _compiled_note(compiled_s))
    al = s.get("alignment") or {}
    if al:
        how = (f"levelling {al.get('levelling')}, heading {al.get('heading')}"
               if al.get("levelling") != "initial" else "the system description's initial:")
        console.print(f"initial attitude: {how}; pitch/roll/heading {al.get('euler_deg')} "
                      f"deg, 1-sigma {al.get('sigma_deg')} deg")
    from rich.markup import escape

    for w in s.get("warnings", []):
        console.print(f"[yellow]warning:[/] {escape(w)}")
    for w in s.get("hints", []):
        console.print(f"[cyan]hint:[/] {escape(w)}")
    q = {k: v for k, v in s.get("data_quality", {}).items()
         if v and not k.endswith(("_seen_s", "_sigma_s"))}
    if q:
        console.print("data: " + ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in q.items())
                      + " (docs/reliability.md)")
    if s.get("noise"):
        from .process.identify import noise_lines

        for line in noise_lines(s["noise"]):
            console.print(escape(line))
    for name, c in s["consistency"].items():
        console.print(f"  local '{name}': mean NIS/dof {c['nis_per_dof']:.2f}, isolated "
                      f"{100 * c['isolated_fraction']:.1f} % of {c['measurements']}")
    ig = s.get("integrity")
    if ig:  # (docs/integrity.md)
        def level(k, unit):
            v = ig[k]
            return "-" if v["median"] is None else f"{v['median']:.3g} (max {v['max']:.3g}) {unit}"
        ex = ", ".join(f"{e['sensor']} at {e['t_s']:.1f} s" for e in ig["exclusions"])
        console.print(f"integrity ({'+'.join(ig['sensors'])}): HPL median {level('hpl_m', 'm')}, "
                      f"VPL {level('vpl_m', 'm')}, heading PL {level('heading_pl_deg', 'deg')}"
                      f"; alerts {100 * ig['alert_fraction']:.1f} % of rows"
                      + (f"; availability {100 * ig['availability']:.1f} %"
                         if "availability" in ig else "")
                      + (f"; excluded {ex}" if ex else "")
                      + ("" if "horizontal_misleading" not in ig else
                         f"; error above the level with no alert: horizontal "
                         f"{100 * ig['horizontal_misleading']:.2f} %, vertical "
                         f"{100 * ig['vertical_misleading']:.2f} % of the reference's epochs"))
    from .ins.states import BLOCKS

    for name, b in BLOCKS.items():  # the optional states (filter.states)
        v = s.get("error_states", {}).get(f"{name}_{b.suffix}")
        if v is not None:
            d = 0 if b.label == "ppm" else 3
            pm = "  ".join(f"{e:+.{d}f} ± {sd:.{d}f}"
                           for e, sd in zip(v["estimate"], v["sigma"], strict=True))
            console.print(f"  {name.replace('_', ' ')} {b.axes} \\[{b.label}] at the end: "
                          f"{pm}", highlight=False)
    from rich.markup import escape

    from .campaign.explain import label
    from .campaign.numbers import format_attitude, is_attitude_deg

    what = {"rmse": "RMSE of the forward solution", "rmse_smoothed": "RMSE smoothed"}
    blocks = [(f"{what[key]} against the reference", s[key])
              for key in ("rmse", "rmse_smoothed") if key in s]
    for name, other in s.get("against", {}).items():
        blocks += [(f"{what[key]} against {name}", other[key])
                   for key in ("rmse", "rmse_smoothed") if key in other]
    for name, rows in s.get("outages", {}).items():  # (sensors.<name>.outages_s)
        for row in rows:
            a, b = row["window_s"]
            blocks += [(f"{what[key]} inside the {name} outage {a:g}-{b:g} s", row[key])
                       for key in ("rmse", "rmse_smoothed") if key in row]
    for title, block in blocks:
        tab = Table(title=title)
        for k in block:
            tab.add_column(escape(label(k)), justify="right")  # ([m] is not markup)
        tab.add_row(*(format_attitude(v, fmt=lambda x: f"{x:.3f}") if is_attitude_deg(k)
                      else f"{v:.3f}" for k, v in block.items()))
        console.print(tab)


def _navego_reader(imu: Path, gnss: Path, visual: Path | None, ref: Path | None = None):
    """``read(cfg)`` of NaveGo .mat files: {imu, gnss, velocity, ref} (None when absent)."""
    def read(cfg):
        from .io import (
            read_navego_gnss,
            read_navego_imu,
            read_navego_reference,
            read_navego_visual,
        )

        return {"imu": read_navego_imu(imu, cfg.imu.max_bridge_s, cfg.imu.mounting),
                "sensors": {"gnss": read_navego_gnss(gnss), "velocity": None if visual
                            is None else read_navego_visual(visual)},
                "ref": None if ref is None else read_navego_reference(ref)}
    return read


def _kfgins_reader(path: Path):
    """``read(cfg)`` of a KF-GINS user's folder or ``kf-gins.yaml``: its files and its
    configuration translated key by key (:mod:`fednav.process.kfgins`), ``cfg``'s keys
    laid over it."""
    def read(cfg):
        from .process.kfgins import read_kfgins

        data = read_kfgins(path, cfg)
        tr = data.pop("translation")
        counts = {}
        for k in tr.keys:
            counts[k.fate] = counts.get(k.fate, 0) + 1
        console.print(f"KF-GINS configuration {tr.source}: "
                      + ", ".join(f"{n} {f}" for f, n in counts.items())
                      + " (fednav process kfgins --keys lists each)")
        return data
    return read


def _csv_reader(imu: Path | None, gnss: Path | None, velocity: Path | None,
                ref: Path | None = None, files: dict | None = None, config: Path | None = None):
    """``read(cfg)`` of fednav CSV files (GNSS sigmas and lever arm from the config, else
    5 m, 0.1 m/s and none; ``files``: other registered sensors' files by name).  A file
    the options leave out is taken from the system description's ``files:`` (relative to
    its folder); ``read`` returns the paths it used under ``paths``."""
    def read(cfg):
        import numpy as np

        from .io import (
            read_gnss_csv,
            read_imu_csv,
            read_nmea,
            read_reference_csv,
            read_rtklib_pos,
            read_ubx,
            read_velocity_csv,
        )
        from .io.sensorfile import read_sensor_file

        base = Path(config).parent if config is not None else Path(".")
        listed = {k: base / v for k, v in cfg.files.items()}
        paths = {"imu": imu or listed.get("imu"), "gnss": gnss or listed.get("gnss"),
                 "reference": ref or listed.get("reference")}
        others = {n: f for n, f in listed.items()
                  if n not in ("imu", "gnss", "reference", "velocity")}
        others.update(files or {})
        vel = velocity or listed.get("velocity")
        if paths["imu"] is None:
            raise typer.BadParameter("no IMU file: give --imu FILE or files: {imu: FILE} in "
                                     "--config", param_hint="--imu")
        gc = cfg.sensors.gnss

        def given(v, default):
            return default if v is None else np.broadcast_to(np.asarray(v, float), (3,))

        g = None
        if paths["gnss"] is not None:
            # (an RTKLIB solution or an NMEA log by its suffix, else fednav's CSV)
            reader = {".pos": read_rtklib_pos, ".nmea": read_nmea, ".nme": read_nmea,
                      ".ubx": lambda p, sigma_pos_enu, sigma_vel, lever: read_ubx(
                          p, lever=lever)}.get(Path(paths["gnss"]).suffix.lower(),
                                               read_gnss_csv)
            g = reader(paths["gnss"], sigma_pos_enu=given(gc and gc.sigma_pos_enu_m,
                                                          (5.0, 5.0, 5.0)),
                       sigma_vel=given(gc and gc.sigma_vel_mps, (0.1, 0.1, 0.1)),
                       lever=given(gc and gc.lever_m, (0.0, 0.0, 0.0)))
        return {"imu": read_imu_csv(paths["imu"], cfg.imu.max_bridge_s, cfg.imu.mounting),
                "sensors": {"gnss": g, "velocity": None if vel is None
                            else read_velocity_csv(vel),
                            **{n: read_sensor_file(n, f) for n, f in others.items()}},
                "ref": None if paths["reference"] is None
                else read_reference_csv(paths["reference"]),
                "paths": {k: v for k, v in {**paths, **others, "velocity": vel}.items()
                          if v is not None}}
    return read


def _sensor_option_helps() -> list[list[str]]:
    """[name, help] of each registered sensor's ``--NAME FILE`` option."""
    from rich.markup import escape

    from .sensors import registry

    out = []
    for name in registry.names():
        spec = registry.spec(name)
        cols = ", ".join(["t_s"] + ([spec.columns_doc] if spec.columns_doc else
                                    [c.name for c in spec.columns]))
        out.append([name, escape(f"{spec.summary}: CSV {cols} [, t_arrival_s]"
                                 + (f"; or {spec.files_doc}" if spec.files_doc else ""))])
    return out


def _sensor_file_options(*exclude: str):
    """Give a command that takes ``**files`` one ``--NAME FILE`` option per registered
    sensor but ``exclude`` (from the sensor registry: a new sensor gets its option).
    The options are remembered per source tree (:func:`_kernel_cache.remembered`), so
    that the command line starts without importing the sensors (and numba) when the
    registry is not imported yet: a plug-in that registered a sensor before is seen."""
    import inspect
    import sys
    from typing import Optional

    if "fednav.sensors.registry" in sys.modules:
        helps = _sensor_option_helps()
    else:
        helps = _kernel_cache.remembered("cli-sensor-options.json", _sensor_option_helps)

    def add(command):
        sig = inspect.signature(command)
        params = [p for p in sig.parameters.values() if p.kind != p.VAR_KEYWORD]
        ann = dict(command.__annotations__)
        for name, help_ in helps:
            if name in exclude:
                continue
            params.append(inspect.Parameter(
                name, inspect.Parameter.KEYWORD_ONLY, annotation=Optional[Path],  # noqa: UP045
                default=typer.Option(None, f"--{name}", help=help_)))
            ann[name] = Optional[Path]  # noqa: UP045  (evaluated by typer, not a hint)
        command.__signature__ = sig.replace(parameters=params)
        command.__annotations__ = ann
        return command
    return add


_OUT = typer.Option(Path("results/process"), help="output folder")
_SMOOTH = typer.Option(False, "--smooth", help="also run the RTS smoother")
_CONFIG = typer.Option(None, help="processing config YAML (noise figures, options)")
_RATE = typer.Option(None, "--output-rate", help="solution rows per second [Hz], 'filter' "
                     "(the filter epochs) or 'imu' (every IMU sample; also 0); default: the "
                     "config's output_rate_hz, else 10 Hz (at most the IMU rate)")
_FORMAT = typer.Option("csv", "--format", help="solution file format: csv or parquet "
                       "(needs pyarrow: the extra 'parquet' of fednav)")
_FORCE = typer.Option(False, "--force", help="write the solution even when its innovations "
                      "say the data are wrong (mean NIS/dof above 100)")
_NOISE = typer.Option(None, "--noise", help="identify: the IMU's process noise identified "
                      "from the recording before the final pass (the given figures its "
                      "prior and floor); identify-all: the sensors' sigmas that no file "
                      "gives too; as-given: flown as given; default: the config's "
                      "noise:, else identify (docs/real-data.md)")
_EXPORT = typer.Option(None, "--export", help="also write the solution as kml, gpx, geojson, "
                       "kfgins and/or rosbag (comma-separated; kml, gpx, geojson need the "
                       "extra 'export' of fednav, rosbag the extra 'formats')")


@process_app.command("navego")
@_one_line_errors
def process_navego(
    imu: Path = typer.Option(..., help="NaveGo IMU .mat"),
    gnss: Path = typer.Option(..., help="NaveGo GNSS .mat"),
    visual: Path = typer.Option(None, help="NaveGo visual-odometry .mat (velocity)"),
    ref: Path = typer.Option(None, help="NaveGo reference .mat (for RMSE)"),
    smooth: bool = _SMOOTH, out: Path = _OUT, config: Path = _CONFIG,
    output_rate: str = _RATE, fmt: str = _FORMAT, force: bool = _FORCE,
    noise: str = _NOISE,
    export: str = _EXPORT,
) -> None:
    """Loosely coupled INS/GNSS (+ visual velocity) on NaveGo .mat files."""
    _run_process(_navego_reader(imu, gnss, visual, ref), imu, gnss, visual, ref, smooth, out,
                 config, output_rate, force=force, noise=noise, fmt=fmt, export=export)


@process_app.command("csv")
@_one_line_errors
@_sensor_file_options("gnss", "velocity")
def process_csv(
    imu: Path = typer.Option(None, help="IMU CSV: rates or increments (docs/data-formats.md)"),
    gnss: Path = typer.Option(None, help="GNSS CSV: positions and/or velocities (or an "
                                         "RTKLIB .pos solution, an NMEA .nmea or a "
                                         "u-blox .ubx log)"),
    velocity: Path = typer.Option(None, help="velocity-sensor CSV"),
    ref: Path = typer.Option(None, help="reference CSV (for RMSE and errors.csv)"),
    smooth: bool = _SMOOTH, out: Path = _OUT, config: Path = _CONFIG,
    output_rate: str = _RATE, fmt: str = _FORMAT, force: bool = _FORCE,
    noise: str = _NOISE,
    export: str = _EXPORT, **files: Path,
) -> None:
    """The system described by --config (any registered sensors, local filters, fault
    detection, delay handling, smoother) on fednav CSV files: one option per sensor, or
    the files the description lists (files:); the IMU noise figures and sensor sigmas
    come from --config (or each row's sigma columns)."""
    files = {n: f for n, f in files.items() if f is not None}
    _run_process(_csv_reader(imu, gnss, velocity, ref, files, config), imu, gnss, velocity,
                 ref, smooth, out, config, output_rate, files, force=force, noise=noise, fmt=fmt,
                 export=export)


@process_app.command("kfgins")
@_one_line_errors
def process_kfgins(
    path: Path = typer.Argument(..., help="a KF-GINS configuration (kf-gins.yaml) or the "
                                          "folder holding it"),
    keys: bool = typer.Option(False, "--keys", help="list what became of each KF-GINS key "
                                                    "and stop"),
    smooth: bool = _SMOOTH, out: Path = _OUT,
    config: Path = typer.Option(None, help="fednav system description YAML whose keys are "
                                           "laid over the translated configuration"),
    output_rate: str = _RATE, fmt: str = _FORMAT, force: bool = _FORCE,
    noise: str = _NOISE,
    export: str = _EXPORT,
) -> None:
    """A KF-GINS user's data as they are: its IMU and GNSS text files and its kf-gins.yaml
    (every key used, translated into fednav's units and frames, or named as ignored), the
    dataset's truth.nav as the reference when it is there; the solution also written as
    KF_GINS_Navresult.nav for KF-GINS's plotting script."""
    if keys:
        from rich.table import Table

        from .process.kfgins import find_config, translate

        try:
            tr = translate(find_config(path))
        except (FednavError, ValueError) as e:
            typer.echo(f"error: {e}", err=True)
            raise typer.Exit(2) from None
        tab = Table(title=f"KF-GINS configuration {tr.source}")
        for c in ("key", "fate", "what fednav does"):
            tab.add_column(c)
        from rich.markup import escape

        for k in tr.keys:
            tab.add_row(k.key, k.fate, escape(k.detail))
        console.print(tab)
        return
    kinds = "kfgins" if not export else f"{export},kfgins"
    _run_process(_kfgins_reader(path), None, None, None, None, smooth, out, config,
                 output_rate, force=force, noise=noise, fmt=fmt, export=kinds)


@process_app.command("ulog")
@_one_line_errors
def process_ulog(
    log: Path = typer.Argument(..., help="PX4 flight log (.ulg)"),
    smooth: bool = _SMOOTH, out: Path = _OUT,
    config: Path = typer.Option(None, help="system description YAML: IMU figures, which "
                                           "sensors aid (aiding:), filters; what it leaves "
                                           "out comes from the log"),
    output_rate: str = _RATE, fmt: str = _FORMAT, force: bool = _FORCE,
    noise: str = _NOISE,
    export: str = _EXPORT,
) -> None:
    """A PX4 autopilot log (ULog, read with pyulog): its IMU, GNSS, barometer and
    magnetometer through the navigator, compared with PX4's own estimate (and the log's
    ground truth when it has one)."""
    _run_process(_ulog_reader(log), log, None, None, None, smooth, out, config,
                 output_rate, force=force, noise=noise, fmt=fmt, export=export)


@process_app.command("rosbag")
@_one_line_errors
def process_rosbag(
    bag: Path = typer.Argument(..., help="ROS 1 bag (.bag) or ROS 2 bag (folder, .db3 or "
                                         ".mcap)"),
    imu_topic: str = typer.Option(None, "--imu-topic", help="the sensor_msgs/msg/Imu topic "
                                                            "(default: the bag's one)"),
    gnss_topic: str = typer.Option(None, "--gnss-topic", help="the sensor_msgs/msg/NavSatFix "
                                                              "topic (default: the bag's "
                                                              "one)"),
    topic: list[str] = typer.Option(None, "--topic", help="NAME=TOPIC for another sensor: "
                                    "velocity (TwistWithCovarianceStamped, ENU), odometer "
                                    "(Odometry), mag (MagneticField), baro (FluidPressure); "
                                    "NAME= leaves it out; repeat for more"),
    time: str = typer.Option("header", "--time", help="each message's time: header "
                             "(header.stamp, the receive time as its arrival) or bag (the "
                             "receive time)"),
    smooth: bool = _SMOOTH, out: Path = _OUT,
    config: Path = typer.Option(None, help="system description YAML: IMU figures (a bag has "
                                           "none), sensor sections (sigmas where the "
                                           "messages give no covariance, lever arms), "
                                           "filters"),
    output_rate: str = _RATE, fmt: str = _FORMAT, force: bool = _FORCE,
    noise: str = _NOISE,
    export: str = _EXPORT,
) -> None:
    """A ROS 1 or ROS 2 bag (read with rosbags: no ROS install): its IMU, GNSS fixes and
    the other sensors found by message type through the navigator; ROS's body FLU and
    world ENU turned into fednav's frames at the reader (docs/recorded-data.md)."""
    topics = {}
    for item in topic or []:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            typer.echo(f"error: --topic {item}: NAME=TOPIC (velocity, odometer, mag or "
                       f"baro)", err=True)
            raise typer.Exit(2)
        topics[name.strip()] = value.strip() or None
    topics.update({k: v for k, v in (("imu", imu_topic), ("gnss", gnss_topic)) if v})
    _run_process(_rosbag_reader(bag, topics, time), bag, None, None, None, smooth, out,
                 config, output_rate, force=force, noise=noise, fmt=fmt, export=export)


@process_app.command("gnss-ins-sim")
@_one_line_errors
def process_gnss_ins_sim(
    folder: Path = typer.Argument(..., help="a folder gnss-ins-sim wrote (time.csv, "
                                            "accel-0.csv, gyro-0.csv, gps-0.csv ...)"),
    run: int = typer.Option(0, "--run", min=0, help="which simulation run (accel-RUN.csv "
                                                    "...)"),
    smooth: bool = _SMOOTH, out: Path = _OUT,
    config: Path = typer.Option(None, help="system description YAML: IMU figures (the "
                                           "folder has none), sensors.mag / "
                                           "sensors.odometer to aid with them, filters; the "
                                           "GPS sigmas come from the folder"),
    output_rate: str = _RATE, fmt: str = _FORMAT, force: bool = _FORCE,
    noise: str = _NOISE,
    export: str = _EXPORT,
) -> None:
    """A gnss-ins-sim (Aceinna) output folder: its IMU and GPS (NED, FRD, units from the
    headers) through the navigator, compared with the simulator's true trajectory."""
    _run_process(_gnss_ins_sim_reader(folder, run), None, None, None, None, smooth, out,
                 config, output_rate, force=force, noise=noise, fmt=fmt, export=export)


tune_app = typer.Typer(no_args_is_help=True,
                       help="Estimate IMU and sensor noise figures from the data "
                            "(innovation-based, scored on held-back time blocks) and write "
                            "a processing config.")
app.add_typer(tune_app, name="tune")
_TUNE_OUT = typer.Option(Path("tuned.yaml"), help="config YAML to write")
_TUNE_CONFIG = typer.Option(None, help="base processing config: its figures are the "
                                       "starting point, its lever arms, options and sensor "
                                       "sigmas are kept")
_TUNE_FIX = typer.Option(None, "--fix", help="a figure to keep as the base config gives it "
                                             "(an imu: key such as gyro_arw_deg_sqrt_h, "
                                             "'imu' for all; "
                                             "sensors.gnss.sigma_pos_enu_m ...); repeat for "
                                             "more")
_TUNE_SENSORS = typer.Option(False, "--tune-sensors",
                             help="also estimate the sensor sigmas the files or the base "
                                  "config give (by covariance matching, never below the "
                                  "data's scatter)")
_TUNE_BLOCK = typer.Option(60.0, "--block-s", min=1.0,
                           help="length of the alternating fitted / held-back time blocks, "
                                "seconds")
_TUNE_OUTAGES = typer.Option(3, "--outages", min=0,
                             help="GNSS outages (30 s, in held-back blocks) simulated to "
                                  "measure the drift before -> after")


def _run_tune(read, inputs: list, config, out: Path, fix=None, tune_sensors=False,
              block_s=60.0, outages=3, sigma_from_file=()) -> None:
    from rich.markup import escape
    from rich.table import Table

    from .core.atomic import write_text
    from .core.config import load_model
    from .navigator.system import System
    from .process.tuning import config_yaml, fixed_keys, format_value, tune

    base = {}
    cfg = System()
    fixed_keys(fix)  # a bad --fix is refused before the data are read
    for p in [*inputs, config]:
        if p is not None and Path(p).resolve() == Path(out).resolve():
            typer.echo(f"error: --out {out} is one of the inputs ({p}); choose another file",
                       err=True)
            raise typer.Exit(2)
    _output_folder(Path(out).parent)  # one it cannot write in: said before the filter runs
    if config is not None:
        from .core.config import read_mapping

        cfg = load_model(config, System, "processing config")
        base = read_mapping(config, "processing config")
    data = read(cfg)
    since = _kernel_cache.compile_seconds()
    with console.status("tuning") as status:
        res = tune(data["imu"], _series(data), cfg,
                   progress=lambda what: status.update(f"filter run: {what}"),
                   fixed=fix or (), tune_sensors=tune_sensors, block_s=block_s,
                   outages=outages, sigma_from_file=sigma_from_file)
    compiled = _less_compile(res, since)
    tab = Table(title="noise figures (SI units); fitted on alternate "
                      f"{res.blocks.length_s:.0f} s blocks, scored on the others")
    # The reasons are printed below the table, one line each: as a table column they
    # were squeezed into a few characters and wrapped over five lines.
    tab.add_column("figure", no_wrap=True)
    for c in ("start", "tuned", "floor"):
        tab.add_column(c)  # (a 3-list folds at its commas on a narrow terminal)
    whys = []
    for f in res.figures:
        tab.add_row(f.key.removeprefix("imu."), format_value(f.start), format_value(f.value),
                    format_value(f.floor))
        whys.append((f.key.removeprefix("imu."), escape(f.how)))
    gc = res.config.sensors.gnss
    lever = gc.lever_m if gc is not None and gc.lever_m is not None else res.lever_from_file
    if lever is None:
        tab.add_row("sensors.gnss.lever_m", "-", "-", "-")
        whys.append(("sensors.gnss.lever_m", "[bold red]WARNING: none set[/]"))
    else:
        tab.add_row("sensors.gnss.lever_m", format_value(list(lever)),
                    format_value(list(lever)), "-")
        whys.append(("sensors.gnss.lever_m", "kept: from the " + (
            "base config" if res.lever_from_file is None
            else "file (written into the config)")))
    console.print(tab)
    console.print("how each figure was found:")
    for key, why in whys:
        console.print(f"  {key}: {why}", highlight=False)
    for n in res.notes:
        console.print(f"note: {n}")
    for line in res.summary():
        console.print(line)
    for w in res.warnings:
        typer.echo(f"warning: {w}", err=True)
    header = (f"fednav tune {__version__}: " + " ".join(str(i) for i in inputs if i)
              + (f" (base config {config})" if config else "")
              + f"\n{res.runs} filter runs in {res.run_time_s:.1f} s; see docs/tuning.md "
                f"for the method")
    write_text(out, config_yaml(res, base, header))  # (OutputError: one line, the file)
    console.print(f"{res.runs} filter runs in {res.run_time_s:.1f} s{_compiled_note(compiled)}; "
                  f"wrote {out} (fednav process ... --config {out})")


@tune_app.command("navego")
@_one_line_errors
def tune_navego(
    imu: Path = typer.Option(..., help="NaveGo IMU .mat"),
    gnss: Path = typer.Option(..., help="NaveGo GNSS .mat"),
    visual: Path = typer.Option(None, help="NaveGo visual-odometry .mat (velocity)"),
    config: Path = _TUNE_CONFIG, out: Path = _TUNE_OUT, fix: list[str] = _TUNE_FIX,
    tune_sensors: bool = _TUNE_SENSORS, block_s: float = _TUNE_BLOCK,
    outages: int = _TUNE_OUTAGES,
) -> None:
    """Noise figures from NaveGo .mat files (start: the base config's figures, else the
    files'; the files' GNSS and visual sigmas are kept unless --tune-sensors)."""
    _run_tune(_navego_reader(imu, gnss, visual), [imu, gnss, visual], config, out, fix,
              tune_sensors, block_s, outages, sigma_from_file=("gnss",))


@tune_app.command("csv")
@_one_line_errors
def tune_csv(
    imu: Path = typer.Option(..., help="IMU CSV (docs/data-formats.md)"),
    gnss: Path = typer.Option(..., help="GNSS CSV (or an RTKLIB .pos solution)"),
    velocity: Path = typer.Option(None, help="velocity-sensor CSV"),
    config: Path = _TUNE_CONFIG, out: Path = _TUNE_OUT, fix: list[str] = _TUNE_FIX,
    tune_sensors: bool = _TUNE_SENSORS, block_s: float = _TUNE_BLOCK,
    outages: int = _TUNE_OUTAGES,
) -> None:
    """Noise figures from fednav CSV files (start: the base config's figures, else a
    generic MEMS IMU; the GNSS sigma is estimated when neither the file nor the base
    config gives it; give the GNSS lever arm in the base config)."""
    _run_tune(_csv_reader(imu, gnss, velocity), [imu, gnss, velocity], config, out, fix,
              tune_sensors, block_s, outages)


@app.command()
@_one_line_errors
def simulate(
    scenario: str = typer.Argument(..., help="a paper (000, 002, 003, 004 or its alias), a "
                                             "paper-layout scenario YAML (with modes), or a "
                                             "dataset scenario YAML (examples/car-drive.yaml)"),
    out: Path = typer.Option(None, help="output folder", show_default="results/dataset"),
    fmt: str = typer.Option("csv", "--format", help="csv (fednav layout), navego (.mat) or "
                                                    "kfgins (KF-GINS's text files and "
                                                    "kf-gins.yaml; both dataset scenarios)"),
    seed: int = typer.Option(None, help="the run's seed (a paper's run S of `fednav "
                                        "reproduce --seed S`; default 1 or the dataset's)"),
    mode: str = typer.Option(None, help="the mode whose sensors and system to write (papers "
                                        "and scenarios; default: the last, the full system)"),
    max_time: float = typer.Option(None, help="truncate the flight (as reproduce --max-time)"),
) -> None:
    """Simulate recorded data in the layouts `fednav process csv|navego|kfgins` reads: a paper's
    or scenario's run (IMU increments, each sensor of the mode, reference, system.yaml) or
    a dataset scenario (IMU, GNSS, velocity sensor, reference)."""
    if fmt not in ("csv", "navego", "kfgins"):
        typer.echo(f"error: --format must be csv, navego or kfgins, got '{fmt}'", err=True)
        raise typer.Exit(2)
    _check_counts(max_time=max_time, seed=seed)
    from .scenarios import paper_module

    mod = paper_module(scenario)
    path = Path(scenario)
    if mod is None and not path.exists():
        typer.echo(f"error: '{scenario}' is neither a paper (000, 002, 003, 004 or an alias) "
                   f"nor a scenario file", err=True)
        raise typer.Exit(2)
    if mod is not None or _has_modes(path):
        _simulate_run(mod, path, out, fmt, 1 if seed is None else seed, mode, max_time)
        return
    if mode is not None or max_time is not None:
        typer.echo("error: --mode and --max-time apply to papers and scenarios with modes, "
                   f"not to the dataset scenario {path}", err=True)
        raise typer.Exit(2)
    from .sim.dataset import (
        load_dataset_config,
        simulate_dataset,
        write_csv_dataset,
        write_kfgins_dataset,
        write_navego_dataset,
    )

    cfg = load_dataset_config(path)
    if seed is not None:
        cfg = cfg.model_copy(update={"seed": seed})
    out = out or Path("results/dataset")
    _refuse_writing_over(out, {"scenario": path}, _simulate_writes)
    _refuse_foreign_files(out)
    out = _output_folder(out)
    ds = simulate_dataset(cfg)
    files = {"csv": write_csv_dataset, "navego": write_navego_dataset,
             "kfgins": write_kfgins_dataset}[fmt](ds, out)
    _mark_simulated(out, files)
    console.print(f"{cfg.name}: {ds.t[-1] - ds.t[0]:.0f} s, {len(ds.t)} IMU samples, "
                  f"{len(ds.gnss_t)} GNSS fixes (seed {cfg.seed})")
    console.print(f"wrote {', '.join(str(f) for f in files)}")


def _has_modes(path: Path) -> bool:
    """Whether a YAML file is a paper-layout scenario (it has ``modes``)."""
    from .core.config import read_mapping

    try:
        return "modes" in read_mapping(path, "scenario")
    except FednavError:
        return False  # the dataset reader says what is wrong


def _simulate_run(mod, path: Path, out: Path | None, fmt: str, seed: int, mode: str | None,
                  max_time: float | None) -> None:
    """``fednav simulate PAPER|SCENARIO``: run ``seed``'s data of one mode as files."""
    from .sim.export import find_mode, write_run
    from .sim.scenario import Scenario, load_scenario

    if fmt != "csv":
        typer.echo(f"error: --format {fmt} applies to dataset scenarios ({fmt} has no "
                   f"star sensor or SAR layout)", err=True)
        raise typer.Exit(2)
    scn = mod.EXPERIMENT.load_scenario() if mod is not None else load_scenario(path)
    if not isinstance(scn, Scenario):
        typer.echo(f"error: paper {mod.PAPER} flies in its own frame (the launch frame); "
                   f"fednav simulate writes the ENU papers 000, 002, 003 and 004", err=True)
        raise typer.Exit(2)
    m = find_mode(scn, mode)
    if not m.aiding:
        aided = ", ".join(x.name for x in scn.modes if x.aiding)
        typer.echo(f"error: mode {m.name} has no aiding sensor (a free INS): fednav process "
                   f"needs one; give --mode ({aided})", err=True)
        raise typer.Exit(2)
    try:
        truth = scn.trajectory(max_time)
    except ValueError as e:
        typer.echo(f"error: --max-time {max_time:g}: {e}", err=True)
        raise typer.Exit(2) from None
    out = out or Path("results") / f"{scn.name}-{seed}"
    _refuse_writing_over(out, {"scenario": None if mod is not None else path},
                         _simulate_writes)
    _refuse_foreign_files(out)
    out = _output_folder(out)
    files = write_run(scn, seed, m, out, max_time)
    _mark_simulated(out, files)
    console.print(f"{scn.name}: run seed {seed}, mode {m.name}: {truth.t[-1] - truth.t[0]:.0f} "
                  f"s, {len(truth.t) - 1} IMU samples")
    console.print(f"wrote {', '.join(str(f) for f in files)}")
    console.print(f"process them: fednav process csv --config {out / 'system.yaml'} "
                  f"--out {out / 'processed'}")


@app.command()
@_one_line_errors
def report(folder: Path = typer.Argument(..., help="a fednav reproduce, run or process "
                                                   "output folder")) -> None:
    """Write FOLDER/report.html: a reproduction's tables beside the paper's (each cell
    outside ×3 says better, or why worse), or a process run's solution summary,
    consistency, warnings and RMSE; the plots; the run metadata."""
    from .campaign.html_report import write_report

    console.print(f"wrote {write_report(folder, _report_titles(folder))}")


def _report_titles(folder: Path) -> dict | None:
    """The table headings of the paper a reproduction folder holds (None if unknown)."""
    try:
        paper = str(json.loads((folder / "summary.json").read_text()).get("paper"))
    except (OSError, ValueError, AttributeError):
        return None  # write_report says what is wrong with the folder
    from .scenarios import paper_module

    mod = paper_module(paper)
    return mod.EXPERIMENT.titles if mod is not None else None


@app.command()
def version() -> None:
    """Print the fednav version."""
    console.print(__version__)


@app.command("run")
@_one_line_errors
def run_design(
    scenario: Path = typer.Argument(..., help="design scenario YAML: flight, IMU, sensors, "
                                              "filter, modes (docs/designs.md)"),
    runs: int = typer.Option(10, help="Monte Carlo runs (at least 1)"),
    seed: int = typer.Option(1, help="seed of the first run (run i uses seed + i)"),
    out: Path = typer.Option(None, help="output folder", show_default="results/<name>"),
    jobs: int = typer.Option(min(2, os.cpu_count() or 1), help="worker processes (at least 1)"),
    max_time: float = typer.Option(None, help="fly only the first T seconds (smoke runs only)"),
    fresh: bool = typer.Option(False, "--fresh", help="discard the runs stored in --out"),
    dask: str = typer.Option(None, "--dask", help="Dask scheduler address (tcp://HOST:PORT) "
                                                  "to run on instead of local processes"),
) -> None:
    """Monte Carlo campaign of your own design: every mode of SCENARIO flown on the same
    runs; tables of RMSE / mean / max errors per mode with 95 % confidence intervals,
    error plots with the Monte Carlo spread, report.html."""
    _check_counts(runs=runs, jobs=jobs, max_time=max_time, seed=seed)
    from .campaign.design import DESIGN

    scn = DESIGN.load_scenario(scenario)
    DESIGN.check(scn, scenario, max_time)
    out = out or Path("results") / scn.name
    _refuse_writing_over(out, {"scenario": scenario}, _campaign_writes)
    out = _output_folder(out)
    _campaign(DESIGN, scn, DESIGN.identity(scn), f"design {scn.name}", "runs", out, runs,
              seed, jobs, max_time, fresh, dask, {})


@app.command("allan")
@_one_line_errors
def allan_command(
    imu: Path = typer.Argument(..., help="IMU CSV of a static recording (rates or "
                                         "increments, docs/data-formats.md)"),
    out: Path = typer.Option(None, help="output folder", show_default="results/allan"),
) -> None:
    """Noise figures from a static recording: the overlapping Allan deviation of each
    gyro and accelerometer axis, with the fitted white noise (ARW/VRW), bias instability
    and rate random walk; writes allan.png, summary.json and imu-figures.yaml (the imu:
    section of a processing config)."""
    from .io import read_imu_csv
    from .process.allan import allan, write

    out = out or Path("results/allan")
    _refuse_writing_over(out, {"imu": imu}, lambda rel: str(rel) in (
        "allan.png", "summary.json", "imu-figures.yaml", "report.html"))
    res = allan(read_imu_csv(imu))
    out = _output_folder(out)
    files = write(res, out)
    _print_allan(res)
    console.print(f"wrote {', '.join(str(f) for f in files)}")


def _print_allan(res) -> None:
    from rich.markup import escape
    from rich.table import Table

    from .process.allan import ACCEL_UNITS, GYRO_UNITS, display_rows

    console.print(f"{escape(res.source)}: {res.duration_s:.0f} s at {res.rate_hz:.4g} Hz, "
                  f"{res.taus_s.size} averaging times {res.taus_s[0]:.3g} to "
                  f"{res.taus_s[-1]:.4g} s")
    for sensor, title, u, white in (("gyro", "gyro", GYRO_UNITS, "ARW"),
                                    ("accel", "accelerometer", ACCEL_UNITS, "VRW")):
        tab = Table(title=f"{title} (IEEE Std 952 reading; ? = floor not reached)")
        for col in ("axis", f"{white}\n{u['white'][0]}", f"bias instab.\n{u['adev'][0]}",
                    f"RRW\n{u['rrw'][0]}", "floor at\ns", f"G-M σ\n{u['adev'][0]}",
                    "G-M τ_c\ns"):
            tab.add_column(col, justify="right")
        for row in display_rows(res, sensor):
            tab.add_row(*row)
        console.print(tab)
    for w in res.warnings:
        console.print(f"[yellow]warning:[/] {escape(w)}")
    console.print("processing-config snippet (largest axis):")
    console.print(escape(res.config_yaml()), highlight=False, end="")


def _names_option(value: str | None, known: list[str], option: str) -> list[str] | None:
    """A comma-separated ``--filters``/``--forms``/``--modes`` value checked against
    ``known`` (None: all); a one-line error naming the unknown one."""
    if value is None:
        return None
    names = [v.strip() for v in value.split(",") if v.strip()]
    for n in names:
        if n not in known:
            typer.echo(f"error: {option}: unknown '{n}'; known: {', '.join(known)}", err=True)
            raise typer.Exit(2)
    return names


@app.command("certify")
@_one_line_errors
def certify_command(
    runs: int = typer.Option(None, help="Monte Carlo runs per combination (at least 1)",
                             show_default="50; 3 with --quick"),
    quick: bool = typer.Option(False, "--quick", help="the quick tier of the test suite: "
                                                      "a few runs of the first 60 s"),
    seed: int = typer.Option(1, help="seed of the first run (run i uses seed + i)"),
    out: Path = typer.Option(Path("results/certificate"), help="output folder (its runs/ "
                             "keeps every unit of work: the same command resumes)"),
    jobs: int = typer.Option(min(2, os.cpu_count() or 1), help="worker processes (at least 1)"),
    dask: str = typer.Option(None, "--dask", help="Dask scheduler address (tcp://HOST:PORT) "
                                                  "to run on instead of local processes"),
    filters: str = typer.Option(None, help="only these filter types (comma-separated)"),
    forms: str = typer.Option(None, help="only these forms: standard, square_root"),
    modes: str = typer.Option(None, help="only these modes (comma-separated: a sensor's "
                                         "name, land-all, air-all)"),
    duration: float = typer.Option(None, help="fly only the first T seconds"),
    runs_of: str = typer.Option(None, "--runs-of", help="fewer runs for some filter "
                                "types, e.g. pf=20,aekf=20 (costly or known outside)"),
    fresh: bool = typer.Option(False, "--fresh", help="discard the runs stored in --out"),
) -> None:
    """Consistency certificate: every registered sensor x every registered filter type and
    form, random lever arms, mountings, latencies and rates, on trajectories made without
    fednav's simulator; NEES of position, velocity and attitude and NIS of every sensor
    against their 99 % chi-square bands (docs/certificate.md).  Writes
    certificate.json and certificate.md; exit status 1 when a combination is outside its
    band without a documented limitation."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeElapsedColumn

    from .campaign import certify as cf
    from .campaign.store import Campaign
    from .filters.registry import FILTERS, FORMS

    if runs is None:
        runs = cf.QUICK_RUNS if quick else cf.FULL_RUNS
    if quick and duration is None:
        duration = cf.QUICK_DURATION_S
    _check_counts(runs=runs, jobs=jobs, max_time=duration, seed=seed)
    pick_f = _names_option(filters, list(FILTERS), "--filters")
    pick_forms = _names_option(forms, list(FORMS), "--forms")
    pick_m = _names_option(modes, [m.name for m in cf.modes()], "--modes")
    fewer = {}
    for item in (runs_of or "").split(","):
        if not item.strip():
            continue
        name, _, n = item.partition("=")
        _names_option(name.strip(), list(FILTERS), "--runs-of")
        try:
            fewer[name.strip()] = int(n)
        except ValueError:
            typer.echo(f"error: --runs-of: '{item.strip()}' is not TYPE=RUNS", err=True)
            raise typer.Exit(2) from None
        _check_counts(runs=fewer[name.strip()])
    out = _output_folder(out)
    n_units = len(cf.units(runs, seed, pick_f, pick_forms, pick_m, duration, fewer))
    if not n_units:
        typer.echo("error: no combination left (--filters and --forms select none)", err=True)
        raise typer.Exit(2)
    cold = _kernel_cache.cold()
    if cold:
        _say_on_stderr(_kernel_cache.NOTICE)
    _kernel_cache.announced()
    t0 = time.perf_counter()
    camp = Campaign(out, "certify", cf.settings(), seed, fresh, dask)
    with Progress("[progress.description]{task.description}", BarColumn(),
                  MofNCompleteColumn(), TimeElapsedColumn(), console=console) as prog:
        task = prog.add_task("certificate", total=n_units)
        try:
            with camp:
                cert = cf.run(runs, seed, jobs, pick_f, pick_forms, pick_m, duration, camp,
                              progress=lambda: prog.advance(task), runs_of=fewer)
        except KeyboardInterrupt as e:
            prog.stop()
            if _state["debug"]:
                raise
            name, status = _interruption(e)
            typer.echo(f"interrupted{'' if name == 'Ctrl-C' else f' ({name})'}: "
                       f"{camp.computed + camp.reused} of {n_units} units of work are "
                       f"stored in {out}; the same command computes the others", err=True)
            raise typer.Exit(status) from None
    cf.print_table(cert, console)
    files = cf.write(cert, out)
    c = camp.summary()
    console.print(f"{c['runs_computed']} units computed, {c['runs_reused']} reused "
                  f"({c['engine']}); wrote {', '.join(str(f) for f in files)} in "
                  f"{time.perf_counter() - t0:.1f} s")
    if cert["verdicts"]["outside"]:
        raise typer.Exit(1)


def main() -> None:  # pragma: no cover
    app()

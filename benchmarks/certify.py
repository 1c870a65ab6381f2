"""The consistency certificate by hand, and the studies behind its documented limitations.

    python benchmarks/certify.py [--runs 50] [--jobs 2] [--dask tcp://HOST:PORT]
                                 [--out results/certificate]
    python benchmarks/certify.py --study adaptive|pf|airdata|baro|quick [--runs N]
                                 (default 20 runs; pf: 3)
    python benchmarks/certify.py --condensed results/certificate/certificate.json

Without ``--study``: the full certificate (``fednav certify --runs N``: every registered
sensor x filter type x form, ``N`` runs per combination, resumable in ``--out``), its
table and ``certificate.json`` / ``certificate.md``.  On 2 cores it takes hours
(docs/certificate.md gives the figures); ``--dask`` spreads it over a cluster.

The studies (in this process, seeds 1..N; docs/certificate.md quotes their output):

* ``adaptive`` — the Sage-Husa filters (aekf, raukf, aasghqf) in the GNSS, star and
  land-all modes, with their R floor in the nominal R's metric (``R >= r_floor
  R_nominal``; the floor of ``r_floor`` times the smallest eigenvalue it replaced gave
  position NEES of tens to thousands with a GNSS receiver);
* ``pf`` — the particle filter at 1000 (its default), 4000 and 16000 particles, without
  and with its progressive correction (``filter.pf``);
* ``airdata`` — the wind constraint with air data every 0.1 s and every 1 s (each sample
  used once), with one local filter and with two (the constraint in each with R / beta);
* ``baro`` — the barometer with its lever arm, as a filter measurement only and with the
  vertical-channel damping loop (which takes the lever arm too), and at the IMU;
* ``health`` — the health monitor on the clean runs of every mode (``kf``, ``ukf``): its
  false alarms;
* ``quick`` — the wall time of the quick tier (the test suite's), every combination.
"""

from __future__ import annotations

import argparse
import time
from contextlib import contextmanager
from dataclasses import replace

import numpy as np

from fednav.campaign import certify as cf


def _summary(mode, filter_type: str, runs: int, form: str = "standard",
             duration: float | None = None, data_of=None) -> str:
    """NEES per dof (pos, vel, att), NIS per dof of every figure, failed runs."""
    nees: dict = {}
    nis: dict = {}
    errors = []
    for s in range(1, runs + 1):
        data = cf.run_data(s, duration) if data_of is None else data_of(s)
        r = cf.fly(mode, filter_type, form, data)
        if "error" in r:
            errors.append(r["error"])
            continue
        for k, v in r["nees"].items():
            nees.setdefault(k, []).append(v)
        for k, (total, count, dof) in r["nis"].items():
            a = nis.setdefault(k, [0.0, 0, dof])
            a[0] += total
            a[1] += count
    parts = []
    for k in ("pos", "vel", "att"):
        if k in nees:
            v = np.asarray(nees[k])
            lo, hi = cf.band(3.0 * len(v))
            x = v.mean(axis=0).mean() / 3.0
            parts.append(f"NEES {k} {x:.2f}{'' if lo <= x <= hi else ' !'}")
    for k, (total, count, dof) in nis.items():
        lo, hi = cf.band(count * dof)
        x = total / (count * dof)
        parts.append(f"NIS {k} {x:.3f}{'' if lo <= x <= hi else ' !'}")
    if errors:
        parts.append(f"{len(errors)} of {runs} runs failed ({errors[0][:100]})")
    return ", ".join(parts)


def _mode(name: str):
    return {m.name: m for m in cf.modes()}[name]


@contextmanager
def _setup(name: str, **changes):
    """The certificate's setup of sensor ``name`` changed for a study (the run data
    drawn afresh)."""
    old = cf.SETUP[name]
    cf.SETUP[name] = replace(old, **changes)
    cf.run_data.cache_clear()
    try:
        yield
    finally:
        cf.SETUP[name] = old
        cf.run_data.cache_clear()


def study_adaptive(runs: int) -> None:
    """The Sage-Husa filters with their R floor (R >= r_floor R_nominal, in the nominal
    R's metric; before 2026-11-28 a floor of the nominal R's smallest eigenvalue let a
    GNSS position variance fall to 0.1 x (0.05 m/s)^2: position NEES 83-6100)."""
    for f in ("aekf", "raukf", "aasghqf"):
        for m in ("gnss", "star", "land-all"):
            print(f"{f:8s} {m:9s} {_summary(_mode(m), f, runs)}", flush=True)


def study_pf(runs: int) -> None:
    """The particle filter at 1000 (its default), 4000 and 16000 particles, without and
    with its progressive correction (``filter.pf``; on by default since 2026-11-30)."""
    base = cf.system_for
    for progressive in (False, True):
        for n in (1000, 4000, 16000):
            def system_for(mode, filter_type, form, data, _n=n, _p=progressive):
                s = base(mode, filter_type, form, data)
                pf = s.filter.pf.model_copy(update={"particles": _n,
                                                    "progressive_correction": _p})
                return s.model_copy(update={"filter": s.filter.model_copy(
                    update={"pf": pf})})

            cf.system_for = system_for
            try:
                for m in ("gnss", "baro", "star"):
                    t0 = time.perf_counter()
                    s = _summary(_mode(m), "pf", runs, duration=cf.QUICK_DURATION_S)
                    print(f"pf {n:6d} particles, progressive correction "
                          f"{'on ' if progressive else 'off'} {m:6s} "
                          f"({time.perf_counter() - t0:.0f} s, "
                          f"{cf.QUICK_DURATION_S:g} s flights) {s}", flush=True)
            finally:
                cf.system_for = base


def study_airdata(runs: int) -> None:
    for period in (0.1, 1.0):
        with _setup("airdata", periods=(period,)):
            for f in ("kf", "cukf"):
                print(f"air data every {period:g} s, {f:5s}: "
                      f"{_summary(_mode('airdata'), f, runs)}", flush=True)
    # the constraint in each of two local filters (star and baro)
    two = cf.Mode("airdata-2", "air", ("star", "baro"), "wind")
    for f in ("kf", "cukf"):
        print(f"air data every 0.1 s, two local filters, {f:5s}: {_summary(two, f, runs)}",
              flush=True)


def study_baro(runs: int) -> None:
    from fednav.campaign import certify_truth as ct

    mode = _mode("baro")
    for loop, lever in ((False, True), (True, True), (True, False)):
        def data_of(s, loop=loop, lever=lever):
            d = cf.run_data(s)
            sec = dict(d.sections["baro"], damping_loop=loop)
            meas = dict(d.measurements)
            if not lever:  # the same barometer at the IMU (its heights drawn again)
                sec.pop("lever_m", None)
                tr = d.truth[mode.trajectory]
                t, ta, _ = meas[("baro", mode.trajectory)]
                idx = np.rint(t / tr.dt).astype(int)
                z = ct.measure("baro", tr, idx, np.zeros(3), None, cf.SETUP["baro"].sigma,
                               np.random.default_rng(s))
                meas[("baro", mode.trajectory)] = (t, ta, z)
            return replace(d, sections={**d.sections, "baro": sec}, measurements=meas)

        print(f"baro {'with its lever arm' if lever else 'at the IMU        '}, damping "
              f"loop {'on ' if loop else 'off'}: {_summary(mode, 'kf', runs, data_of=data_of)}",
              flush=True)


def study_health(runs: int, filters=("kf", "ukf")) -> None:
    """The health monitor on the certificate's clean runs: every mode, ``runs`` runs of
    each filter type (standard form); a warning here is a false alarm (the filters are in
    their bands)."""
    hits: dict = {(f, m.name): [] for f in filters for m in cf.modes()}
    total = 0
    for seed in range(1, runs + 1):
        data = cf.run_data(seed)
        for f in filters:
            for mode in cf.modes():
                r = cf.fly(mode, f, "standard", data)
                if "error" in r:
                    continue
                total += 1
                if r["health"]:
                    hits[(f, mode.name)].append((seed, r["health"][0]))
    for (f, name), h in hits.items():
        print(f"{f:4s} {name:9s} {len(h)} of {runs} runs warned"
              + (f": seed {h[0][0]}: {h[0][1][:160]}" if h else ""))
    print(f"health monitor: {sum(map(len, hits.values()))} false alarms in {total} clean "
          f"runs")


def study_quick() -> None:
    t0 = time.perf_counter()
    cert = cf.run(cf.QUICK_RUNS, 1, 2, duration_s=cf.QUICK_DURATION_S)
    print(f"quick tier: {len(cert['combinations'])} combinations x {cf.QUICK_RUNS} runs of "
          f"{cf.QUICK_DURATION_S:g} s in {time.perf_counter() - t0:.1f} s on 2 worker "
          f"processes; verdicts {cert['verdicts']}")


def condensed(path) -> str:
    """A certificate.json condensed for docs/certificate.md: per mode the range of each
    figure over the filter types and forms in band, then per limited filter type the
    figures outside and the failed runs."""
    import json

    cert = json.loads(open(path).read())
    limited = {lim.filter for lim in cf.LIMITATIONS}
    out = ["| mode | sensors | runs | NEES pos | NEES vel | NEES att | NEES band | "
           "NIS per dof [band] | in band |", "|" + "---|" * 9]

    def rng(vals):
        lo, hi = min(vals), max(vals)
        return f"{lo:.3f}" if f"{lo:.3f}" == f"{hi:.3f}" else f"{lo:.3f}–{hi:.3f}"

    for mode in dict.fromkeys(c["mode"] for c in cert["combinations"]):
        cs = [c for c in cert["combinations"] if c["mode"] == mode
              and c["filter"] not in limited]
        fig: dict = {}
        for c in cs:
            for x in c["figures"]:
                fig.setdefault(x["figure"], []).append(x)
        nees = [rng([x["value"] for x in fig[f"nees.{k}"]]) for k in ("pos", "vel", "att")]
        b = fig["nees.pos"][0]
        nis = "; ".join(f"{k[4:]} {rng([x['value'] for x in v])} [{v[0]['low']:.3f}, "
                        f"{v[0]['high']:.3f}]" for k, v in fig.items() if k.startswith("nis."))
        ok = sum(c["verdict"] == "pass" for c in cs)
        out.append(f"| {mode} | {', '.join(cs[0]['sensors'])} | {cs[0]['runs']} | "
                   f"{' | '.join(nees)} | [{b['low']:.2f}, {b['high']:.2f}] | {nis} | "
                   f"{ok} of {len(cs)} |")
    out += ["", "| filter | forms | runs | combinations outside | failed runs | NEES "
            "outside (range) | NIS outside (range) |", "|" + "---|" * 7]
    for f in sorted(limited):
        cs = [c for c in cert["combinations"] if c["filter"] == f]
        if not cs:
            continue
        bad = [x for c in cs for x in c["figures"] if not x["inside"]]
        nees = [x["value"] for x in bad if x["figure"].startswith("nees")]
        nis = [x["value"] for x in bad if x["figure"].startswith("nis")]
        out.append(f"| {f} | {', '.join(sorted({c['form'] for c in cs}))} | "
                   f"{max(c['runs'] for c in cs)} | "
                   f"{sum(c['verdict'] != 'pass' for c in cs)} of {len(cs)} | "
                   f"{sum(c['failed_runs'] for c in cs)} of {sum(c['runs'] for c in cs)} | "
                   f"{len(nees)}: {min(nees):.2f}–{max(nees):.0f} | "
                   + (f"{len(nis)}: {min(nis):.3f}–{max(nis):.3f} |" if nis else "— |"))
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=None)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--dask", default=None)
    ap.add_argument("--out", default="results/certificate")
    ap.add_argument("--study", choices=("adaptive", "pf", "airdata", "baro", "health",
                                        "quick"))
    ap.add_argument("--condensed", metavar="CERTIFICATE_JSON",
                    help="print the condensed tables of docs/certificate.md")
    a = ap.parse_args()
    if a.condensed:
        print(condensed(a.condensed))
        return
    if a.study == "quick":
        study_quick()
        return
    if a.study is not None:
        # (the particle filter at 16000 particles: minutes per flight)
        runs = a.runs or (3 if a.study == "pf" else 20)
        {"adaptive": study_adaptive, "pf": study_pf, "airdata": study_airdata,
         "health": study_health,
         "baro": study_baro}[a.study](runs)
        return
    from fednav.cli import app

    args = ["certify", "--runs", str(a.runs or cf.FULL_RUNS), "--jobs", str(a.jobs),
            "--out", a.out]
    if a.dask:
        args += ["--dask", a.dask]
    app(args)


if __name__ == "__main__":
    main()

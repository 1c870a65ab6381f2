"""Paper 003 fault experiment with the paper's immediate return after isolation
(fdi_recovery = 1) and with 3 consecutive passes required (fdi_recovery = 3).

Run by hand: ``python benchmarks/paper003_fdi_recovery.py [seeds...]`` (default 6 8).
"""

import pathlib
import sys
import tempfile

import yaml

from fednav.scenarios import paper003, scenario_path
from fednav.sim.scenario import load_scenario


def main(seeds):
    for n in (1, 3):
        d = yaml.safe_load(scenario_path("paper003").read_text())
        d["filter"]["fdi_recovery"] = n
        p = pathlib.Path(tempfile.mkdtemp()) / "scenario.yaml"
        p.write_text(yaml.safe_dump(d))
        scn = load_scenario(p)
        for seed in seeds:
            r = paper003.one_run((scn, seed, None))[2][0]  # the 'isolated' case
            print(f"fdi_recovery={n} seed={seed}: window isolated {r['isolated_fraction']:.3f}, "
                  f"false alarms {r['false_alarm_rate']:.4f}, "
                  f"position RMS in window {r['pos_err_rms_fault_window_m']:.1f} m")


if __name__ == "__main__":
    main([int(a) for a in sys.argv[1:]] or [6, 8])

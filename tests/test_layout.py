"""The package layout: layered subpackages, no import running upward, old names kept."""

import ast
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "src" / "fednav"
#: Subpackages from the bottom up.  A module may import its own subpackage and any
#: subpackage of a lower layer; packages on one layer do not import each other.
LAYERS = [{"core"}, {"ins"}, {"filters"}, {"sensors"}, {"io"}, {"navigator"},
          {"sim", "process"}, {"campaign"}, {"launch"}, {"scenarios"}]
LEVEL = {name: i for i, layer in enumerate(LAYERS) for name in layer}
TOP = len(LAYERS)  # the package's own top-level modules (cli, __init__, _compat)
#: the console script's entry point, above the command line it loads
ENTRY = TOP + 1


def _level(module_path: Path) -> tuple[str, int]:
    rel = module_path.relative_to(PKG)
    name = rel.parts[0] if len(rel.parts) > 1 else rel.stem
    return name, ENTRY if name == "__main__" else LEVEL.get(name, TOP)


def _imports(path: Path):
    """(line, imported subpackage) for every fednav import of a module."""
    tree = ast.parse(path.read_text())
    parts = path.relative_to(PKG).with_suffix("").parts
    pkg = ["fednav", *parts[:-1]]
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg[:len(pkg) - (node.level - 1)]
                target = base + (node.module.split(".") if node.module else [])
            elif node.module and node.module.split(".")[0] == "fednav":
                target = node.module.split(".")
            else:
                continue
            if len(target) > 1:
                yield node.lineno, target[1]
            else:  # from fednav import x, y: each name is a subpackage or module
                for alias in node.names:
                    yield node.lineno, alias.name
        elif isinstance(node, ast.Import):
            for alias in node.names:
                t = alias.name.split(".")
                if t[0] == "fednav" and len(t) > 1:
                    yield node.lineno, t[1]


def test_every_subpackage_has_a_layer():
    subpackages = {p.parent.name for p in PKG.glob("*/__init__.py")}
    assert subpackages == set(LEVEL), subpackages ^ set(LEVEL)


def test_no_import_runs_upward_or_sideways():
    bad = []
    for path in sorted(PKG.rglob("*.py")):
        name, level = _level(path)
        for line, target in _imports(path):
            if target == name or target.startswith("_") or target == "__version__":
                continue
            tl = LEVEL.get(target, TOP)
            if tl >= level:
                bad.append(f"{path.relative_to(PKG)}:{line} imports {target}")
    assert not bad, "\n".join(bad)


def test_top_level_holds_only_the_entry_points():
    # (and what must run before any subpackage is imported: old names, the kernel cache)
    assert sorted(p.name for p in PKG.glob("*.py")) == ["__init__.py", "__main__.py",
                                                        "_compat.py", "_kernel_cache.py",
                                                        "cli.py"]


@pytest.mark.parametrize("old", ["fednav.earth", "fednav.simulate", "fednav.tuning",
                                 "fednav.config"])
def test_old_module_names_still_import_with_a_warning(old):
    from fednav._compat import MOVED

    code = (f"import warnings; warnings.simplefilter('error', FutureWarning)\n"
            f"try:\n    import {old}\nexcept FutureWarning as w:\n    print(w)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert f"{old} is now {MOVED[old]}" in out
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        import importlib

        assert importlib.import_module(old) is importlib.import_module(MOVED[old])


def test_launch_scenario_keys_of_0_1_still_read():
    import yaml

    from fednav.launch import errors, scenario

    d = yaml.safe_load((PKG / "scenarios" / "paper001.yaml").read_text())
    d["gps"] = d.pop("gnss")
    d["filters"]["pf_gps_likelihood"] = "mixture"
    with pytest.warns(FutureWarning, match="are now"):
        s = scenario.LaunchScenario.model_validate(d)
    assert s.gnss.sigma_m == 15.0 and s.filters.pf_gnss_likelihood == "mixture"
    with pytest.warns(FutureWarning, match="GnssPositionLI"):
        assert errors.GpsPosition is errors.GnssPositionLI


def test_names_users_imported_from_0_1_modules_still_import():
    import importlib

    names = {
        "fednav.config": ["GnssConfig", "StarConfig", "SarConfig", "SarVelocityConfig",
                          "AirDataConfig", "BaroConfig", "TimingConfig", "FilterConfig",
                          "SensorsConfig", "read_text_file", "load_scenario", "Scenario"],
        "fednav.process": ["gnss_course", "check_units", "adjust_sensors", "gnss_z",
                           "imu_figures", "ImuNoiseConfig", "ProcessConfig", "process"],
        "fednav.simulate": ["TOTAL_MODELS", "total_state_models", "run_mode",
                            "make_run_data"],
        "fednav.measurements": ["euler_error_nb", "MODELS", "NavSnapshot"],
    }
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        for mod, attrs in names.items():
            m = importlib.import_module(mod)
            missing = [a for a in attrs if not hasattr(m, a)]
            assert not missing, (mod, missing)


#: The only places outside ``sensors/`` and ``io/`` whose code names a sensor of the
#: registry as the GNSS, each with why; everywhere else the GNSS is the sensor whose
#: fixes start a run (``SensorSpec.fixes``, ``registry.fix_sensor``) or one entry of the
#: registry among the others.
GNSS_NAMED = {
    "cli.py": "the command line's --gnss file options and the formats its readers take",
    "process/kfgins.py": "KF-GINS's configuration and GNSS file, translated",
    "process/gnss_ins_sim.py": "gnss-ins-sim's output folder, translated",
    "process/flight_log.py": "a PX4 log's receiver figures, translated",
    "sim/dataset.py": "the car-drive dataset generator: writes the receiver's file in "
                      "fednav's and the peers' formats (NaveGo gnss.mat, KF-GINS gnss.txt) "
                      "from draws of its own (seeded datasets stay the same)",
    "sim/drives.py": "the test drives built on that generator (Drive.gnss)",
    "campaign/certify.py": "the certificate's setup of every registered sensor",
    "campaign/certify_truth.py": "the certificate's independent generator: every sensor's "
                                 "measurement written again, on purpose",
    "ins/states.py": "the gnss_markov error state (its key in filter.states)",
    "launch": "paper 001's own launch-frame GNSS model",
    "scenarios": "the papers' own systems",
}
#: fednav 0.1's names, kept for one more release (the old call layouts included).
OLD_GNSS_NAMES = {"gnss_course", "gnss_z", "gnss_flown", "flown_gnss", "check_gnss_timing",
                  "GnssConfig", "read_gnss_csv"}


def _names_gnss(path: Path) -> list[tuple[int, str]]:
    """(line, name) of each code reference to the GNSS in a module: identifiers,
    attributes, arguments, definitions and keys (strings without spaces); docstrings,
    comments and messages are prose."""
    tree = ast.parse(path.read_text())
    shims = set()  # the bodies of fednav 0.1's call layouts and deprecated properties
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef):
            doc = ast.get_docstring(node) or ""
            if doc.startswith("Deprecated") or "fednav 0.1's" in doc:
                shims |= {id(n) for n in ast.walk(node)}
    found = []
    for node in ast.walk(tree):
        if id(node) in shims:
            continue
        name = (node.id if isinstance(node, ast.Name) else
                node.attr if isinstance(node, ast.Attribute) else
                node.arg if isinstance(node, ast.arg) else
                node.name if isinstance(node, (ast.FunctionDef, ast.ClassDef)) else
                node.asname or node.name if isinstance(node, ast.alias) else
                node.value if isinstance(node, ast.Constant) and isinstance(node.value, str)
                and " " not in node.value else None)
        if name and "gnss" in name.lower() and name not in OLD_GNSS_NAMES:
            found.append((node.lineno, name))
    return found


def test_the_gnss_is_named_only_where_a_format_or_a_paper_needs_it():
    """Issue 38's one route: GNSS and the velocity sensor are ordinary registry entries.
    What processing takes from the GNSS it takes from the sensor whose fixes start a run
    (tests/test_fix_sensor.py flies the same run under another name)."""
    bad = {}
    for path in sorted(PKG.rglob("*.py")):
        rel = path.relative_to(PKG).as_posix()
        if rel.split("/")[0] in ("sensors", "io") or rel in GNSS_NAMED \
                or rel.split("/")[0] in GNSS_NAMED:
            continue
        if found := _names_gnss(path):
            bad[rel] = found[:3]
    assert not bad, bad
    assert all((PKG / p).exists() or (PKG / f"{p}.py").exists() for p in GNSS_NAMED)

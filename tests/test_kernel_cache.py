"""numba's cache of fednav's kernels is per version of the sources: a change of any module
(not only of the kernel's own file) compiles afresh (fednav._kernel_cache)."""

import os
import subprocess
import sys

from fednav import _kernel_cache


def test_the_cache_folder_is_named_by_every_source_file(tmp_path):
    (tmp_path / "a.py").write_text("x = 1\n")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "b.py").write_text("y = 2\n")
    h0 = _kernel_cache.source_hash(tmp_path)
    (tmp_path / "sub" / "b.py").write_text("y = 3\n")  # another module than the kernel's
    h1 = _kernel_cache.source_hash(tmp_path)
    (tmp_path / "sub" / "b.py").write_text("y = 2\n")  # reverted: the old kernels again
    assert h1 != h0 and _kernel_cache.source_hash(tmp_path) == h0


def test_fednav_sets_numba_cache_dir_and_respects_the_users(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(tmp_path)
    code = "import fednav, os, numba; print(os.environ['NUMBA_CACHE_DIR'])"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, check=True).stdout.strip()
    assert out.startswith(str(tmp_path / "fednav" / "kernels" / "0.1.0-"))
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "mine")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, check=True).stdout.strip()
    assert out == str(tmp_path / "mine")


def test_kernels_compile_at_fednavs_level_unless_the_user_sets_one(tmp_path):
    """``NUMBA_OPT`` 1 by default (a fresh install compiles in three quarters of the time
    at the same speed), the user's when set, and numba's own when numba came first."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_OPT"}
    env["XDG_CACHE_HOME"] = str(tmp_path)

    def level(code):
        return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                              text=True, check=True).stdout.split()

    code = "import fednav, os, numba; print(os.environ['NUMBA_OPT'], int(numba.config.OPT))"
    assert level(code) == [_kernel_cache.OPT_LEVEL] * 2 == ["1", "1"]
    first = "import numba, fednav, os; print(os.environ.get('NUMBA_OPT'), int(numba.config.OPT))"
    assert level(first) == ["None", "3"]  # (numba read its level before fednav came)
    env["NUMBA_OPT"] = "2"
    assert level(code) == ["2", "2"]
    del env["NUMBA_OPT"]  # a .numba_config.yaml in the working folder: numba's file rules
    (tmp_path / ".numba_config.yaml").write_text("opt: 2\n")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, cwd=tmp_path)
    assert "KeyError: 'NUMBA_OPT'" in out.stderr


def test_old_versions_are_pruned(tmp_path):
    import time

    for i in range(6):
        (tmp_path / f"v{i}").mkdir()
        t = time.time() - 100 + i
        os.utime(tmp_path / f"v{i}", (t, t))
    _kernel_cache._prune(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v2", "v3", "v4", "v5"]


def test_the_command_line_starts_without_the_sensors_once_it_remembers_their_options(
        tmp_path):
    """``fednav.cli`` builds one ``--NAME FILE`` option per registered sensor: the first
    process of a source tree imports the registry (and numba) for them and remembers
    them in its kernel folder; later ones start without (``fednav process --help`` ~0.3 s
    against ~0.7 s), with the same help as the registry gives live."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(XDG_CACHE_HOME=str(tmp_path), COLUMNS="200")
    code = ("import sys, fednav.cli; print(sorted(m for m in ('numba', 'fednav.sensors', "
            "'pydantic') if m in sys.modules))")

    def run(*args, **more):
        return subprocess.run([sys.executable, *args], env={**env, **more},
                              capture_output=True, text=True, check=True).stdout.strip()

    assert run("-c", code) == "['fednav.sensors', 'numba', 'pydantic']"  # (the first)
    assert run("-c", code) == "[]"
    remembered = run("-m", "fednav", "process", "csv", "--help")
    live = run("-m", "fednav", "process", "csv", "--help",
               NUMBA_CACHE_DIR=str(tmp_path / "mine"))  # (no folder of fednav's: live)
    assert remembered == live and "--baro" in live and "--gnss_raw" in live


def test_a_sensor_registered_before_the_options_are_built_gets_its_option():
    """With the registry imported (a plug-in registered a sensor), the options are the
    registry's, not the remembered ones."""
    import dataclasses
    import inspect

    from fednav import cli
    from fednav.sensors import registry

    registry.register(dataclasses.replace(registry.spec("baro"), name="plugin_baro"))
    try:
        def command(**files):
            pass

        names = inspect.signature(cli._sensor_file_options("gnss")(command)).parameters
    finally:
        registry.unregister("plugin_baro")
    assert "plugin_baro" in names and "baro" in names and "gnss" not in names

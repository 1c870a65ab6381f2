"""Record a kernel plan (:mod:`fednav.campaign.kernel_plan`) on an empty kernel cache.

    NUMBA_CACHE_DIR=$(mktemp -d) python tests/make_kernel_plan.py paper002

Run it after a change of the engine's records or kernels' arguments (the test suite's
``tests/test_kernel_plan.py`` says when the plan is stale).
"""

import os
import sys
import tempfile
from pathlib import Path

#: The command each plan records (``fednav`` arguments; ``OUT``: a fresh output folder).
COMMANDS = {"paper002": ["reproduce", "002", "--runs", "1", "--jobs", "1", "--fresh",
                         "--out", "OUT"]}


def run_command(name: str, out: Path):
    """A function that runs plan ``name``'s command in this process."""
    from typer.testing import CliRunner

    from fednav.cli import app

    args = [str(out) if a == "OUT" else a for a in COMMANDS[name]]

    def run():
        res = CliRunner().invoke(app, args)
        if res.exit_code != 0:
            raise RuntimeError(f"fednav {' '.join(args)} failed: {res.output[-500:]}")
    return run


def main() -> None:
    if len(sys.argv) != 2 or sys.argv[1] not in COMMANDS:
        sys.exit(f"usage: python tests/make_kernel_plan.py {{{','.join(COMMANDS)}}}")
    cache = os.environ.get("NUMBA_CACHE_DIR")
    if not cache or any(Path(cache).rglob("*.nbi")):
        sys.exit("set NUMBA_CACHE_DIR to an empty folder (a plan is what a first run "
                 "compiles)")
    from fednav.campaign import kernel_plan

    with tempfile.TemporaryDirectory() as tmp:
        plan = kernel_plan.record(run_command(sys.argv[1], Path(tmp) / "out"))
    print(kernel_plan.write(sys.argv[1], plan), f"({len(plan)} kernels)")


if __name__ == "__main__":
    main()

"""Record a kernel plan (:mod:`fednav.campaign.kernel_plan`) on an empty kernel cache.

    NUMBA_CACHE_DIR=$(mktemp -d) python tests/make_kernel_plan.py paper002

Run it after a change of the engine's records or kernels' arguments (the test suite's
``tests/test_kernel_plan.py`` says when the plan is stale).
"""

import os
import pickle
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: Per plan: the ``fednav`` commands that make its inputs, then the command it records
#: (``OUT``: a fresh folder; ``EXAMPLES``: the clone's examples).
COMMANDS = {
    "paper002": ([], ["reproduce", "002", "--runs", "1", "--jobs", "1", "--fresh", "--out",
                      "OUT/run"]),
    # the README's second command: a simulated car drive processed from its files
    "process-csv": ([["simulate", "EXAMPLES/car-drive.yaml", "--out", "OUT/sim"]],
                    ["process", "csv", "--imu", "OUT/sim/imu.csv", "--gnss", "OUT/sim/gnss.csv",
                     "--velocity", "OUT/sim/velocity.csv", "--ref", "OUT/sim/reference.csv",
                     "--config", "OUT/sim/process.yaml", "--smooth", "--out", "OUT/processed"]),
}


def run_command(name: str, out: Path):
    """Make plan ``name``'s inputs under ``out`` and return a function that runs its
    command in this process."""
    from typer.testing import CliRunner

    from fednav.cli import app

    def invoke(args):
        args = [a.replace("OUT", str(out)).replace("EXAMPLES", str(ROOT / "examples"))
                for a in args]
        res = CliRunner().invoke(app, args)
        if res.exit_code != 0:
            raise RuntimeError(f"fednav {' '.join(args)} failed: {res.output[-500:]}")

    setup, command = COMMANDS[name]
    for args in setup:
        invoke(args)
    return lambda: invoke(command)


def main() -> None:
    """``make_kernel_plan.py NAME [--to FILE]``: record plan NAME and keep it (or, with
    ``--to``, pickle the kernels to FILE: the test suite's check)."""
    args = sys.argv[1:]
    to = None
    if len(args) == 3 and args[1] == "--to":
        args, to = args[:1], Path(args[2])
    if len(args) != 1 or args[0] not in COMMANDS:
        sys.exit(f"usage: python tests/make_kernel_plan.py {{{','.join(COMMANDS)}}} "
                 f"[--to FILE]")
    from fednav import _kernel_cache
    from fednav.campaign import kernel_plan

    if not os.environ.get("NUMBA_CACHE_DIR") or not _kernel_cache.cold():
        sys.exit("set NUMBA_CACHE_DIR to an empty folder (a plan is what a first run "
                 "compiles)")
    with tempfile.TemporaryDirectory() as tmp:
        plan = kernel_plan.record(run_command(args[0], Path(tmp)))
    if to is not None:
        to.write_bytes(pickle.dumps(plan))
        return
    print(kernel_plan.write(args[0], plan), f"({len(plan)} kernels)")


if __name__ == "__main__":
    main()

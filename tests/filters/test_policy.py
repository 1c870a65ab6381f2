"""The federated filter's rules are written once (:mod:`fednav.filters.policy`): the Python
federated filter, the Python loop and the compiled engine call them and write none of
them again."""

import ast
import math
from pathlib import Path

import numpy as np
import pytest

from fednav.filters import policy

SRC = Path(__file__).resolve().parents[2] / "src" / "fednav"
RULES = ("fdi_gate", "fdi_passes", "is_accepted", "adapt_qlog", "adapted_qd",
         "fused_q_scale", "adaptive_shares", "validity_sample", "leave_one_out")
#: who calls which rule
CALLERS = {"filters/federated.py": {"fdi_gate", "fdi_passes", "adapt_qlog", "adapted_qd",
                                    "fused_q_scale", "adaptive_shares", "leave_one_out"},
           "navigator/engine.py": set(RULES),
           "navigator/loop.py": {"validity_sample"}}


def _calls(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    return {n.func.attr for n in ast.walk(tree) if isinstance(n, ast.Call)
            and isinstance(n.func, ast.Attribute) and isinstance(n.func.value, ast.Name)
            and n.func.value.id == "policy"}


@pytest.mark.parametrize("module", sorted(CALLERS))
def test_each_engine_calls_the_rules(module):
    assert CALLERS[module] <= _calls(SRC / module)


@pytest.mark.parametrize("module", sorted(CALLERS))
def test_no_engine_writes_a_rule_again(module):
    """The rules' own expressions appear in policy.py only: the recovery count, the Q
    adaptation's step, the exponential scale of Qd, the sharing traces' normalisation and
    the sample nearest the time of validity."""
    text = (SRC / module).read_text().replace(" ", "")
    for pattern in ("+1<recovery", "+1<self.fdi_recovery", "/dof-1.0", "/d-1.0",
                    "exp(qlog", "exp(self.qlog", "/traces.sum()", "traces[f]/", "int(round((",
                    "recoveryifacceptedelse0", "recoveryifinn.acceptedelse0"):
        assert pattern not in text, f"{module} writes a rule of policy.py again: {pattern}"
    for node in ast.walk(ast.parse((SRC / module).read_text())):
        if isinstance(node, ast.FunctionDef):
            assert node.name not in RULES, f"{module} defines {node.name} again"


def test_the_gate_off_testing_and_on():
    assert policy.fdi_gate(np.nan, 0, 1) == np.inf
    assert policy.fdi_gate(9.0, 0, 3) == -1.0  # recovering: test only
    assert policy.fdi_gate(9.0, 1, 3) == -1.0
    assert policy.fdi_gate(9.0, 2, 3) == 9.0  # two passes in a row: the gate
    assert policy.fdi_gate(9.0, 0, 1) == 9.0


def test_recovery_needs_consecutive_passes():
    """recovery 3: an isolation, then two passes in a row tested only, the third applied;
    a failure while recovering starts the count again."""
    thr, rec = 9.0, 3
    passes, seen = rec, []
    for nis in (20.0, 1.0, 20.0, 1.0, 1.0, 1.0):
        gate = policy.fdi_gate(thr, passes, rec)
        seen.append(bool(policy.is_accepted(nis, gate)))
        passes = policy.fdi_passes(thr, gate, passes, rec, nis)
    assert seen == [False, False, False, False, False, True]
    assert passes == rec
    assert policy.fdi_passes(np.nan, np.inf, 5, 1, 1e9) == 5  # detection off: untouched


def test_leave_one_out_finds_the_unit_that_explains_the_failure():
    """Three satellites of two rows each, correlated through a common clock: a 40-sigma
    error on satellite 12's rows fails the test; leaving 12 out passes (its statistic
    is the one of the rows left, r_k' S_kk^-1 r_k, against the threshold of their
    count), no other unit does; one unit, or no unit whose removal passes: none."""
    from fednav.core.stats import chi2_ppf

    groups = np.array([5, 12, 30, 5, 12, 30], dtype=np.int64)
    S = np.eye(6) + 0.5  # (a shared clock: every row correlated)
    r = np.array([0.3, 40.0, -0.2, 0.1, 38.0, 0.4])
    thr = np.array([np.nan] + [chi2_ppf(0.999, d) for d in range(1, 7)])
    u, stat, keep = policy.leave_one_out(r, S, groups, thr)
    k = groups != 12
    assert u == 12 and np.array_equal(keep, k)
    assert stat == pytest.approx(r[k] @ np.linalg.solve(S[np.ix_(k, k)], r[k]), rel=1e-12)
    assert stat <= thr[4]
    r[0] = 40.0  # two satellites faulty: no single one explains it
    assert policy.leave_one_out(r, S, groups, thr)[0] == -1
    one = np.array([7, 7], dtype=np.int64)
    assert policy.leave_one_out(r[:2], S[:2, :2], one, thr)[0] == -1


def test_q_adaptation_steps_within_its_bounds():
    assert policy.adapt_qlog(0.0, 0.1, 4.0, 2, 1.0) == pytest.approx(0.1)
    assert policy.adapt_qlog(0.0, 0.1, 0.5, 2, 1.0) == 0.0
    assert policy.adapt_qlog(0.9, 1.0, 100.0, 1, math.log(4.0)) == math.log(4.0)
    Qd, Qw = np.eye(2) * 3.0, np.eye(2)
    assert np.allclose(policy.adapted_qd(Qd, Qw, math.log(2.0)), np.eye(2) * 4.0)
    # equal scales: the fused prior's scale is that scale; none adapted: 1
    assert policy.fused_q_scale(np.array([0.5, 0.5]), np.log([2.0, 2.0])) == pytest.approx(2.0)
    assert policy.fused_q_scale(np.array([0.3, 0.7]), np.zeros(2)) == pytest.approx(1.0)


def test_adaptive_shares_follow_the_information():
    b = policy.adaptive_shares(np.array([1.0, 3.0]))
    assert np.allclose(b, [0.25, 0.75]) and b.sum() == pytest.approx(1.0)


@pytest.mark.parametrize(("t", "j", "lag"), [(10.0, 0, 0.0), (10.013, 1, -0.003),
                                             (10.016, 2, 0.004), (9.5, 0, 0.5),
                                             (10.5, 10, -0.4)])
def test_the_sample_nearest_the_time_of_validity(t, j, lag):
    """An interval from 10 s with 10 samples 10 ms apart: the nearest sample, clamped to
    the interval, and its time minus the time of validity."""
    jj, lg = policy.validity_sample(t, 10.0, 0.01, 10)
    assert jj == j and lg == pytest.approx(lag, abs=1e-12)


@pytest.mark.parametrize("module", ["navigator/engine.py", "filters/policy.py",
                                    "filters/federated.py"])
def test_the_compiled_functions_take_records_not_dozens_of_arrays(module):
    """The engine's cycle is named stages over typed records: no compiled function of the
    engine, the rules or the federated filter takes more than 10 parameters."""
    for node in ast.walk(ast.parse((SRC / module).read_text())):
        if isinstance(node, ast.FunctionDef) and any(
                "njit" in ast.unparse(d) for d in node.decorator_list):
            n = len(node.args.args)
            assert n <= 10, f"{module}: {node.name} takes {n} parameters"

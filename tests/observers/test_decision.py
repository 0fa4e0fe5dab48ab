"""Decisions on residuals (observer_cad.observers.decide): alarms with persistence and
isolation by column matching, on hand-checkable arrays; a property test against a plain
loop; the rules built from a design and from a bank."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from observer_cad.errors import UsageError
from observer_cad.residuals import NO_FAULT, UNKNOWN_PATTERN, DecisionRule, decide, decision_rule

ROOT = Path(__file__).resolve().parents[2]
NAN = float("nan")


def single(persistence=1):
    return DecisionRule(residuals=("r",), faults=("f1", "f2"), structure=((1, 1),),
                        persistence=persistence)


def cols(r, lo=-1.0, hi=1.0, name="r"):
    r = np.asarray(r, dtype=float)
    return {name: r, f"{name}_lower": np.full_like(r, lo), f"{name}_upper": np.full_like(r, hi)}


def test_persistence_one_alarms_at_every_out_sample():
    d = decide(single(), cols([0, 2, 0.5, -3, -3, 0]))
    assert d.alarm.tolist() == [False, True, False, True, True, False]
    assert d.code.tolist() == [0, 1, 0, 1, 1, 0]
    # one residual sensitive to both faults: its column equals both
    assert d.diagnosis.tolist() == [NO_FAULT, "f1 or f2", NO_FAULT, "f1 or f2", "f1 or f2",
                                    NO_FAULT]


def test_persistence_three_needs_three_consecutive_outs():
    r = [2, 2, 0, 2, 2, 2, 2, 0, 2, 2, 2]
    d = decide(single(3), cols(r))
    assert d.alarm.astype(int).tolist() == [0, 0, 0, 0, 0, 1, 1, 0, 0, 0, 1]
    assert d.out[0].astype(int).tolist() == [1, 1, 0, 1, 1, 1, 1, 0, 1, 1, 1]


def test_boundary_is_inside_and_nan_is_not_out():
    # strict comparisons: exactly on lower/upper is in; NaN residual or bound is not out
    r = np.array([1.0, -1.0, np.nextafter(1.0, 2), NAN, 5.0, 5.0])
    c = cols(r)
    c["r_upper"] = np.array([1.0, 1.0, 1.0, 1.0, NAN, 1.0])
    d = decide(single(), c)
    assert d.alarm.tolist() == [False, False, True, False, False, True]


def test_nan_breaks_a_run_of_outs():
    d = decide(single(2), cols([2, NAN, 2, 2]))
    assert d.alarm.tolist() == [False, False, False, True]


def test_time_varying_band():
    r = np.array([0.0, 0.0, 0.0])
    c = {"r": r, "r_lower": np.array([-1.0, 0.5, -0.1]), "r_upper": np.array([1.0, 1.0, -0.05])}
    assert decide(single(), c).alarm.tolist() == [False, True, True]


GOS = DecisionRule(residuals=("r1", "r2", "r3"), faults=("f1", "f2", "f3"),
                   structure=((0, 1, 1), (1, 0, 1), (1, 1, 0)))


def bank_cols(pattern_rows):
    """pattern_rows: per sample, which residuals are out (0/1 per residual)."""
    P = np.asarray(pattern_rows, dtype=float).T  # (m, N)
    out = {}
    for i, row in enumerate(P, 1):
        out.update(cols(2 * row, name=f"r{i}"))
    return out


def test_bank_patterns_match_columns():
    d = decide(GOS, bank_cols([[0, 0, 0], [0, 1, 1], [1, 0, 1], [1, 1, 0], [1, 0, 0],
                               [1, 1, 1]]))
    assert d.diagnosis.tolist() == [NO_FAULT, "f1", "f2", "f3", UNKNOWN_PATTERN,
                                    UNKNOWN_PATTERN]
    # code: bit i-1 for residual i
    assert d.code.tolist() == [0, 6, 5, 3, 1, 7]
    assert d.alarm_of("r2").astype(int).tolist() == [0, 1, 0, 1, 0, 1]


def test_identical_columns_give_an_or_in_fault_order():
    rule = DecisionRule(residuals=("r1", "r2"), faults=("f1", "f2", "f3"),
                        structure=((1, 0, 1), (1, 1, 1)))
    assert rule.table() == (NO_FAULT, UNKNOWN_PATTERN, "f2", "f1 or f3")
    assert rule.diagnoses() == (NO_FAULT, "f1 or f3", "f2", UNKNOWN_PATTERN)
    d = decide(rule, bank_cols([[1, 1], [0, 1], [1, 0]]))
    assert d.diagnosis.tolist() == ["f1 or f3", "f2", UNKNOWN_PATTERN]


def test_vectorised_over_runs_equals_run_by_run():
    rng = np.random.default_rng(3)
    R, N = 5, 40
    c = {}
    for i in (1, 2, 3):
        c[f"r{i}"] = rng.uniform(-2, 2, (R, N))
        c[f"r{i}_lower"] = np.full((R, N), -1.0)
        c[f"r{i}_upper"] = rng.uniform(0.5, 1.5, (R, N))
    rule = DecisionRule(GOS.residuals, GOS.faults, GOS.structure, persistence=2)
    d = decide(rule, c)
    assert d.code.shape == (R, N) and d.diagnosis.shape == (R, N)
    for k in range(R):
        one = decide(rule, {n: v[k] for n, v in c.items()})
        assert np.array_equal(one.code, d.code[k])
        assert list(one.diagnosis) == list(d.diagnosis[k])


def _loop_reference(out, n):
    c, alarms = 0, []
    for o in out:
        c = c + 1 if o else 0
        alarms.append(c >= n)
    return alarms


@settings(max_examples=200, deadline=None)
@given(st.lists(st.booleans(), min_size=1, max_size=60), st.integers(1, 6))
def test_alarm_exactly_in_runs_of_at_least_n_outs(out, n):
    r = np.where(out, 2.0, 0.0)
    d = decide(single(n), cols(r))
    got = d.alarm.tolist()
    assert got == _loop_reference(out, n)
    # and as a statement about runs: sample k alarms iff samples k-n+1 … k are all out
    for k in range(len(out)):
        assert got[k] == (k + 1 >= n and all(out[k - n + 1:k + 1]))


def test_columns_for_the_writer():
    d = decide(GOS, bank_cols([[0, 1, 1], [0, 0, 0]]))
    c = d.columns()
    assert c["alarm"].tolist() == [1, 0]
    assert c["r1_alarm"].tolist() == [0, 0] and c["r3_alarm"].tolist() == [1, 0]
    assert c["diagnosis"].tolist() == ["f1", NO_FAULT]


@pytest.mark.parametrize("kwargs, msg", [
    (dict(residuals=(), faults=("f",), structure=()), "residuals is empty"),
    (dict(residuals=("r", "r"), faults=("f",), structure=((1,), (1,))), "appears twice"),
    (dict(residuals=("r",), faults=("f",), structure=((1,), (0,))), "2 rows"),
    (dict(residuals=("r",), faults=("f", "g"), structure=((1,),)), "2 entries"),
    (dict(residuals=("r",), faults=("f",), structure=((2,),)), "entries are 0 or 1"),
    (dict(residuals=("r",), faults=("f",), structure=((1,),), persistence=0), "persistence"),
    (dict(residuals=("r",), faults=("f",), structure=((1,),), persistence=1.5), "persistence"),
    (dict(residuals=("r",), faults=("f",), structure=((1,),), persistence=True), "persistence"),
    (dict(residuals="r", faults=("f",), structure=((1,),)), "sequence of names"),
])
def test_rule_validation_is_one_line(kwargs, msg):
    with pytest.raises(UsageError, match=msg) as e:
        DecisionRule(**kwargs)
    assert "\n" not in str(e.value)


def test_missing_threshold_column_is_named():
    c = cols([0.0, 1.0])
    del c["r_upper"]
    with pytest.raises(UsageError, match="no column 'r_upper'.*threshold"):
        decide(single(), c)
    c = cols([0.0, 1.0])
    c["r_lower"] = np.zeros(3)
    with pytest.raises(UsageError, match="'r_lower' has shape"):
        decide(single(), c)


def test_rule_of_a_bank_and_of_a_design():
    from observer_cad.model import load_model
    from observer_cad.synthesis import design
    from observer_cad.analysis import design_bank
    tanks = load_model(ROOT / "models" / "three_tank_isolation.py")
    bank = design_bank(tanks, structure="011,101,110")
    rule = decision_rule(tanks, bank, persistence=4)
    assert rule.residuals == ("r1", "r2", "r3")
    assert rule.faults == ("f1", "f2", "f3")
    assert rule.structure == ((0, 1, 1), (1, 0, 1), (1, 1, 0))
    assert rule.persistence == 4
    drive = load_model(ROOT / "models" / "electric_drive.py")
    d = design(drive, observer="diagnostic")
    rule = decision_rule(drive, d)
    assert rule.residuals == ("r",) and rule.faults == ("d",) and rule.structure == ((1,),)
    assert rule.table() == (NO_FAULT, "d")
    with pytest.raises(UsageError, match="no residual"):
        tank = load_model(ROOT / "models" / "three_tank.py")
        decision_rule(tank, design(tank, observer="virtual-sensor", estimate="x1"))
    with pytest.raises(UsageError, match="not a str"):
        decision_rule(drive, "bank")


def test_thirty_residuals_fill_the_code_bits():
    names = tuple(f"r{i}" for i in range(1, 31))
    rule = DecisionRule(names, ("f",), tuple((1,) for _ in names), persistence=3)
    c = {}
    for i, r in enumerate(names):
        c.update(cols([2.0, 2.0, 2.0, 2.0 if i % 2 else 0.0], name=r))
    d = decide(rule, c)
    assert d.code.tolist() == [0, 0, 2 ** 30 - 1, sum(1 << i for i in range(1, 30, 2))]
    assert d.diagnosis[2] == "f" and d.diagnosis[3] == UNKNOWN_PATTERN
    with pytest.raises(UsageError, match="at most 30"):
        DecisionRule(names + ("r31",), ("f",), tuple((1,) for _ in range(31)))


def test_a_fault_seen_only_as_a_transient_is_still_named_after_its_transient():
    """r1 sees f2 only as a transient (zero steady-state gain): while f2 persists the pattern
    is first (1, 1), f2's column, then (0, 1) once r1 is back in its band — its column of the
    steady rows (the strong structure matrix). Both name f2; without the steady rows the
    second was "unknown pattern"."""
    from observer_cad.residuals import DecisionRule
    weak = DecisionRule(residuals=("r1", "r2"), faults=("f1", "f2"), structure=((1, 1), (0, 1)))
    rule = DecisionRule(residuals=("r1", "r2"), faults=("f1", "f2"), structure=((1, 1), (0, 1)),
                        steady=((1, 0), (0, 1)))
    assert weak.diagnosis(0b10) == "unknown pattern"
    assert rule.diagnosis(0b11) == "f2" and rule.diagnosis(0b10) == "f2"
    assert rule.diagnosis(0b01) == "f1"
    assert rule.steady_column("f2") == (0, 1) and rule.column("f2") == (1, 1)
    assert "after a fault's transient: 10, 01" in rule.describe()
    assert rule.table() == ("no fault", "f1", "f2", "f2")
    # steady rows equal to the structure are the same rule
    same = DecisionRule(residuals=("r1",), faults=("f1",), structure=((1,),), steady=((1,),))
    assert same.steady == () and same == DecisionRule(residuals=("r1",), faults=("f1",),
                                                      structure=((1,),))
    with pytest.raises(UsageError, match="steady has 1 rows but there are 2 residuals"):
        DecisionRule(residuals=("r1", "r2"), faults=("f1",), structure=((1,), (0,)), steady=((1,),))

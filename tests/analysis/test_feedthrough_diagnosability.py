"""Diagnosability with faults and disturbances in the outputs, and strong detectability.

Grouped by what they prove:
* published examples (docs/REFERENCES.md: "FaultDetectionTools.jl", which asserts the
  structure matrices of Varga 2017 §5.2 for the papers named below, and the least orders
  of ``fdichkspec``): weak and strong structure matrices compared as sets of rows, least
  orders of the rows;
* random systems with feedthrough against independent criteria: f is detectable with
  the disturbances decoupled iff the normal rank of the pencil grows,
  nrank [[sI − F, L, D_f], [−H, Ly, Dy_f]] > nrank [[sI − F, L], [−H, Ly]]
  (equivalently rank [G_f G_ρ] > rank G_ρ over rational functions), and, at a point λ
  where the disturbance pencil keeps its normal rank, strongly detectable at λ iff the
  rank grows there;
* without feedthrough the order-by-order spaces reproduce the geometric recursion;
* a zero-order residual (the outputs alone suffice) and a fault seen only as a transient.
"""
from __future__ import annotations

import dataclasses
import json
import random

import pytest
import sympy as sp
from hypothesis import given, settings, strategies as st

from observer_cad.analysis import analyze, detecting_orders, feedthrough_orders
from observer_cad.model import random_structure
from observer_cad.reporting import format_analysis

from .varga_examples import (boeing_747, niemann, rows, structure, xiong_saif_1,
                             xiong_saif_2, yuan_1997)


def pattern_set(a, structure_rows):
    return {r.sensitive for r in structure_rows}


def row_least_order(st, sensitive):
    """The least order of a residual sensitive to ``sensitive`` with every other fault
    decoupled (fdichkspec's least order): the largest of the faults' least orders with
    the others moved to the disturbances."""
    names = [f.name for f in st.model.faults]
    dec = [j for j, f in enumerate(names) if f not in sensitive]
    sen = [j for j, f in enumerate(names) if f in sensitive]
    L = sp.Matrix.hstack(st.L, *[st.D[:, j] for j in dec])
    Ly = sp.Matrix.hstack(st.Ly, *[st.Dy[:, j] for j in dec])
    D = sp.Matrix.hstack(*[st.D[:, j] for j in sen])
    Dy = sp.Matrix.hstack(*[st.Dy[:, j] for j in sen])
    orders, _ = feedthrough_orders(st.F, st.H, L, Ly, D, Dy)
    return max(orders)


# ---------------------------------------------------------------- published examples
# (example, weak rows, strong rows at ω = 0 and 1, least orders of the weak rows)
PUBLISHED = {
    # Niemann & Stoustrup 1998 (fdigenspec test): rows 11, 01, 10; least orders 1, 1, 1
    "niemann": (niemann, ["11", "01", "10"], ["11", "01", "10"],
                {"01": 1, "10": 1, "11": 1}),
    # Xiong & Saif 2000, Example 1, a sensor fault on y3: least orders 1, 2, 1
    "xiong_saif_1": (xiong_saif_1, ["11", "01", "10"], ["11", "01", "10"],
                     {"01": 1, "10": 2, "11": 1}),
    # Xiong & Saif 2000, Example 2: least orders 1, 1, 1
    "xiong_saif_2": (xiong_saif_2, ["11", "01", "10"], ["11", "01", "10"],
                     {"01": 1, "10": 1, "11": 1}),
    # the Boeing 747 (Varga 2007), f5 also in the second output: weak rows with least
    # orders 1, 2, 1, 2, 1, 1, 1; strong rows (ω = 0 and 1) all of order 1
    "boeing_747": (boeing_747,
                   ["00001", "00110", "00111", "11000", "11001", "11110", "11111"],
                   ["11111", "00111", "11001", "11110"],
                   {"00001": 1, "00110": 2, "00111": 1, "11000": 2, "11001": 1,
                    "11110": 1, "11111": 1}),
}


@pytest.mark.parametrize("name", sorted(PUBLISHED))
def test_published_structure_matrices_and_least_orders(name):
    make, weak, strong, orders = PUBLISHED[name]
    st = make()
    a = analyze(st.model, structure=st, frequencies=[0, 1])
    assert pattern_set(a, a.structure) == rows(weak)
    assert pattern_set(a, a.strong_structure) == rows(strong)
    for p, k in orders.items():
        assert row_least_order(st, rows([p]).pop()) == k, p
    if name == "boeing_747":  # every strong row has a residual of order 1
        assert {r.order for r in a.strong_structure} == {1}


def test_yuan_1997_eight_faults():
    """Yuan et al. 1997 (fdigenspec test): 18 weak rows, 12 strong rows at ω = 0 and 1;
    six weak rows lose a fault to a zero gain (detected only as a transient there)."""
    st = yuan_1997()
    a = analyze(st.model, structure=st, frequencies=[0, 1])
    weak = ["00010011", "01101110", "01111101", "01111111", "10101110", "10111101",
            "10111111", "11001100", "11011111", "11100110", "11101010", "11101110",
            "11110101", "11110111", "11111001", "11111011", "11111101", "11111111"]
    strong = ["00010011", "01101110", "01111101", "01111111", "10101110", "10111101",
              "10111111", "11001100", "11011111", "11101110", "11111101", "11111111"]
    assert pattern_set(a, a.structure) == rows(weak)
    assert pattern_set(a, a.strong_structure) == rows(strong)
    # the model has no feedthrough: the weak answers are those of the geometric recursion
    orders, _ = detecting_orders(st.F, st.H, st.L, st.D)
    assert tuple(r.min_order for r in a.fault_results) == orders


# ---------------------------------------------------------------- small cases
def test_zero_order_residual_from_redundant_sensors():
    """Three sensors on one state, a bias on each: y_i − y_j is a residual of order 0
    (R* H = 0, R* Dy ≠ 0), with a nonzero steady-state gain."""
    F, H = sp.Matrix([[-1]]), sp.Matrix([[1], [1], [1]])
    st = structure(F, H, sp.zeros(1, 3), Dy=sp.eye(3), name="triplex")
    a = analyze(st.model, structure=st)
    assert [r.min_order for r in a.fault_results] == [0, 0, 0]
    assert all(p.isolable and p.a_from_b_order == 0 for p in a.pairs)
    assert a.strongly_detectable == {"f1": True, "f2": True, "f3": True}
    # two sensors compared: order 0; one sensor against the model (x' = −x + u): order 1
    assert {r.sensitive: r.order for r in a.strong_structure} == {
        ("f1", "f2", "f3"): 0, ("f2", "f3"): 0, ("f1", "f3"): 0, ("f1", "f2"): 0,
        ("f3",): 1, ("f2",): 1, ("f1",): 1}
    j = a.to_json()
    assert j["strongly_detectable"] == {"f1": True, "f2": True, "f3": True}
    assert sorted(map(json.dumps, j["strong_structure_matrices"])) == \
        sorted(map(json.dumps, j["structure_matrices"]))


def transient_example():
    """x1' = −x1 + f1, x2' = −2 x2 + 2 f1, y = (x1 + ρ + f2, x2 + ρ): decoupling ρ
    leaves y1 − y2, whose transfer to f1 is −s / ((s + 1)(s + 2)) (zero steady-state
    gain) and to the sensor bias f2 is 1 (a residual compares y1 − y2 with its
    fault-free estimate: the gains keep these zeros)."""
    F = sp.Matrix([[-1, 0], [0, -2]])
    return structure(F, sp.eye(2), sp.Matrix([[1, 0], [2, 0]]), Dy=sp.Matrix([[0, 1], [0, 0]]),
                     L=sp.zeros(2, 1), Ly=sp.Matrix([[1], [1]]), name="transient")


def test_fault_seen_only_as_a_transient():
    st = transient_example()
    a = analyze(st.model, structure=st)
    assert a.detectable == {"f1": True, "f2": True}
    # y1 − y2 = x1 − x2 + f2 must be compared with an estimate of x1 − x2: order 2
    # (order 1 would need R* = a(1, −1), J*_1 = b(1, −1) and R* F = J*_1 H)
    assert [r.min_order for r in a.fault_results] == [2, 2]
    assert a.strongly_detectable == {"f1": False, "f2": True}
    assert a.transient_only == ("f1",)
    text = format_analysis(a)
    assert "f1  detectable only as a transient" in text
    # at ω = 1 the gain −j / ((j + 1)(j + 2)) is not zero
    b = analyze(st.model, structure=st, frequencies=["1"])
    assert b.strongly_detectable == {"f1": True, "f2": True}
    # every weak row with f1 is lost at ω = 0, kept at ω = 1
    assert all("f1" not in r.sensitive for r in a.strong_structure)
    assert pattern_set(b, b.strong_structure) == pattern_set(b, b.structure)


def test_transient_in_discrete_time():
    """The same numerator in discrete time: x1+ = x1/2 + f1, x2+ = x2/4 + (3/2) f1 has
    the steady-state gains 2 and 2 (z = 1), so y1 − y2 has none to f1."""
    F = sp.Matrix([[sp.Rational(1, 2), 0], [0, sp.Rational(1, 4)]])
    st = structure(F, sp.eye(2), sp.Matrix([[1], [sp.Rational(3, 2)]]), L=sp.zeros(2, 1),
                   Ly=sp.Matrix([[1], [1]]), time="discrete", name="transient_d")
    a = analyze(st.model, structure=st, frequencies=[0, "0.5"])
    assert a.detectable == {"f1": True}
    assert a.strongly_detectable == {"f1": False}
    c = analyze(st.model, structure=st, frequencies=["0.5"])
    assert c.strongly_detectable == {"f1": True}
    assert any("floating point" in n for n in c.notes)


def test_frequency_option_refuses_text_that_is_not_a_number():
    st = transient_example()
    from observer_cad.errors import UsageError
    for bad in ("1+1", "pi", "-1", "__import__('os')", "1e100000000", "1e13", "1e-300",
                "1" * 60):
        with pytest.raises(UsageError):
            analyze(st.model, structure=st, frequencies=[bad])


# ---------------------------------------------------------------- random systems
def _rand(rng, r, c, density=0.6):
    return sp.Matrix(r, c, lambda i, j: rng.choice([-2, -1, 1, 2]) if rng.random() < density
                     else 0)


def _pencil_rank(F, H, X, Xy, s0):
    n = F.rows
    top = sp.Matrix.hstack(s0 * sp.eye(n) - F, X)
    return sp.Matrix.vstack(top, sp.Matrix.hstack(-H, Xy)).rank()


def _normal_rank(F, H, X, Xy):
    return max(_pencil_rank(F, H, X, Xy, s0)
               for s0 in (sp.Rational(7, 3), sp.Rational(-11, 5), sp.Rational(13, 17)))


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10 ** 6), st.sampled_from(["continuous", "discrete"]))
def test_random_feedthrough_against_the_normal_rank(seed, time):
    rng = random.Random(seed)
    n, l, p, m = rng.randint(1, 4), rng.randint(1, 3), rng.randint(0, 2), 2
    F, H = _rand(rng, n, n), _rand(rng, l, n, 0.7)
    L, Ly = _rand(rng, n, p), _rand(rng, l, p, 0.4)
    D, Dy = _rand(rng, n, m), _rand(rng, l, m, 0.4)
    weak, _ = feedthrough_orders(F, H, L, Ly, D, Dy)
    strong, _ = feedthrough_orders(F, H, L, Ly, D, Dy, frequencies=[0], time=time)
    base = _normal_rank(F, H, L, Ly)
    lam = 0 if time == "continuous" else 1
    base_at = _pencil_rank(F, H, L, Ly, lam)
    for j in range(m):
        X, Xy = sp.Matrix.hstack(L, D[:, j]), sp.Matrix.hstack(Ly, Dy[:, j])
        assert (weak[j] is not None) == (_normal_rank(F, H, X, Xy) > base), (seed, j)
        assert weak[j] is None or weak[j] <= n
        if strong[j] is not None:
            assert weak[j] is not None and strong[j] >= weak[j]
        if base_at == base:  # λ is not a zero of the disturbance pencil
            grows = _pencil_rank(F, H, X, Xy, lam) > base_at
            assert (strong[j] is not None) == grows, (seed, j)


@pytest.mark.parametrize("seed", range(12))
def test_without_feedthrough_the_orders_are_the_geometric_ones(seed):
    n, l, p = 3 + seed % 4, 1 + seed % 3, seed % 3
    _, s = random_structure(n, l, p, seed=seed, m=2)
    expected, _ = detecting_orders(s.F, s.H, s.L, s.D)
    got, _ = feedthrough_orders(s.F, s.H, s.L, sp.zeros(l, p), s.D, sp.zeros(l, 2))
    assert got == expected


def test_float_path_agrees_on_a_published_example():
    st = boeing_747()
    exact = analyze(st.model, structure=st, frequencies=[0, 1])
    flt = analyze(st.model, structure=st, frequencies=[0, 1], method="float")
    assert pattern_set(flt, flt.structure) == pattern_set(exact, exact.structure)
    assert pattern_set(flt, flt.strong_structure) == pattern_set(exact, exact.strong_structure)


def test_structure_fields_default_to_zero():
    _, s = random_structure(3, 2, 1, seed=1, m=2)
    assert s.Dy.shape == (2, s.D.cols) and s.Ly.shape == (2, s.L.cols)
    assert s.Gy.shape == (2, s.G.cols)
    assert not s.has_feedthrough
    Dy = sp.zeros(2, s.D.cols)
    Dy[0, 0] = 1
    assert dataclasses.replace(s, Dy=sp.ImmutableMatrix(Dy)).has_feedthrough


# ---------------------------------------------------------------- the command line
def test_cli_frequency_and_json_keys(capsys, models_dir):
    from observer_cad.cli import main
    path = str(models_dir / "three_tank_faults.py")
    assert main(["analyze", path, "--json", "--frequency", "0", "--frequency", "0.5"]) == 0
    js = json.loads(capsys.readouterr().out)
    assert js["frequencies"] == ["0", "1/2"]
    assert js["strongly_detectable"] == {"f1": True, "f2": True, "f3": False}
    assert js["strong_structure_matrices"] == [{"f1": 1, "f2": 1, "f3": 0}]
    assert js["structure_matrices"] == [{"f1": 1, "f2": 1, "f3": 0}]  # unchanged
    assert main(["analyze", path]) == 0
    out = capsys.readouterr().out
    assert "Strong detectability" in out and "f1  strongly detectable" in out
    assert main(["analyze", path, "--frequency", "1e"]) == 2
    assert "observer-cad: error: frequency '1e'" in capsys.readouterr().err


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 10 ** 6))
def test_random_feedthrough_isolation_through_analyze(seed):
    """analyze builds each decoupled set's residual generators from its parent's; the
    isolation orders and strong answers equal those computed from scratch with the
    other fault moved to the disturbances."""
    rng = random.Random(seed)
    n, l, p = rng.randint(1, 4), rng.randint(1, 3), rng.randint(0, 1)
    F, H = _rand(rng, n, n), _rand(rng, l, n, 0.7)
    L, Ly = _rand(rng, n, p), _rand(rng, l, p, 0.4)
    D, Dy = _rand(rng, n, 3), _rand(rng, l, 3, 0.5)
    for j in range(3):  # every fault enters somewhere (a model declares only those)
        if not any(D[:, j]) and not any(Dy[:, j]):
            Dy[rng.randrange(l), j] = 1
    if p and not any(L[:, 0]) and not any(Ly[:, 0]):
        Ly[0, 0] = 1
    s = structure(F, H, D, Dy, L, Ly, name="random_ft")
    a = analyze(s.model, structure=s, frequencies=[0])
    for i, j in [(0, 1), (1, 0), (2, 0), (0, 2), (1, 2), (2, 1)]:
        Lj, Lyj = sp.Matrix.hstack(L, D[:, j]), sp.Matrix.hstack(Ly, Dy[:, j])
        (weak,), _ = feedthrough_orders(F, H, Lj, Lyj, D[:, i], Dy[:, i])
        (strong,), _ = feedthrough_orders(F, H, Lj, Lyj, D[:, i], Dy[:, i], frequencies=[0])
        fi, fj = f"f{i + 1}", f"f{j + 1}"
        pair = a.pair(fi, fj)
        assert pair.a_from_b == (weak is not None) and pair.a_from_b_order == weak
    strong_rows = {r.sensitive for r in a.strong_structure}
    for row in a.structure:
        dec = [int(f[1:]) - 1 for f in row.requested]
        Ls = sp.Matrix.hstack(L, *[D[:, j] for j in dec])
        Lys = sp.Matrix.hstack(Ly, *[Dy[:, j] for j in dec])
        kept = all(feedthrough_orders(F, H, Ls, Lys, D[:, i], Dy[:, i], frequencies=[0])[0][0]
                   is not None for i in (int(f[1:]) - 1 for f in row.sensitive))
        assert (row.sensitive in strong_rows) == kept, (seed, row)


def test_reason_with_feedthrough():
    """A bias on y1 next to a disturbance entering y1 the same way cannot be detected."""
    F, H = sp.Matrix([[-1]]), sp.Matrix([[1], [1]])
    s = structure(F, H, sp.zeros(1, 1), Dy=sp.Matrix([[2], [0]]), L=sp.zeros(1, 1),
                  Ly=sp.Matrix([[1], [0]]), name="masked")
    a = analyze(s.model, structure=s)
    r = a.fault("f1")
    assert not r.detectable and a.strongly_detectable == {"f1": False}
    assert "(D(f1); Dy(f1)) is a combination of the columns of rho1" in r.reason

"""Diagnosability analysis: detectability, minimal order, isolability.

Grouped by what they prove:
* agreement with an independent criterion on random systems: f is detectable with L
  decoupled iff normal-rank [[sI − F, −L, −D_f], [H, 0, 0]] > normal-rank
  [[sI − F, −L], [H, 0]] (evaluated with plain Fractions at random rational s), and f_a
  is isolable from f_b iff f_a is detectable with [L, D_b] decoupled;
* the minimal order against its definition (METHOD §2a): the smallest k for which a
  member of the left null space of (W⁽ᵏ⁾ L⁽ᵏ⁾), built and solved with Fractions in
  tests/oracle.py, has Φ D_f ≠ 0;
* the worked example, a symbolic case whose answer rests on a parameter being nonzero,
  a nonlinear plant, and messages naming the fault.
"""
from __future__ import annotations

import random
from fractions import Fraction

import numpy as np
import pytest
import sympy as sp

from oracle import frac_left_null_space, frac_rank, krylov_stack
from observer_cad import PlantModel
from observer_cad.errors import ModelError, UsageError
from observer_cad.model import load_model
from observer_cad.analysis import analyze, detecting_orders


# ---------------------------------------------------------------- helpers
def multi_fault_matrices(n, l, p, m, seed, density):
    rng = np.random.default_rng(seed)

    def draw(r, c):
        a = rng.integers(-2, 3, size=(r, c)) * (rng.random((r, c)) < density)
        return [[int(v) for v in row] for row in a]
    F, H, L, D = draw(n, n), draw(l, n), draw(n, p), draw(n, m)
    for i in range(l):  # no zero output row
        if not any(H[i]):
            H[i][int(rng.integers(n))] = 1
    for M in (L, D):  # every fault and disturbance enters the plant (a model requirement)
        for j in range(len(M[0]) if M else 0):
            if not any(row[j] for row in M):
                M[int(rng.integers(n))][j] = 1
    return F, H, L, D


def model_from(F, H, L, D, name="random_faults"):
    n, m, p = len(F), len(D[0]), len(L[0]) if L and L[0] else 0
    xs = sp.symbols(f"x1:{n + 1}")
    fs = sp.symbols(f"f1:{m + 1}")
    rs = sp.symbols(f"rho1:{p + 1}") if p else ()
    dyn = [sum(F[i][j] * xs[j] for j in range(n)) + sum(D[i][j] * fs[j] for j in range(m))
           + sum(L[i][j] * rs[j] for j in range(p)) for i in range(n)]
    outs = [sum(H[i][j] * xs[j] for j in range(n)) for i in range(len(H))]
    return PlantModel(name=name, time="continuous", states=list(xs), faults=list(fs),
                      disturbances=list(rs), outputs=outs, dynamics=dyn)


def normal_rank(F, H, cols, trials=3, seed=0):
    """Normal rank of [[sI − F, −cols], [H, 0]]: the largest rank at random rational s."""
    n = len(F)
    rng = random.Random(seed)
    best = 0
    for _ in range(trials):
        s = Fraction(rng.randint(-10**6, 10**6), rng.randint(1, 10**6))
        top = [[(s if i == j else 0) - F[i][j] for j in range(n)] + [-c[i] for c in cols]
               for i in range(n)]
        bottom = [list(H[i]) + [0] * len(cols) for i in range(len(H))]
        best = max(best, frac_rank(top + bottom))
    return best


def oracle_detectable(F, H, L_cols, d):
    return normal_rank(F, H, L_cols + [d]) > normal_rank(F, H, L_cols)


def columns(M):
    return [[row[j] for row in M] for j in range(len(M[0]))] if M and M[0] else []


def oracle_min_order(F, H, L, d, kmax):
    """Smallest k ≤ kmax with a member v of the left null space of (W⁽ᵏ⁾ L⁽ᵏ⁾), v·D⁽ᵏ⁾ ≠ 0."""
    n = len(F)
    Lm = L if L and L[0] else [[] for _ in range(n)]
    for k in range(1, kmax + 1):
        WL = krylov_stack(F, H, Lm, k)
        WD = krylov_stack(F, H, [[v] for v in d], k)
        Dk = [row[n:] for row in WD]  # the Toeplitz blocks of D: column i gives Φ_{i+1} D
        for v in frac_left_null_space(WL):
            if any(sum(v[r] * Dk[r][c] for r in range(len(v))) != 0 for c in range(k)):
                return k
    return None


CASES = [(n, l, p, m, seed, density)
         for seed, (n, l, p, m, density) in enumerate(
             [(3, 1, 0, 2, 1.0), (3, 2, 1, 3, 0.6), (4, 2, 1, 3, 0.5), (4, 1, 0, 2, 0.5),
              (4, 3, 1, 3, 0.6), (5, 2, 1, 3, 0.5), (5, 3, 1, 4, 0.4), (5, 2, 0, 3, 0.4),
              (6, 3, 2, 3, 0.5), (6, 2, 1, 2, 0.7), (6, 4, 2, 4, 0.35), (3, 2, 0, 3, 0.5),
              (5, 3, 2, 3, 0.8), (4, 2, 2, 2, 0.6), (6, 3, 1, 3, 0.3), (5, 4, 1, 4, 0.5)])]


# ---------------------------------------------------------------- against the oracle
@pytest.mark.slow
@pytest.mark.parametrize("n,l,p,m,seed,density", CASES)
def test_detectability_and_isolability_agree_with_the_rank_criterion(n, l, p, m, seed, density):
    F, H, L, D = multi_fault_matrices(n, l, p, m, seed, density)
    a = analyze(model_from(F, H, L, D))
    Lc, Dc = columns(L), columns(D)
    for j, f in enumerate(a.faults):
        assert a.detectable[f] == oracle_detectable(F, H, Lc, Dc[j]), f
    for pr in a.pairs:
        i, j = (a.faults.index(x) for x in pr.faults)
        assert pr.a_from_b == oracle_detectable(F, H, Lc + [Dc[j]], Dc[i]), pr.faults
        assert pr.b_from_a == oracle_detectable(F, H, Lc + [Dc[i]], Dc[j]), pr.faults


@pytest.mark.slow
@pytest.mark.parametrize("n,l,p,m,seed,density", CASES)
def test_structure_rows_agree_with_the_rank_criterion(n, l, p, m, seed, density):
    F, H, L, D = multi_fault_matrices(n, l, p, m, seed, density)
    a = analyze(model_from(F, H, L, D))
    Lc, Dc = columns(L), columns(D)
    expected = set()
    import itertools
    for size in range(m):
        for S in itertools.combinations(range(m), size):
            sens = tuple(a.faults[j] for j in range(m) if j not in S
                         and oracle_detectable(F, H, Lc + [Dc[i] for i in S], Dc[j]))
            if sens:
                expected.add(sens)
    assert {row.sensitive for row in a.structure} == expected
    assert a.structure_complete


@pytest.mark.parametrize("n,l,p,m,seed,density", CASES[:10])
def test_min_order_is_the_smallest_k_of_a_sensitive_member(n, l, p, m, seed, density):
    F, H, L, D = multi_fault_matrices(n, l, p, m, seed, density)
    Dc = columns(D)
    orders, _ = detecting_orders(sp.Matrix(F), sp.Matrix(H), sp.Matrix(n, p, sum(L, [])),
                                 sp.Matrix(D))
    for j in range(m):
        assert orders[j] == oracle_min_order(F, H, L, Dc[j], n + 1), j


def test_min_order_of_a_single_output_chain_is_n():
    # x1' = x2, x2' = x3, x3' = f, y = x1: the only parity relation is y''' = f (k = n)
    F = [[0, 1, 0], [0, 0, 1], [0, 0, 0]]
    H = [[1, 0, 0]]
    orders, _ = detecting_orders(sp.Matrix(F), sp.Matrix(H), sp.zeros(3, 0),
                                 sp.Matrix([0, 0, 1]))
    assert orders == (3,) == (oracle_min_order(F, H, [[], [], []], [0, 0, 1], 4),)


# ---------------------------------------------------------------- worked example
@pytest.fixture(scope="module")
def tank(models_dir):
    return analyze(load_model(models_dir / "three_tank_faults.py"))


def test_three_tank_faults_detectability(tank):
    assert tank.detectable == {"f1": True, "f2": True, "f3": False}
    # seed 001 §7: the rho-decoupled linear three-tank needs k = 2
    assert tank.min_order == {"f1": 2, "f2": 2, "f3": None}


def test_three_tank_faults_reason_names_fault_and_condition(tank):
    why = tank.fault("f3").reason
    assert why.startswith("f3 is undetectable with rho decoupled")
    assert "D(f3)" in why


def test_three_tank_faults_pairs_and_structure(tank):
    assert not tank.pair("f1", "f2").isolable
    assert tank.pair("f1", "f3").a_from_b and not tank.pair("f1", "f3").b_from_a
    assert [r.row(tank.faults) for r in tank.structure] == [{"f1": 1, "f2": 1, "f3": 0}]


def test_three_tank_faults_suggests_measuring_x1(tank):
    goals = {(s.goal, s.measurement, s.min_order) for s in tank.suggestions}
    assert ("isolate f1 from f2", "x1", 1) in goals
    assert ("isolate f2 from f1", "x1", 1) in goals
    assert any(u.startswith("detect f3") for u in tank.unhelped)


def test_json_keys(tank):
    js = tank.to_json()
    for key in ("detectable", "min_order", "isolable", "structure_matrices", "suggestions",
                "assumptions"):
        assert key in js, key
    assert js["isolable"][0]["faults"] == ["f1", "f2"]
    assert js["min_order"]["f3"] is None


def test_candidate_outputs_are_tried(models_dir):
    a = analyze(load_model(models_dir / "three_tank_faults.py"), candidates=["x1 + x2"])
    assert ("isolate f1 from f2", "x1 + x2") in {(s.goal, s.measurement) for s in a.suggestions}


def test_decoupling_a_fault_as_a_disturbance(models_dir):
    a = analyze(load_model(models_dir / "three_tank_faults.py"), faults=["f1"],
                disturbances=["f2"])
    assert a.detectable == {"f1": False}
    assert "f2" in a.disturbances


# ---------------------------------------------------------------- symbolic
def test_symbolic_detectability_rests_on_a_parameter_being_nonzero():
    x1, x2, f, k = sp.symbols("x1 x2 f k")
    model = PlantModel(name="coupled", time="continuous", states=[x1, x2], faults=[f],
                       outputs=[x2], dynamics=[-x1 + f, k * x1 - x2],
                       parameters={k: sp.Rational(1, 2)})
    a = analyze(model, symbolic=True)
    assert a.detectable == {"f": True} and a.min_order == {"f": 2}
    assert sp.Ne(k, 0) in a.assumptions
    assert sp.Ne(k, 0) in a.fault("f").assumptions
    # at k = 0 the fault does not reach y: the numeric answer with that value says so
    zero = PlantModel(name="coupled0", time="continuous", states=[x1, x2], faults=[f],
                      outputs=[x2], dynamics=[-x1 + f, k * x1 - x2], parameters={k: 0})
    b = analyze(zero)
    assert b.detectable == {"f": False}
    assert "does not reach the outputs" in b.fault("f").reason


def test_symbolic_electric_drive_agrees_with_numeric(models_dir):
    model = load_model(models_dir / "electric_drive.py")
    sym = analyze(model, symbolic=True)
    num = analyze(model)
    assert sym.detectable == num.detectable == {"d": True}
    assert sym.min_order == num.min_order
    assert sym.assumptions  # generic answer: conditions on k1..k6


# ---------------------------------------------------------------- nonlinear
def test_nonlinear_three_tank_with_faults():
    x1, x2, x3, u1, u2, f1, f2, r1 = sp.symbols("x1 x2 x3 u1 u2 f1 f2 rho1")
    model = PlantModel(
        name="three_tank_nl_faults", time="continuous", states=[x1, x2, x3],
        inputs=[u1, u2], faults=[f1, f2], disturbances=[r1], outputs=[x2, x3],
        dynamics=[u1 - sp.sqrt(x1 - x2) + f1,
                  u2 + sp.sqrt(x1 - x2) - sp.sqrt(x2 - x3) + f2,
                  sp.sqrt(x2 - x3) - sp.sqrt(x3) + r1],
        linear_part=[[-1, 1, 0], [1, -2, 1], [0, 1, -2]],
        domain=[x1 >= x2, x2 >= x3, x3 >= 0])
    a = analyze(model)
    # sqrt(x1 - x2) has an unmeasured argument; decoupling it (Φ C = 0) and rho1 leaves
    # no row at all, so detecting f1 rests on recovering x1 - x2 from x* and y: at k = 2,
    # Φ = [x2; x1] (seed 002 §8's plant, rho1 moved to tank 3)
    assert a.detectable == {"f1": True, "f2": True}
    assert a.fault("f1").via_substitution and a.min_order["f1"] == 2
    assert a.fault("f2").via_substitution
    assert any("argument" in n for n in a.notes)


# ---------------------------------------------------------------- bad input
def test_unknown_fault_is_named(models_dir):
    with pytest.raises(ModelError, match="unknown fault 'f9'"):
        analyze(load_model(models_dir / "three_tank_faults.py"), faults=["f9"])


def test_fault_both_analysed_and_decoupled(models_dir):
    with pytest.raises(UsageError, match="'f1' cannot be both"):
        analyze(load_model(models_dir / "three_tank_faults.py"), faults=["f1"],
                disturbances=["f1"])


def test_model_without_faults(models_dir):
    with pytest.raises(UsageError, match="no faults"):
        analyze(load_model(models_dir / "three_tank_linear.py"))


# ---------------------------------------------------------------- float path
@pytest.mark.parametrize("n,l,p,m,seed,density", CASES)
def test_float_path_agrees_with_the_exact_one(n, l, p, m, seed, density):
    model = model_from(*multi_fault_matrices(n, l, p, m, seed, density))
    ex, fl = analyze(model, method="exact"), analyze(model, method="float")
    assert fl.detectable == ex.detectable
    assert fl.min_order == ex.min_order
    assert [(q.a_from_b, q.b_from_a) for q in fl.pairs] == [(q.a_from_b, q.b_from_a) for q in ex.pairs]
    assert {r.sensitive for r in fl.structure} == {r.sensitive for r in ex.structure}
    assert any(note.startswith("float path") for note in fl.notes)


# ---------------------------------------------------------------- parity with the designer
@pytest.mark.parametrize("n,l,p,m,seed,density", CASES[:8])
def test_min_order_is_the_k_the_canonical_designer_finds(n, l, p, m, seed, density):
    from observer_cad.errors import InfeasibleDesignError
    from observer_cad.synthesis import design_canonical
    model = model_from(*multi_fault_matrices(n, l, p, m, seed, density))
    a = analyze(model)
    for f in a.faults:
        try:
            k = design_canonical(model, unknown_input=f, symbolic=False, single_row=False).k
        except InfeasibleDesignError:
            k = None
        mo = a.min_order[f]
        assert k == (mo if mo is not None and mo < n else None), f  # the designer: k < n


def test_structure_enumeration_beyond_the_limit_is_partial_and_says_so():
    model = model_from(*multi_fault_matrices(5, 4, 1, 4, 3, 0.7))
    full = analyze(model)
    part = analyze(model, max_enumerated=3)
    assert full.structure_complete and not part.structure_complete
    assert {r.sensitive for r in part.structure} <= {r.sensitive for r in full.structure}
    assert any("enumerated for at most two decoupled faults" in n for n in part.notes)

"""The float (SVD) path of the canonical-form synthesis, on seeded random systems.

* float and exact designs agree on k (and on the row D* enters) for small systems,
  dense and sparse (sparse integer systems have structural zeros and rank drops);
* the n = 60, l = 8, one-disturbance benchmark system: the generic k, a passing float
  certificate with small relative residuals, and every rank decision with its evidence;
* invariance to the scale of F (a contractive F once gave a wrong k);
* a case where ``rtol`` decides k.

No wall-clock assertions: timings live in benchmarks/bench_synthesis.py.
"""
import dataclasses
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from observer_cad import InfeasibleDesignError, design_canonical
from observer_cad.errors import CertificateError
from observer_cad import numerics as linalg
from observer_cad.model import generic_k, random_matrices, random_model, random_structure
from observer_cad.model import Structure, extract_structure

BENCH = dict(n=60, l=8, p=1, seed=0)  # the benchmark system (benchmarks/bench_synthesis.py)


def _design(model, st, **kw):
    """Design with a given structure (the model has no parameters: symbolic=True only
    lets design_canonical reuse the structure instead of extracting it again)."""
    return design_canonical(model, unknown_input="d", symbolic=True, structure=st, **kw)


def _k_and_rows(model, st, **kw):
    try:
        d = _design(model, st, **kw)
    except InfeasibleDesignError:
        return "infeasible"
    Ds = d.matrices.D_star
    return d.k, tuple(i for i in range(d.k) if Ds[i, 0] != 0)


def _with_matrices(model, mats):
    """The structure of the plant with these matrices, and that plant as its model (its
    equations written from the matrices: a design is also checked against them)."""
    im = sp.ImmutableMatrix
    n, l = mats["F"].rows, mats["H"].rows
    col = lambda v: sp.Matrix(list(v))  # noqa: E731
    dyn = (mats["F"] * col(model.states) + mats["G"] * col(model.inputs)
           + mats["D"] * col(model.faults) + mats["L"] * col(model.disturbances))
    plant = dataclasses.replace(model, dynamics=tuple(dyn),
                                outputs=tuple(mats["H"] * col(model.states)))
    return Structure(plant, im(mats["F"]), im(mats["G"]), im(mats["H"]), im(sp.zeros(n, 0)),
                     im(mats["D"]), im(mats["L"]), im(sp.zeros(l, 0)), ())


def _rerun_float(case) -> str:
    """What the same float design gives when computed again, in this process and in a
    fresh one: evidence for a failure that does not reproduce (this test failed
    intermittently, only after other tests had run in the same worker)."""
    n, l, p, seed, dens = case  # noqa: E741
    model, st = random_structure(n, l, p, seed=seed, density=dens)
    try:
        again = repr(_k_and_rows(model, st, method="float"))
    except Exception as exc:  # noqa: BLE001 - reported, the test fails anyway
        again = f"{type(exc).__name__}: {exc}"
    code = ("from observer_cad import design_canonical as d\n"
            "from observer_cad.model import random_structure as r\n"
            f"m, st = r({n}, {l}, {p}, seed={seed}, density={dens})\n"
            "x = d(m, unknown_input='d', symbolic=True, structure=st, method='float')\n"
            "print(x.k, tuple(i for i in range(x.k) if x.matrices.D_star[i, 0] != 0))")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=Path(__file__).resolve().parents[2])
    fresh = run.stdout.strip() or run.stderr.strip().splitlines()[-1:]
    return f"the same float design again in this process: {again}; in a fresh process: {fresh}"


# ---------------------------------------------------------------- generator
def test_random_model_is_seeded_and_matches_extraction():
    a = random_model(7, 3, 2, seed=5, m=2)
    b = random_model(7, 3, 2, seed=5, m=2)
    assert a.dynamics == b.dynamics and a.outputs == b.outputs
    assert random_model(7, 3, 2, seed=6, m=2).dynamics != a.dynamics
    for integer in (True, False):
        model, st = random_structure(7, 3, 2, seed=5, m=2, integer=integer, density=0.6)
        ex = extract_structure(model)
        for name in ("F", "G", "H", "C", "D", "L", "W"):
            assert getattr(st, name) == getattr(ex, name), name
    mats = random_matrices(9, 4, 1, seed=1, integer=False)
    assert all(e.is_Rational for e in mats["F"])  # exact, yet not small integers
    assert generic_k(60, 8, 1) == 9 and generic_k(6, 3, 1) == 3


# ---------------------------------------------------------------- float vs exact
AGREE = [(n, l, p, seed, dens)
         for (n, l, p) in [(6, 3, 1), (8, 3, 1), (10, 4, 1), (12, 4, 1), (12, 5, 1), (7, 3, 0),
                           (9, 4, 2)]
         for seed in range(3) for dens in (1.0, 0.4)]
AGREE += [(8, 4, 1, 2, 0.5),  # H has dependent rows: R* H = 0 members must not pass as k = 1
          (8, 4, 1, 4, 0.3)]


@pytest.mark.slow
@pytest.mark.parametrize("n,l,p,seed,dens", AGREE)
def test_float_and_exact_agree_on_k(n, l, p, seed, dens):  # noqa: E741
    model, st = random_structure(n, l, p, seed=seed, density=dens)
    exact = _k_and_rows(model, st, method="exact")
    try:
        flt = _k_and_rows(model, st, method="float")
        assert flt == exact
    except (AssertionError, CertificateError) as exc:
        raise AssertionError(f"{exc}\n{_rerun_float((n, l, p, seed, dens))}") from exc
    if dens == 1.0 and exact != "infeasible":
        assert exact[0] == generic_k(n, l, p)  # dense random systems are generic


@pytest.mark.parametrize("seed", range(3))
def test_float_and_exact_agree_without_single_row(seed):
    model, st = random_structure(8, 3, 1, seed=seed, density=0.5)
    assert _k_and_rows(model, st, method="float", single_row=False)[0] == \
        _k_and_rows(model, st, method="exact", single_row=False)[0]


def test_plain_float_call_extracts_and_agrees():
    """design_canonical(model, symbolic=False, method="float") — the call a user makes —
    extracts the structure itself and gives the same design as with a given structure."""
    model, st = random_structure(24, 4, 1, seed=2, integer=False)
    plain = design_canonical(model, unknown_input="d", symbolic=False, method="float")
    given = _design(model, st, method="float")
    assert plain.method == given.method == "float"
    assert plain.k == given.k == generic_k(24, 4, 1)
    assert plain.matrices.Phi == given.matrices.Phi
    assert plain.certificate.passed


# ---------------------------------------------------------------- the n = 60 system
@pytest.fixture(scope="module")
def bench_design():
    model, st = random_structure(**BENCH, integer=False)
    return _design(model, st, method="float")


def _rel_residuals(d):
    return [float(i.residual.split()[0]) for i in d.certificate.identities]


def test_bench_system_generic_k_and_certificate(bench_design):
    d = bench_design
    assert d.method == "float" and d.k == generic_k(60, 8, 1) == 9
    assert d.certificate.passed and not d.certificate.exact
    assert max(_rel_residuals(d)) < 1e-12
    assert all(c.holds for c in d.conditions if c.required)


def test_bench_design_identities_recomputed(bench_design):
    """Independently of the certificate: Φ F = F* Φ + J* H, H* Φ = R* H, Φ L = 0,
    Φ D = D* with D* in one row only, on the original (exact → float) matrices."""
    d = bench_design
    mats = random_matrices(60, 8, 1, seed=BENCH["seed"], integer=False)
    F, H, D, L = (np.array(mats[k].evalf(20), dtype=float) for k in "FHDL")
    X = {k: np.array(getattr(d.matrices, k).evalf(), dtype=float) for k in
         ("Phi", "F_star", "J_star", "R_star", "H_star", "D_star")}
    Phi = X["Phi"]
    assert np.linalg.matrix_rank(Phi) == d.k
    big = np.linalg.norm(Phi @ F)
    assert np.linalg.norm(Phi @ F - X["F_star"] @ Phi - X["J_star"] @ H) < 1e-12 * big
    assert np.array_equal(X["H_star"] @ Phi, X["R_star"] @ H)
    assert np.linalg.norm(Phi @ L) < 1e-12 * np.linalg.norm(Phi) * np.linalg.norm(L)
    Ds = X["D_star"][:, 0]
    assert Ds[0] != 0 and np.all(Ds[1:] == 0)  # matched case, other rows exactly 0
    assert abs((Phi @ D)[0, 0] - Ds[0]) < 1e-12 * abs(Ds[0])


EVIDENCE = re.compile(
    r"rank \d+ of \d+×\d+ \(tol [0-9.e+-]+.*σ_\d+ = [0-9.e+-]+ = ([0-9.e+-]+)·tol")


def test_rank_decisions_carry_evidence(bench_design):
    d = bench_design
    cond = {c.name: c for c in d.conditions}
    rank_cond = cond["rank condition (3.3) at k = 9"]
    m = EVIDENCE.search(rank_cond.detail)
    assert m, rank_cond.detail
    assert float(m.group(1)) > 1e3  # the smallest kept singular value is far above the cut
    assert "< l(k+1) = 80" in rank_cond.detail
    # every smaller k is refuted with its own singular values
    assert len(d.attempts) == 8
    for k, a in enumerate(d.attempts, start=1):
        assert a.startswith(f"k={k}:") and EVIDENCE.search(a), a
        assert "nothing cut" in a or "gap" in a
    assert EVIDENCE.search(cond["rank Phi = k (the model is not degenerate)"].detail)
    assert EVIDENCE.search(cond["D* enters one row only"].detail)
    assert "σ_" in cond["decoupling necessary condition rank [H; L0] < rank H + rank L0"].detail
    assert "σ_" in d.choice


@pytest.mark.slow
@pytest.mark.parametrize("factor", [sp.Rational(1, 100), sp.Rational(1, 10), 3, 10])
def test_k_does_not_depend_on_the_scale_of_F(factor):
    """(W L) for c·F is a row/column scaling of the one for F: same k. Without the
    growth scaling a contractive F gave k = 8 or 5 instead of 9."""
    model, st = random_structure(40, 6, 1, seed=3, integer=False)
    base = _design(model, st, method="float")
    mats = random_matrices(40, 6, 1, seed=3, integer=False)
    mats["F"] = mats["F"] * factor
    d = _design(model, _with_matrices(model, mats), method="float")
    assert d.k == base.k == generic_k(40, 6, 1)
    assert d.certificate.passed
    assert max(_rel_residuals(d)) < 1e-10


def test_rtol_decides_k_for_a_nearly_structured_system():
    """A sparse system (exact k = 3) with F perturbed by 1e-9: at the default tolerance
    the perturbation is real and k = 5 (as exact arithmetic on the perturbed system
    says); with rtol = 1e-6 it is treated as noise and the design of the nearby
    structured system (k = 3) is returned, certified on the perturbed matrices with the
    correspondingly looser tolerance 100·rtol."""
    n, l, p, seed, dens = 8, 3, 1, 13, 0.4
    model, st = random_structure(n, l, p, seed=seed, density=dens)
    assert _design(model, st, method="exact").k == 3
    mats = random_matrices(n, l, p, seed=seed, density=dens)
    E = np.random.default_rng(1000 + seed).integers(-1, 2, size=(n, n))
    mats["F"] = mats["F"] + sp.Rational(1, 10**9) * sp.Matrix(n, n, [int(v) for v in E.ravel()])
    pert = _with_matrices(model, mats)
    assert _design(model, pert, method="exact").k == 5
    assert _design(model, pert, method="float").k == 5
    loose = _design(model, pert, method="float", rtol=1e-6)
    assert loose.k == 3
    assert loose.certificate.passed and loose.certificate.tolerance == pytest.approx(1e-4)
    assert max(_rel_residuals(loose)) > 1e-12  # the perturbation shows in the residuals


# ---------------------------------------------------------------- FloatRank
def test_float_rank_margin_and_full_rank_evidence():
    rng = np.random.default_rng(1)
    A = rng.standard_normal((6, 3))
    fr = linalg.float_rank(A)
    assert fr.full and fr.rank == 3 and fr.shape == (6, 3)
    assert "nothing cut: full column rank" in fr.evidence()
    assert fr.margin == pytest.approx(fr.singular_values[2] / fr.tol)
    B = A @ rng.standard_normal((3, 5))  # rank 3 of 6×5
    fb = linalg.float_rank(B)
    assert fb.rank == 3 and not fb.full and fb.margin > 1e3 and "gap" in fb.evidence()
    assert "zero matrix" in linalg.float_rank(np.zeros((2, 2))).evidence()


def test_blas_thread_setting_is_restored():
    from observer_cad.numerics import SingleThreadBLAS

    funcs = SingleThreadBLAS._find()
    if not funcs:
        pytest.skip("no OpenBLAS thread control found in this process")
    before = funcs[0]()
    model, st = random_structure(8, 3, 1, seed=0)
    _design(model, st, method="float")
    assert funcs[0]() == before

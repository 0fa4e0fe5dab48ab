"""Robust (approximate) decoupling, METHOD §2d / seed 001 §6.

Checked by properties recomputed here with numpy, not by trusting the synthesis:
the exact designs are impossible for the test systems; the robust member is optimal
against 1,000 seeded random unit combinations of the same null-space basis; the
identities that must hold exactly hold; the Jordan rows are the best subset of all
candidates; the result is always flagged approximate.
"""
import itertools
import json

import numpy as np
import pytest
import sympy as sp

from observer_cad import InfeasibleDesignError, ModelError, PlantModel, UsageError, load_model
from observer_cad.synthesis import design_canonical
from observer_cad.synthesis import design_jordan
from observer_cad.reporting import format_design
from observer_cad.synthesis import design_robust_canonical, design_robust_jordan, jordan_candidates, robust_basis
from observer_cad.model import extract_structure
from observer_cad.synthesis import design_virtual_sensor_canonical


def _plant(name, F, H, L, D=None, G=None):
    F, H, L = sp.Matrix(F), sp.Matrix(H), sp.Matrix(L)
    n = F.rows
    xs = sp.symbols(f"x1:{n + 1}")
    rs = sp.symbols(f"r1:{L.cols + 1}")
    X = sp.Matrix(xs)
    dyn = F * X + L * sp.Matrix(rs)
    kw = {}
    if D is not None:
        d = sp.Symbol("d")
        dyn += sp.Matrix(D) * d
        kw["faults"] = [d]
    if G is not None:
        u = sp.Symbol("u")
        dyn += sp.Matrix(G) * u
        kw["inputs"] = [u]
    return PlantModel(name=name, time="continuous", states=list(xs), outputs=list(H * X),
                      dynamics=list(dyn), disturbances=list(rs), **kw)


def _np(M):
    M = sp.Matrix(M)
    return np.array(M.evalf(), dtype=float) if M.rows and M.cols else np.zeros(M.shape)


# Two disturbances entering both measured states directly (H L invertible): the
# necessary condition rank [H; L0] < rank H + rank L0 fails, no decoupled model exists.
NODEC = dict(F=[[-1, 1, 0], [1, -2, 1], [0, 1, -3]], H=[[1, 0, 0], [0, 1, 0]],
             L=[[1, 0], [0, 1], [0, 0]], D=[0, 0, 1], G=[1, 0, 0])
# The only exactly decoupled member (k = 1) is blind to the fault (found by a seeded
# random search): the optimum violates the task, the sensitive subspace is used.
BLIND = dict(F=[[0, 0, 1], [2, 2, -1], [2, 0, 1]], H=[[-1, 0, 0], [-1, 0, 1]],
             L=[[-1], [-1], [1]], D=[1, -1, -1])
# Jordan form: no exact decoupled virtual sensor for z = x4 (seeded random search).
NOJORDAN = dict(F=[[-2, -1, 1, 0], [1, 1, 1, -2], [2, 0, 2, -1], [-1, 2, -2, -2]],
                H=[[0, 1, -1, 1], [0, -1, 0, 1]], L=[[1, 1], [-1, -1], [1, 1], [1, -1]])
# Canonical virtual sensor for z = x4: no exact design; at k = 2 the unconstrained
# optimum does not reach z.
NOREACH = dict(F=[[2, 0, 2, -2], [-1, -2, -1, 2], [-2, -2, 0, 2], [-2, 2, 1, -1]],
               H=[[-1, 0, 1, 1], [-1, 1, 0, 1]], L=[[1, 1], [1, 1], [0, 1], [0, 1]])


@pytest.fixture(scope="module")
def nodec():
    return _plant("nodec", **NODEC)


@pytest.fixture(scope="module")
def nodec_design(nodec):
    return design_robust_canonical(nodec, unknown_input="d")


@pytest.fixture(scope="module")
def nojordan():
    return _plant("nojordan", **NOJORDAN)


@pytest.fixture(scope="module")
def jordan_design(nojordan):
    return design_robust_jordan(nojordan, estimate="x4")


def _krylov_np(F, H, X, k):
    """W⁽ᵏ⁾ = [H Fᵏ; …; H] and the block Toeplitz X⁽ᵏ⁾, recomputed here (METHOD §2a)."""
    l, q = H.shape[0], X.shape[1]
    HF = [H]
    for _ in range(k):
        HF.append(HF[-1] @ F)
    W = np.vstack([HF[k - b] for b in range(k + 1)])
    T = np.zeros((l * (k + 1), k * q))
    for b in range(k):
        for j in range(b, k):
            T[b * l:(b + 1) * l, j * q:(j + 1) * q] = HF[j - b] @ X
    return W, T


# ------------------------------------------------------------ (a) exact impossible
def test_exact_canonical_impossible_robust_is_approximate(nodec, nodec_design):
    with pytest.raises(InfeasibleDesignError):
        design_canonical(nodec, unknown_input="d")
    d = nodec_design
    assert d.approximate is True
    assert d.residual_norm > 1e-3
    assert d.form == "canonical" and d.method == "float"
    assert "APPROXIMATE" in d.choice
    assert "APPROXIMATE" in format_design(d).splitlines()[0]
    first = d.conditions[0]
    assert first.name == "approximate: exact decoupling impossible for every k < n"
    assert first.holds and "k=1" in first.detail and "k=2" in first.detail


def test_residual_is_the_reported_phi_L(nodec, nodec_design):
    d = nodec_design
    st = extract_structure(nodec)
    Phi, L = _np(d.matrices.Phi), _np(st.L)
    assert np.linalg.norm(Phi @ L) == pytest.approx(d.residual_norm, rel=1e-12)
    assert np.linalg.norm(_np(d.matrices.L_star)) == pytest.approx(d.residual_norm, rel=1e-12)
    assert np.linalg.norm(Phi @ L) > 1e-3  # not decoupled, and not presented as such


# ------------------------------------------------------------ (b) optimality
def test_random_unit_combinations_never_beat_it(nodec, nodec_design):
    k, N, Lk = robust_basis(nodec, unknown_input="d")
    d = nodec_design
    assert k == d.k
    st = extract_structure(nodec)
    F, H, L = _np(st.F), _np(st.H), _np(st.L)
    W, Lk_own = _krylov_np(F, H, L, k)
    np.testing.assert_allclose(Lk, Lk_own, atol=1e-14)
    np.testing.assert_allclose(N @ N.T, np.eye(N.shape[0]), atol=1e-12)  # orthonormal
    assert np.linalg.norm(N @ W) < 1e-12  # every member solves (R*, −J*) W = 0
    # the design's member v = (R*, −J*_1, …) is a unit combination of N
    v = np.concatenate([_np(d.matrices.R_star).ravel(), -_np(d.matrices.J_star).ravel()])
    assert np.linalg.norm(v) == pytest.approx(1.0, abs=1e-12)
    w = v @ N.T
    np.testing.assert_allclose(w @ N, v, atol=1e-12)  # v lies in the span of N
    assert np.linalg.norm(v @ Lk) == pytest.approx(d.residual_norm, rel=1e-10)
    rng = np.random.default_rng(20240601)
    Ws = rng.standard_normal((1000, N.shape[0]))
    Ws /= np.linalg.norm(Ws, axis=1, keepdims=True)
    norms = np.linalg.norm(Ws @ N @ Lk, axis=1)
    assert norms.min() >= d.residual_norm - 1e-12


# ------------------------------------------------------------ (c) exact identities
def test_identities_that_must_hold_exactly(nodec, nodec_design):
    d = nodec_design
    st = extract_structure(nodec)
    F, G, H, D = (_np(X) for X in (st.F, st.G, st.H, st.D))
    m = {n: _np(M) for n, M in d.matrices.items()}
    Phi = m["Phi"]
    assert np.linalg.norm(Phi @ F - m["F_star"] @ Phi - m["J_star"] @ H) < 1e-10
    assert np.linalg.norm(m["H_star"] @ Phi - m["R_star"] @ H) < 1e-10
    assert np.linalg.norm(Phi @ G - m["G_star"]) < 1e-10
    assert np.linalg.norm(Phi @ D - m["D_star"]) < 1e-10
    np.testing.assert_array_equal(m["F_star"], np.eye(d.k, d.k, 1))  # the shift
    assert np.linalg.norm(Phi @ D) > 1e-3  # the fault reaches the model
    assert np.linalg.matrix_rank(Phi) == d.k
    assert d.certificate.passed
    names = [i.name for i in d.certificate.identities]
    assert "Phi L" not in names  # the decoupling is the residual, never certified as zero


# ------------------------------------------------------------ (d) Jordan counterpart
def test_jordan_exact_impossible(nojordan, jordan_design):
    with pytest.raises(InfeasibleDesignError):
        design_jordan(nojordan, observer="virtual-sensor", estimate="x4")
    d = jordan_design
    assert d.approximate is True and d.form == "jordan"
    assert d.residual_norm > 1e-3
    assert "APPROXIMATE" in d.choice
    assert d.conditions[0].holds  # no exact decoupled Jordan design


def _reaches(Phi, H, M):
    A = np.vstack([Phi, H])
    return np.linalg.matrix_rank(A, tol=1e-9) == np.linalg.matrix_rank(np.vstack([A, M]), tol=1e-9)


def test_jordan_picks_rows_of_least_phi_L(nojordan, jordan_design):
    d = jordan_design
    st = extract_structure(nojordan)
    F, H, L = _np(st.F), _np(st.H), _np(st.L)
    M = np.array([[0.0, 0.0, 0.0, 1.0]])
    n = F.shape[0]
    cands, Lused = jordan_candidates(nojordan, estimate="x4")
    np.testing.assert_array_equal(Lused, L)
    # every candidate: a unit row admissible for its λ (Φ_i (F − λI) ∈ rowspace H) with
    # the stated ‖Φ_i L‖
    PH = np.eye(n) - np.linalg.pinv(H) @ H
    for lam, phi, res in cands:
        assert np.linalg.norm(phi) == pytest.approx(1.0, abs=1e-12)
        assert np.linalg.norm(phi @ (F - float(lam) * np.eye(n)) @ PH) < 1e-10
        assert np.linalg.norm(phi @ L) == pytest.approx(res, abs=1e-12)
    # per λ, the first candidate is the least ‖Φ_i L‖ over all unit admissible rows
    rng = np.random.default_rng(7)
    for lam in sorted({c[0] for c in cands}, key=float):
        _, s, Vt = np.linalg.svd((F - float(lam) * np.eye(n)) @ PH)
        B = Vt[np.sum(s > 1e-10 * s[0]):]  # orthonormal basis of the admissible rows
        best = min(r for lm, _, r in cands if lm == lam)
        X = rng.standard_normal((1000, B.shape[0]))
        X /= np.linalg.norm(X, axis=1, keepdims=True)
        assert np.linalg.norm(X @ B @ L, axis=1).min() >= best - 1e-12
    # brute force over all subsets of the candidates: fewest rows, then least ‖Φ L‖_F
    k = d.k
    for m in range(1, k):
        for combo in itertools.combinations(range(len(cands)), m):
            Phi = np.vstack([cands[i][1] for i in combo])
            assert not (np.linalg.matrix_rank(Phi, tol=1e-9) == m and _reaches(Phi, H, M))
    best = min(
        np.sqrt(sum(cands[i][2] ** 2 for i in combo))
        for combo in itertools.combinations(range(len(cands)), k)
        if np.linalg.matrix_rank(np.vstack([cands[i][1] for i in combo]), tol=1e-9) == k
        and _reaches(np.vstack([cands[i][1] for i in combo]), H, M))
    assert d.residual_norm == pytest.approx(best, rel=1e-12)
    Phi = _np(d.matrices.Phi)
    assert np.linalg.norm(Phi @ L) == pytest.approx(d.residual_norm, rel=1e-12)
    for row in Phi:  # the chosen rows are candidates
        assert min(np.linalg.norm(row - c[1]) for c in cands) < 1e-12


def test_jordan_identities(nojordan, jordan_design):
    d = jordan_design
    st = extract_structure(nojordan)
    F, H = _np(st.F), _np(st.H)
    m = {n: _np(M) for n, M in d.matrices.items()}
    Phi = m["Phi"]
    assert np.allclose(m["F_star"], np.diag([float(v) for v in d.lambdas]))
    assert all(float(v) < 0 for v in d.lambdas)
    assert np.linalg.norm(Phi @ F - m["F_star"] @ Phi - m["J_star"] @ H) < 1e-10
    M = np.array([[0.0, 0.0, 0.0, 1.0]])
    assert np.linalg.norm(M - m["Hz"] @ Phi - m["Q"] @ H) < 1e-10
    np.testing.assert_allclose(np.linalg.norm(Phi, axis=1), 1.0, atol=1e-12)


# ------------------------------------------------------------ (e) JSON
def test_json_flags_approximate(nodec_design, jordan_design):
    for d in (nodec_design, jordan_design):
        js = json.loads(json.dumps(d.to_json()))
        assert js["approximate"] is True
        assert js["residual_norm"] == pytest.approx(d.residual_norm)
        assert js["residual_norm"] > 0
        assert "APPROXIMATE" in js["choice"]


# ------------------------------------------------------------ the task
def test_optimum_blind_to_the_fault_uses_the_sensitive_subspace():
    model = _plant("blind", **BLIND)
    with pytest.raises(InfeasibleDesignError):
        design_canonical(model, unknown_input="d", single_row=False)
    d = design_robust_canonical(model, unknown_input="d")
    k, N, Lk = robust_basis(model, unknown_input="d")
    sigma_min = np.linalg.svd(N @ Lk, compute_uv=False)
    sigma_min = 0.0 if N.shape[0] > Lk.shape[1] else sigma_min.min()
    assert sigma_min < 1e-12  # an exactly decoupled member exists ...
    detail = next(c.detail for c in d.conditions if c.name.startswith("achieved residual"))
    assert "fails the task" in detail and "range of N D" in detail  # ... but it is blind
    st = extract_structure(model)
    Phi = _np(d.matrices.Phi)
    assert np.linalg.norm(Phi @ _np(st.D)) > 1e-3
    assert d.residual_norm > 1e-3
    # the best member of the sensitive subspace: range of N D⁽ᵏ⁾, recomputed here
    _, Dk = _krylov_np(_np(st.F), _np(st.H), _np(st.D), k)
    U, s, _ = np.linalg.svd(N @ Dk, full_matrices=False)
    Z = U[:, s > 1e-9 * s[0]].T
    best = np.linalg.svd(Z @ N @ Lk, compute_uv=False).min() if Z.shape[0] <= Lk.shape[1] else 0.0
    assert d.residual_norm == pytest.approx(best, rel=1e-10)


def test_estimate_unreachable_optimum_falls_back_to_the_reaching_subspace():
    model = _plant("noreach", **NOREACH)
    with pytest.raises(InfeasibleDesignError):
        design_virtual_sensor_canonical(model, estimate="x4")
    d = design_robust_canonical(model, estimate="x4")
    assert d.approximate and d.k == 2 and d.conditions[0].holds
    detail = next(c.detail for c in d.conditions if c.name.startswith("achieved residual"))
    assert "fails the task" in detail
    st = extract_structure(model)
    F, H, L = _np(st.F), _np(st.H), _np(st.L)
    M = np.array([[0.0, 0.0, 0.0, 1.0]])
    m = {n: _np(X) for n, X in d.matrices.items()}
    Phi = m["Phi"]
    assert _reaches(Phi, H, M)
    assert np.linalg.norm(M - m["Hz"] @ Phi - m["Q"] @ H) < 1e-9
    # independent optimum over the reaching members at k = 2: Φ_2 = R* H F − J*_1 H, so
    # z is reachable iff Φ_2 P_H ∥ M P_H, a linear condition on w (v = w N)
    k, N, Lk = robust_basis(model, estimate="x4")
    l = H.shape[0]
    PH = np.eye(4) - np.linalg.pinv(H) @ H
    mh = (M @ PH)[0] / np.linalg.norm(M @ PH)
    Phi2 = N[:, :l] @ H @ F - (-N[:, l:2 * l]) @ H  # Φ_2 of each basis member
    E = Phi2 @ PH @ (np.eye(4) - np.outer(mh, mh))
    U, s, _ = np.linalg.svd(E, full_matrices=True)
    V = U[:, int(np.sum(s > 1e-9 * s[0])):].T
    best = np.linalg.svd(V @ N @ Lk, compute_uv=False)
    best = 0.0 if V.shape[0] > Lk.shape[1] else best.min()
    assert d.residual_norm == pytest.approx(best, rel=1e-8)
    assert d.residual_norm > np.linalg.svd(N @ Lk, compute_uv=False).min()


def test_exact_design_exists_is_said(models_dir):
    model = load_model(models_dir / "electric_drive.py")
    d = design_robust_canonical(model, unknown_input=model.faults[0].name)
    assert d.approximate and d.residual_norm < 1e-10
    first = d.conditions[0]
    assert not first.holds and not first.required and "exact" in first.detail
    assert "exact design exists" in d.choice


def test_no_k_even_without_decoupling():
    # one output, n = 3, observable: W⁽ᵏ⁾ has full row rank for k = 1, 2
    model = _plant("oneout", F=[[-1, 1, 0], [1, -2, 1], [0, 1, 1]], H=[[1, 0, 0]],
                   L=[[0], [1], [0]])
    with pytest.raises(InfeasibleDesignError, match="even without decoupling"):
        design_robust_canonical(model, estimate="x3")


def test_usage_errors(nodec, models_dir):
    with pytest.raises(UsageError):
        design_robust_canonical(nodec, unknown_input="d", estimate="x1")
    drive = load_model(models_dir / "electric_drive.py")
    with pytest.raises(UsageError):
        design_robust_canonical(drive, unknown_input="d", symbolic=True)
    # a declared disturbance entering no equation is refused when the model is built
    with pytest.raises(ModelError, match="'r1' is declared but appears in no dynamics"):
        _plant("unused", F=[[-1, 1], [0, -2]], H=[[1, 0]], L=[[0], [0]], D=[0, 1])
    x1, x2, d = sp.symbols("x1 x2 d")
    nothing = PlantModel(name="nothing", time="continuous", states=[x1, x2], outputs=[x1],
                         dynamics=[-x1 + x2, -2 * x2 + d], faults=[d])
    with pytest.raises(UsageError, match="nothing to decouple"):
        design_robust_canonical(nothing, unknown_input="d")


def test_synthesis_falls_back_to_robust(nodec):
    from observer_cad.synthesis import design
    with pytest.raises(InfeasibleDesignError):
        design(nodec, observer="unknown-input", faults=["d"])
    d = design(nodec, observer="unknown-input", faults=["d"], robust=True)
    assert d.approximate and d.residual_norm > 0


# ------------------------------------------------------------ (e) JSON: read back, not trusted
def test_approximate_design_is_recertified_on_reading(nodec, nodec_design, nojordan,
                                                      jordan_design):
    """An approximate design read back is certified again in floating point (every identity
    but Φ L, its residual) and its ‖Φ L‖_F recomputed from the matrices; the file's own
    tolerance is bounded relative to the identities' terms, never taken as it is."""
    from observer_cad import Design
    from observer_cad.errors import CertificateError

    for model, d in ((nodec, nodec_design), (nojordan, jordan_design)):
        js = json.loads(json.dumps(d.to_json()))
        back = Design.from_json(js, model)
        assert back.approximate and back.certificate.passed and not back.certificate.exact
        assert back.residual_norm == pytest.approx(d.residual_norm, rel=1e-12)
        assert [i.name for i in back.certificate.identities] == \
            [i.name for i in d.certificate.identities]

        bad = json.loads(json.dumps(js))  # a changed J* fails the float certificate
        bad["matrices"]["J_star"][0][0] = "100"
        with pytest.raises(CertificateError):
            Design.from_json(bad, model)
        for tol in (1e300, float("inf"), float("nan"), -1.0, 0, "1e-9", True, None):
            bad = json.loads(json.dumps(js))
            bad["certificate"]["tolerance"] = tol
            with pytest.raises(UsageError, match="tolerance"):
                Design.from_json(bad, model)
        bad = json.loads(json.dumps(js))
        bad["residual_norm"] = d.residual_norm / 2
        with pytest.raises(UsageError, match="residual_norm"):
            Design.from_json(bad, model)
        bad = json.loads(json.dumps(js))
        bad["approximate"] = "yes"
        with pytest.raises(UsageError, match="approximate"):
            Design.from_json(bad, model)


def test_exact_design_cannot_claim_a_float_certificate(models_dir):
    """An exact design whose file says "exact": false with a huge tolerance is refused;
    with a tolerance within the bound it is certified in floating point, which a changed
    J* still fails."""
    from observer_cad import Design, design
    from observer_cad.errors import CertificateError

    model = load_model(models_dir / "three_tank.py")
    d = design(model, observer="virtual-sensor", estimate="x1")
    js = json.loads(json.dumps(d.to_json()))
    js["certificate"] = {"exact": False, "tolerance": 1e300}
    with pytest.raises(UsageError, match="exceeds"):
        Design.from_json(js, model)
    js["certificate"]["tolerance"] = 1e-9
    assert Design.from_json(js, model).certificate.passed
    js["matrices"]["J_star"][0][0] = "100"
    with pytest.raises(CertificateError):
        Design.from_json(js, model)

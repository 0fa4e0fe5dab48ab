"""Jordan minimality (METHOD §2b): when every λ is admissible, the fewest
rows may need a particular λ — a rational one outside the default lists, or an irrational
one (a fixed mode of the reduced model). Constructed plants whose minimal design needs
such a λ; each design is checked for its k, its λ, its certificate and the reason why
fewer rows are impossible."""
import json

import pytest
import sympy as sp

from observer_cad import Design, InfeasibleDesignError, PlantModel, UsageError, design
from observer_cad.errors import CertificateError
from observer_cad.synthesis import design_jordan, design_jordan_float
from observer_cad.synthesis.certificates._certificate import _algebraic_is_zero
from observer_cad.synthesis.jordan._lambda_search import exact_real_roots, one_row_lambdas

LAM = sp.Symbol("lambda")
x1, x2, x3, x4, u = sp.symbols("x1 x2 x3 x4 u")
X = sp.Matrix([x1, x2, x3])
# a rational similarity, so that the special direction is not a coordinate
T = sp.Matrix([[1, 1, 0], [0, 1, 1], [1, 0, 1]])


def _rational_plant(mu, time="continuous"):
    """F has the eigenvalue mu with left eigenvector M (z = M x); y = H x sees the rest.
    The only one-row virtual sensor for z is Φ ∝ M with λ = mu."""
    F0 = sp.Matrix([[mu, 0, 0], [1, sp.Rational(1, 5), 1], [0, 1, sp.Rational(2, 5)]])
    F = T * F0 * T.inv()
    H = sp.Matrix([[0, 1, 0]]) * T.inv()
    M = sp.Matrix([[1, 0, 0]]) * T.inv()
    m = PlantModel(name=f"rational_{time}", time=time, states=[x1, x2, x3], inputs=[u],
                   outputs=list(H * X), dynamics=list(F * X + sp.Matrix([1, 0, 1]) * u))
    return m, F, H, M, (M * X)[0]


def _minimal(d):
    return next(c for c in d.conditions if c.name == "k is minimal over λ")


def _check_rows(d, F, H):
    """Independent of the certificate: every row satisfies Φ_i F = λ_i Φ_i + J*_i H."""
    Phi, J = sp.Matrix(d.matrices.Phi), sp.Matrix(d.matrices.J_star)
    for i, lam in enumerate(d.lambdas):
        res = (Phi[i, :] * F - lam * Phi[i, :] - J[i, :] * H).applyfunc(sp.simplify)
        assert res == sp.zeros(1, F.cols)


@pytest.mark.parametrize("time,mu", [("continuous", sp.Rational(-3, 2)),
                                     ("discrete", sp.Rational(1, 3))])
def test_rational_lambda_outside_the_defaults(time, mu):
    m, F, H, M, z = _rational_plant(mu, time)
    d = design_jordan(m, observer="virtual-sensor", estimate=z, proof_seconds=None)
    assert d.k == 1 and d.lambdas == (mu,)
    assert d.certificate.passed
    _check_rows(d, F, H)
    cond = _minimal(d)
    assert cond.holds and str(mu) in cond.detail and "not in the default list" in cond.detail
    assert str(mu) in d.choice
    # the default λ alone need more rows: the special λ is what makes k = 1
    defaults = ["-1", "-2", "-3"] if time == "continuous" else ["1/2", "1/4", "1/8"]
    d2 = design_jordan(m, observer="virtual-sensor", estimate=z, lambdas=defaults)
    assert d2.k == 2
    assert not _minimal(d2).holds  # requested λ: minimality over λ not claimed


def test_one_row_polynomial_is_exact():
    m, F, H, M, z = _rational_plant(sp.Rational(-3, 2))
    one = one_row_lambdas(F, H, sp.zeros(3, 0), M, LAM, "continuous")
    assert one.analysed and not one.generic
    assert one.roots == (sp.Rational(-3, 2),) and one.stable == (sp.Rational(-3, 2),)
    assert sp.Poly(one.polynomial, LAM).degree() >= 1
    assert one.polynomial.subs(LAM, sp.Rational(-3, 2)) == 0
    # z = x1 of a plant where every λ gives one row: generic, no special λ
    gen = one_row_lambdas(sp.Matrix([[-1, 0], [1, -2]]), sp.Matrix([[0, 1]]), sp.zeros(2, 0),
                          sp.Matrix([[1, 0]]), LAM, "continuous")
    assert gen.generic and gen.roots == ()


def test_why_fewer_rows_impossible_unstable_root():
    """The only one-row λ is unstable: k = 2, and the report says k = 1 needs that root."""
    m, F, H, M, z = _rational_plant(sp.Rational(3, 2))
    d = design_jordan(m, observer="virtual-sensor", estimate=z, proof_seconds=None)
    assert d.k == 2 and d.certificate.passed
    cond = _minimal(d)
    assert cond.holds  # k = 1 impossible for every real λ, so k = 2 is minimal
    assert "k = 1 is impossible for every real λ" in cond.detail
    assert "none is stable" in cond.detail and "3/2" in cond.detail


def test_float_path_finds_the_one_row_lambda():
    m, F, H, M, z = _rational_plant(sp.Rational(-3, 2))
    d = design_jordan_float(m, observer="virtual-sensor", estimate=z)
    assert d.k == 1 and abs(float(d.lambdas[0]) + 1.5) < 1e-9
    assert d.certificate.passed


def _unobservable_block_plant():
    """x1, x2 never reach y = x3; their modes −2 ± √2 are fixed modes of any reduced model
    containing z = x1: k = 2 with exactly those (irrational) λ."""
    return PlantModel(name="irrational", time="continuous", states=[x1, x2, x3], inputs=[u],
                      outputs=[x3], dynamics=[-2 * x1 + x2, 2 * x1 - 2 * x2 + u, -x3 + u])


def test_irrational_lambda_quadratic():
    m = _unobservable_block_plant()
    d = design_jordan(m, observer="virtual-sensor", estimate="x1", proof_seconds=None)
    assert d.k == 2
    assert set(d.lambdas) == {-2 - sp.sqrt(2), -2 + sp.sqrt(2)}
    assert d.certificate.passed
    F = sp.Matrix([[-2, 1, 0], [2, -2, 0], [0, 0, -1]])
    _check_rows(d, F, sp.Matrix([[0, 0, 1]]))
    cond = _minimal(d)
    assert cond.holds and "k = 1 is impossible for every" in cond.detail
    assert "sqrt(2)" in cond.detail
    with pytest.raises(InfeasibleDesignError):  # the default λ cannot give z at all
        design_jordan(m, observer="virtual-sensor", estimate="x1", lambdas=["-1", "-2", "-3"])


def _same_after_json(d, m):
    """The design written as JSON text and read back: equal matrices and λ, re-certified."""
    back = Design.from_json(json.loads(json.dumps(d.to_json())), m)
    assert back.lambdas == d.lambdas
    assert [type(v) for v in back.lambdas] == [type(v) for v in d.lambdas]
    for name, M in d.ordered_matrices:
        assert sp.Matrix(getattr(back.matrices, name)) == sp.Matrix(M), name
    assert back.certificate.passed and back.certificate.exact
    assert back.request == d.request
    return back


@pytest.mark.slow  # three CRootOf λ in one design: arithmetic in a degree-6 field (~15 s; JSON ~3 s)
def test_irrational_lambda_cubic_crootof():
    # unmeasured companion block, char. poly λ³ + 6λ² + 8λ + 1: irreducible, three
    # stable real roots, Galois group S3
    m = PlantModel(name="cubic", time="continuous", states=[x1, x2, x3, x4], inputs=[u],
                   outputs=[x4], dynamics=[x2, x3, -x1 - 8 * x2 - 6 * x3 + u, -x4 + u])
    d = design_jordan(m, observer="virtual-sensor", estimate="x1", proof_seconds=None)
    assert d.k == 3
    assert all(isinstance(v, sp.CRootOf) for v in d.lambdas)
    assert sorted(v.index for v in d.lambdas) == [0, 1, 2]
    assert d.certificate.passed
    _same_after_json(d, m)  # the λ the synthesis found come back from the design's JSON


#: one CRootOf λ in a cheap design: a root of the irreducible cubic λ³ + 6λ² + 8λ + 1
#: (all three roots real and stable), written as sympy prints it
CUBIC_ROOT_TEXT = "CRootOf(x**3 + 6*x**2 + 8*x + 1, 0)"


def _clash_plant():
    """Three states, the first called x — the name sympy writes a CRootOf's polynomial
    in; two outputs, so every λ admits rows (a requested CRootOf λ gives k = 1)."""
    x = sp.Symbol("x")
    return PlantModel(name="clash", time="continuous", states=[x, x2, x3], inputs=[u],
                      outputs=[x2, x3], dynamics=[-x + x2 + u, x - 2 * x2 + x3 + u, x2 - 2 * x3])


@pytest.fixture(scope="module")
def crootof_design():
    m = _clash_plant()
    return m, design(m, observer="virtual-sensor", estimate="x", form="jordan",
                     lambdas=[CUBIC_ROOT_TEXT])


def test_crootof_lambda_design_round_trips_through_json(crootof_design):
    m, d = crootof_design
    (lam,) = d.lambdas
    assert isinstance(lam, sp.CRootOf) and d.k == 1 and d.certificate.passed
    assert d.request.lambdas == (lam,)
    # independent of the certificate: Φ F = λ Φ + J* H, exactly in QQ(λ)
    F = sp.Matrix([[-1, 1, 0], [1, -2, 1], [0, 1, -2]])
    H = sp.Matrix([[0, 1, 0], [0, 0, 1]])
    Phi, J = sp.Matrix(d.matrices.Phi), sp.Matrix(d.matrices.J_star)
    for e in Phi * F - lam * Phi - J * H:
        assert _algebraic_is_zero(sp.expand(e)) is True
    text = json.dumps(d.to_json())
    assert CUBIC_ROOT_TEXT in text
    back = _same_after_json(d, m)
    assert back.matrices.F_star[0, 0] == lam
    from observer_cad.reporting import matrices_from_json  # the matrices alone, no model
    mats = matrices_from_json(json.loads(text))
    assert mats["F_star"] == sp.Matrix([[lam]]) and mats["Phi"] == sp.Matrix(d.matrices.Phi)


def test_crootof_lambda_design_is_recertified_on_load(crootof_design):
    """Reading re-certifies: the other root of the same cubic in F* (a one-character
    edit) no longer satisfies Φ F = F* Φ + J* H and is refused."""
    m, d = crootof_design
    data = json.loads(json.dumps(d.to_json()))
    data["matrices"]["F_star"][0][0] = CUBIC_ROOT_TEXT.replace(", 0)", ", 1)")
    with pytest.raises(CertificateError):
        Design.from_json(data, m)
    data["matrices"]["F_star"][0][0] = CUBIC_ROOT_TEXT.replace(", 0)", ", 3)")
    with pytest.raises(UsageError, match="out of range for degree 3"):
        Design.from_json(data, m)


def test_exact_real_roots():
    lam = LAM
    rts = exact_real_roots([2 * lam + 3, lam**2 - 2, lam**3 + 6 * lam**2 + 8 * lam + 1], lam)
    assert len(rts) == 6
    assert sp.Rational(-3, 2) in rts and sp.sqrt(2) in rts and -sp.sqrt(2) in rts
    assert sum(isinstance(r, sp.CRootOf) for r in rts) == 3
    assert [float(r) for r in rts] == sorted(float(r) for r in rts)


@pytest.mark.parametrize("cubic", [LAM**3 + 6 * LAM**2 + 8 * LAM + 1,   # Galois group S3
                                   LAM**3 + 6 * LAM**2 + 9 * LAM + 1])  # cyclic (square disc.)
def test_algebraic_zero_test(cubic):
    a, b, c = (sp.CRootOf(cubic, i) for i in range(3))
    e2 = sp.Poly(cubic, LAM).all_coeffs()[2]
    assert _algebraic_is_zero(a + b + c + 6) is True
    assert _algebraic_is_zero(a * b + b * c + c * a - e2) is True
    assert _algebraic_is_zero(a**3 + 6 * a**2 + e2 * a + 1) is True
    assert _algebraic_is_zero(a + b + 1) is False
    assert _algebraic_is_zero(a * b - 1 + sp.Rational(1, 10**40)) is not True


def test_directed_rows_for_a_vector_z_give_one_row_per_component(models_dir):
    """z = (x1, x2) of a nonlinear chain: the directed solve needs two rows of the same λ
    (it used to stack a 2-row block as one 'row' and end in a raw ShapeError)."""
    from observer_cad import load_model
    from observer_cad.synthesis import design_jordan
    m = load_model(models_dir / "nonmonotone_chain.py")
    d = design_jordan(m, observer="interval", estimate=["x1", "x2"], proof_seconds=None)
    Phi, F = sp.Matrix(d.matrices.Phi), sp.Matrix(d.matrices.F_star)
    assert Phi.rows == F.rows == d.k and Phi.rank() == d.k
    assert d.certificate.passed

"""Model building and structure extraction at scale: the fast paths
give exactly what sympy's own constructors give, and a seed still draws the same plant.

Timing goals are shown by ``benchmarks/bench_scale.py``, not asserted here."""
import pytest
import sympy as sp

from observer_cad import PlantModel, extract_structure
from observer_cad.errors import ModelError
from observer_cad.model import random_matrices, random_model


def _same_matrix(M, flat, shape):
    """M equals sympy's own ImmutableMatrix of the entries: value, args, hash, domain."""
    ref = sp.ImmutableMatrix(*shape, flat)
    assert M.shape == ref.shape
    assert M == ref
    assert M.args == ref.args
    assert hash(M) == hash(ref)
    assert M._rep.domain == ref._rep.domain  # ZZ / QQ / EXRAW as sympy chooses
    assert M * M.T == ref * ref.T  # arithmetic on the stored representation


@pytest.mark.parametrize("integer,density,p,m", [(False, 1.0, 1, 1), (True, 1.0, 2, 2),
                                                 (False, 0.4, 2, 0), (True, 0.5, 0, 1)])
def test_extracted_matrices_are_sympy_matrices(integer, density, p, m):
    n, l = 9, 3  # noqa: E741
    model = random_model(n, l, p, seed=3, m=m, integer=integer, density=density)
    mats = random_matrices(n, l, p, seed=3, m=m, integer=integer, density=density)
    st = extract_structure(model)
    for name in "FGHDL":
        drawn = mats[name]
        _same_matrix(getattr(st, name), list(drawn), drawn.shape)
        assert drawn == sp.Matrix(*drawn.shape, list(drawn))
    assert st.W.shape == (l, 0) and st.C.shape == (n, 0)


def test_integer_and_zero_matrices_keep_sympys_domain():
    model = random_model(5, 2, 1, seed=0, integer=True)
    st = extract_structure(model)
    assert st.F._rep.domain == sp.ImmutableMatrix(st.F.tolist())._rep.domain
    assert str(st.F._rep.domain) == "ZZ"
    sparse = random_matrices(6, 2, 1, seed=0, integer=True, density=0.05)
    assert sum(1 for e in sparse["F"] if e == 0) >= 30  # mostly structural zeros
    ref = sp.Matrix(6, 6, list(sparse["F"]))
    assert sparse["F"] == ref and sparse["F"]._rep.domain == ref._rep.domain


def test_a_seed_draws_the_same_plant_as_before():
    # fingerprints of the matrices the first implementation drew for these seeds
    mats = random_matrices(40, 8, 1, seed=0, integer=False)
    F, H = mats["F"], mats["H"]
    assert sum(F) == sp.Rational(-2219, 1000)
    assert sum(e ** 2 for e in F) == sp.Rational(38948117, 1000000)
    assert sum(H) == sp.Rational(-4333, 125)
    assert list(mats["D"][:3]) == [sp.Rational(-1, 50), sp.Rational(-159, 500),
                                   sp.Rational(-1407, 1000)]
    assert list(mats["L"][:3]) == [sp.Rational(-451, 1000), sp.Rational(-289, 250),
                                   sp.Rational(773, 1000)]
    sparse = random_matrices(20, 4, 2, seed=5, integer=False, density=0.5)
    assert sum(sparse["F"]) == sp.Rational(-581, 500)
    assert sum(1 for e in sparse["F"] if e == 0) == 184
    assert sum(sparse["H"]) == sp.Rational(411, 125)


def test_long_equation_checks_still_name_the_symbol():
    xs = sp.symbols("x1:61")
    q, w, d = sp.symbols("q w d")
    lin = sum(sp.Rational(i + 1, 7) * x for i, x in enumerate(xs))
    ok = dict(name="long", time="discrete", states=xs, outputs=[xs[0]],
              dynamics=[lin] * len(xs))
    PlantModel(**ok)  # a valid 60-term model
    # an undeclared symbol deep in a product term of a long sum
    bad = [lin + 3 * q * xs[1] * xs[2]] + [lin] * (len(xs) - 1)
    with pytest.raises(ModelError, match="undeclared symbol 'q' in dynamics equation 1"):
        PlantModel(**{**ok, "dynamics": bad})
    # process noise in the dynamics, found through a number·symbol term; a noise symbol
    # that multiplies a state is refused at extraction, naming it
    PlantModel(**{**ok, "noise": [w], "outputs": [xs[0] + w],
                  "dynamics": [lin, lin + sp.Rational(2, 3) * w] + [lin] * 58})
    with pytest.raises(ModelError, match="noise 'w' enters with the coefficient x2"):
        extract_structure(PlantModel(**{**ok, "noise": [w], "outputs": [xs[0] + w],
                                        "dynamics": [lin, lin + w * xs[1]] + [lin] * 58}))
    # a declared fault that appears nowhere
    with pytest.raises(ModelError, match="fault 'd' is declared but appears in no"):
        PlantModel(**{**ok, "faults": [d]})

"""The one preparation step (``synthesis.core.prepare``): the rule "auto" follows, the
refusal of the float path with parameters kept as symbols, a given structure used as is,
and the structure extracted once, when first used."""
from __future__ import annotations

import pytest
import sympy as sp

from observer_cad.errors import UsageError
from observer_cad.model import PlantModel, extract_structure, random_model
from observer_cad.synthesis.core import FLOAT_AUTO_N, Prepared, prepare


def _chain(n: int) -> PlantModel:
    """x_i' = −a x_i + x_{i+1}, y = x_1, with a parameter a (default 2)."""
    xs = sp.symbols(f"x1:{n + 1}")
    a, d = sp.symbols("a d")
    dyn = [-a * xs[i] + (xs[i + 1] if i + 1 < n else d) for i in range(n)]
    return PlantModel(name=f"chain{n}", time="continuous", states=list(xs), outputs=[xs[0]],
                      faults=[d], dynamics=dyn, parameters={a: 2})


@pytest.mark.parametrize("n, want", [(FLOAT_AUTO_N, "exact"), (FLOAT_AUTO_N + 1, "float")])
def test_auto_takes_the_float_path_above_the_threshold(n, want):
    model = random_model(n, 2, 1, seed=0, time="discrete")
    problem = prepare(model)
    assert problem.method == want
    assert problem.work is model  # no parameters: nothing to substitute


def test_auto_with_parameters_substituted_or_kept():
    model = _chain(FLOAT_AUTO_N + 1)
    numeric = prepare(model)
    assert numeric.method == "float" and not numeric.work.parameters and not numeric.symbolic
    kept = prepare(model, symbolic=True)
    assert kept.method == "exact" and kept.work is model and kept.symbolic


def test_auto_asks_the_float_path_whether_it_takes_the_structure():
    model = random_model(FLOAT_AUTO_N + 1, 2, 1, seed=1, time="discrete")
    seen = []

    def never(st):
        seen.append(st)
        return False

    problem = prepare(model, float_takes=never)
    assert problem.method == "exact"
    assert seen and seen[0] is problem.structure  # extracted once, for both
    assert prepare(model, float_takes=lambda st: st.is_linear).method == "float"


def test_float_is_refused_with_parameters_kept_as_symbols():
    with pytest.raises(UsageError, match="the float path needs numeric parameters"):
        prepare(_chain(3), symbolic=True, method="float")
    assert prepare(_chain(3), method="float").method == "float"  # substituted: fine


def test_an_unknown_method_is_refused_in_one_line():
    with pytest.raises(UsageError, match="method must be 'auto', 'exact' or 'float'") as exc:
        prepare(_chain(3), method="svd")
    assert "\n" not in str(exc.value)


def test_a_given_structure_is_used_as_is():
    model = random_model(4, 2, 1, seed=2, time="continuous")
    st = extract_structure(model)
    problem = prepare(model, structure=st, method="exact")
    assert problem.structure is st
    assert problem.method == "exact"


def test_the_structure_is_extracted_once_when_first_used():
    model = _chain(3)
    problem = prepare(model)
    assert problem._structure is None  # nothing extracted yet
    st = problem.structure
    assert problem.structure is st
    assert st.model is problem.work and not st.model.parameters
    assert isinstance(problem, Prepared) and problem.model is model

"""Models from python-control, scipy and plain matrices (PlantModel.from_statespace): exact
rationals by the stated rule, input columns grouped by role, the round trip through
python-control's StateSpace, and one-line refusals."""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import sympy as sp

from observer_cad import PlantModel, extract_structure
from observer_cad.errors import DimensionError, ModelError

control = pytest.importorskip("control")
signal = pytest.importorskip("scipy.signal")

A = [[-1.0, 0.1, 0.0], [0.25, -2.0, 1.0], [0.0, 0.5, -3.0]]
B = [[1.0, 0.5, 0.0, 0.0], [0.0, 1.0, 1.0, 0.2], [0.0, 0.0, 0.0, 0.0]]
C = [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
D = [[0.0] * 4, [0.0] * 4]


def test_python_control_statespace_with_groups():
    sys = control.ss(A, B, C, D)
    m = PlantModel.from_statespace(sys, inputs=[0], faults=[1], disturbances=[2, 3],
                                   name="three")
    st = extract_structure(m)
    assert m.time == "continuous" and m.name == "three"
    # the rule: a float is the rational of its shortest decimal representation
    assert st.F == sp.Matrix([[-1, sp.Rational(1, 10), 0], [sp.Rational(1, 4), -2, 1],
                              [0, sp.Rational(1, 2), -3]])
    assert st.G == sp.Matrix([1, 0, 0])
    assert st.D == sp.Matrix([sp.Rational(1, 2), 1, 0])
    assert st.L == sp.Matrix([[0, 0], [1, sp.Rational(1, 5)], [0, 0]])
    assert st.H == sp.Matrix([[1, 0, 0], [0, 0, 1]])
    assert [s.name for s in m.inputs] == ["u1"] and [s.name for s in m.faults] == ["f1"]
    assert [s.name for s in m.disturbances] == ["rho1", "rho2"]


def test_round_trip_through_python_control():
    """model → control.StateSpace (from its extracted matrices) → model: the same
    structure, exactly."""
    sys = control.ss(A, B, C, D)
    m = PlantModel.from_statespace(sys, inputs=[0, 1], disturbances=[2, 3])
    st = extract_structure(m)
    to_float = lambda M: np.array(sp.Matrix(M).evalf(), dtype=float)  # noqa: E731
    back = control.ss(to_float(st.F), to_float(sp.Matrix.hstack(st.G, st.L)), to_float(st.H),
                      np.zeros((2, 4)))
    again = extract_structure(PlantModel.from_statespace(back, inputs=[0, 1],
                                                         disturbances=[2, 3]))
    for name in ("F", "G", "H", "L"):
        assert getattr(again, name) == getattr(st, name), name
    np.testing.assert_array_equal(back.A, sys.A)


def test_scipy_lti_and_dlti_and_tuples():
    m = PlantModel.from_statespace(signal.lti([[-1.5]], [[2]], [[1]], [[0]]))
    assert m.time == "continuous" and m.dynamics == (2 * m.inputs[0] - sp.Rational(3, 2) * m.states[0],)
    md = PlantModel.from_statespace(signal.dlti([[0.5]], [[1]], [[1]], [[0]], dt=0.1))
    assert md.time == "discrete"
    mt = PlantModel.from_statespace((np.array([[0.3]]), [[1]], [[1]], [[0]]), time="discrete")
    assert mt.dynamics == (mt.inputs[0] + sp.Rational(3, 10) * mt.states[0],)
    mf = PlantModel.from_statespace(([[Fraction(1, 3)]], [[1]], [[1]], [[0]]), time="continuous")
    assert mf.dynamics[0].coeff(mf.states[0]) == sp.Rational(1, 3)


def test_names_given_and_from_labels():
    sys = control.ss([[-1]], [[1, 2]], [[1]], [[0, 0]], states=["speed"], inputs=["volt", "load"])
    m = PlantModel.from_statespace(sys, faults=[1])
    assert [s.name for s in m.states] == ["speed"]
    assert [s.name for s in m.inputs] == ["volt"] and [s.name for s in m.faults] == ["load"]
    m2 = PlantModel.from_statespace(sys, faults=[1], names={"faults": ["f_load"]})
    assert [s.name for s in m2.faults] == ["f_load"]


@pytest.mark.parametrize("args, kwargs, match", [
    (([[1, 2]], [[1]], [[1]], [[0]]), {"time": "continuous"}, "A must be square"),
    (([[1]], [[1]], [[1]], [[0]]), {}, "say time="),
    (([[float("nan")]], [[1]], [[1]], [[0]]), {"time": "continuous"}, r"A\[1,1\]: nan"),
    (([[1]], [[1, 1]], [[1]], [[0, 0]]), {"time": "continuous", "faults": [1],
                                           "disturbances": [1]}, "column 1 is in faults"),
    (([[1]], [[1, 1]], [[1]], [[0, 0]]), {"time": "continuous", "faults": [5]},
     "the system has 2 input columns"),
    (([[1]], [[1, 1]], [[1]], [[0, 0]]), {"time": "continuous", "inputs": [0]},
     "column\\(s\\) 1 are in no group"),
    (([[1]], [[1]], [[1]], [[0]]), {"time": "continuous", "names": {"states": ["a", "b"]}},
     "2 state names for 1 states"),
])
def test_refusals_are_one_line(args, kwargs, match):
    with pytest.raises((ModelError, DimensionError), match=match) as exc:
        PlantModel.from_statespace(args, **kwargs)
    assert len(str(exc.value).splitlines()) == 1

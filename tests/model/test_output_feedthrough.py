"""Faults, disturbances and inputs in the outputs: y = H x + Gy u + Dy d + Ly ρ + W w.
Extraction fills Gy, Dy, Ly (zero matrices when absent), the model certificate rebuilds
every output with them, nonlinear output terms are refused in one line, and
from_statespace's fault and disturbance columns of D give working models."""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from observer_cad import PlantModel, extract_structure
from observer_cad.errors import ModelError
from observer_cad.model import load_model

x1, x2, x3 = sp.symbols("x1 x2 x3")
u, fa, fs, rho, w1, w2, k = sp.symbols("u fa fs rho w1 w2 k")


def _model(outputs, **kw):
    base = dict(name="ft", time="continuous", states=[x1, x2], inputs=[u], faults=[fa, fs],
                disturbances=[rho], noise=[w1, w2], outputs=outputs,
                dynamics=[-x1 + u + fa, x1 - 2 * x2 + rho])
    base.update(kw)
    return PlantModel(**base)


def test_feedthrough_matrices_are_read_exactly():
    m = _model([x1 + fs + w1, 3 * x2 - u / 2 + rho / 3 + w2])
    st = extract_structure(m)
    assert st.H == sp.Matrix([[1, 0], [0, 3]])
    assert st.Gy == sp.Matrix([0, -sp.Rational(1, 2)])
    assert st.Dy == sp.Matrix([[0, 1], [0, 0]])
    assert st.Ly == sp.Matrix([0, sp.Rational(1, 3)])
    assert st.W == sp.eye(2)
    assert st.has_feedthrough
    assert st.output_columns(["fs", "rho"]) == sp.Matrix([[1, 0], [0, sp.Rational(1, 3)]])
    # the certificate rebuilds every output with the feedthrough
    assert "Gy u + Dy d + Ly rho" in st.certificate.IDENTITY
    assert st.certificate.exact and len(st.certificate.checks) == 4
    assert sp.expand(st.outputs_rebuilt()[1] - m.outputs[1]) == 0


def test_without_feedthrough_the_matrices_are_zero_of_the_right_shape():
    st = extract_structure(_model([x1 + w1, x2 + w2], faults=[fa]))
    assert st.Gy.shape == (2, 1) and st.Dy.shape == (2, 1) and st.Ly.shape == (2, 1)
    assert st.Gy.is_zero_matrix and st.Dy.is_zero_matrix and st.Ly.is_zero_matrix
    assert st.Bw.shape == (2, 2) and st.Bw.is_zero_matrix
    assert not st.has_feedthrough


def test_parameters_in_the_feedthrough_stay_symbolic():
    m = _model([x1 + k * fs + w1, x2 + w2], parameters={k: 2})
    st = extract_structure(m)
    assert st.Dy == sp.Matrix([[0, k], [0, 0]])
    assert extract_structure(m.substitute_parameters()).Dy == sp.Matrix([[0, 2], [0, 0]])


def test_a_fault_in_the_outputs_only_is_declared_fine():
    m = _model([x1 + fs + w1, x2 + w2])
    assert fs not in set().union(*[f.free_symbols for f in m.dynamics])
    with pytest.raises(ModelError, match="appears in no dynamics equation or output"):
        _model([x1 + w1, x2 + w2], faults=[fa, fs])


@pytest.mark.parametrize("out, word", [
    (x1 + fs ** 2 + w1, "fault 'fs'"),
    (x1 + u * fs + w1, "not linear"),
    (x1 + sp.sin(rho) + w1, "disturbance 'rho'"),
    (x1 * u + w1, "not linear in the states"),
    (x1 + 1 + w1, "constant offset"),
])
def test_nonlinear_output_terms_are_refused_in_one_line(out, word):
    with pytest.raises(ModelError, match=word) as e:
        extract_structure(_model([out, x2 + fs + w2]))
    assert "\n" not in str(e.value)


def test_sensor_fault_example_model():
    m = load_model("models/three_tank_sensor_faults.py")
    st = extract_structure(m)
    assert st.Dy == sp.Matrix([[0, 0, 1, 0, 0], [0, 0, 0, 1, 0], [0, 0, 0, 0, 1]])
    assert st.D[:, 2:].is_zero_matrix and st.Ly.is_zero_matrix and st.Gy.is_zero_matrix


def test_from_statespace_fault_and_disturbance_columns_of_d():
    A = [[-1.0, 0.0], [0.5, -2.0]]
    B = [[1.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]]
    C = [[1.0, 0.0], [0.0, 1.0]]
    D = [[0.25, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 0.5]]
    m = PlantModel.from_statespace((A, B, C, D), time="continuous", inputs=[0], faults=[1, 2],
                                   disturbances=[3])
    st = extract_structure(m)
    assert st.Gy == sp.Matrix([sp.Rational(1, 4), 0])
    assert st.Dy == sp.Matrix([[0, 1], [0, 0]])
    assert st.Ly == sp.Matrix([0, sp.Rational(1, 2)])
    assert st.D == sp.Matrix([[1, 0], [0, 0]]) and st.L.is_zero_matrix
    assert st.certificate.exact
    # the model designs: a residual for f1, decoupled from rho1 (a disturbance of sensor 2
    # only: y2 is projected out), certified with the feedthrough identities
    from observer_cad.synthesis import design
    d = design(m, observer="diagnostic", faults=["f1"])
    names = [i.name for i in d.certificate.identities]
    assert d.certificate.passed and "R* Ly" in names and "Phi G - J* Gy - G*" in names
    Ly = np.array(st.Ly, dtype=float)
    assert np.allclose(np.array(d.matrices.R_star, dtype=float) @ Ly, 0)
    assert np.allclose(np.array(d.matrices.J_star, dtype=float) @ Ly, 0)
    assert d.signature_map["f1"] and d.signature_map["f2"]  # f2: the bias of sensor 1
    # r = y1 − u/4 − x*: the input's feedthrough is taken off the measurement
    (_, r), = d.outputs
    assert sp.expand(r - (sp.Symbol("y1") - m.inputs[0] / 4 - d.observer_states[0])) == 0

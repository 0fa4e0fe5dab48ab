"""Interoperability: python-control StateSpace of linear observers,
LaTeX of a design's matrices, JSON files.

The StateSpace is checked against the reference simulator on step inputs: a "signal
source" plant (constant states, outputs y = s) feeds the observer exact steps in one
input at a time, so the simulator's RK4 trajectory of the observer is its step response
(RK4 error at dt = 0.01 on these stable modes is below 1e-9) and python-control's
step_response (exact matrix exponential) must agree to that accuracy.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
import sympy as sp

from observer_cad import PlantModel, UsageError, load_model
from observer_cad.reporting import design_latex, design_latex_document, linear_matrices, matrices_from_json, read_design_json, to_statespace, write_design_json
from observer_cad.observers import build_observer
from observer_cad.simulation import scenario_from_dict, simulate
from observer_cad.synthesis import design


@pytest.fixture(scope="module")
def tank_lin(models_dir):
    return load_model(models_dir / "three_tank_linear.py")


@pytest.fixture(scope="module")
def drive(models_dir):
    return load_model(models_dir / "electric_drive.py")


def _source(time: str, inputs, l: int = 2) -> PlantModel:
    """A plant whose outputs are its constant states: y_i = s_i, s_i' = 0 (or s_i(t+1) = s_i)."""
    s = sp.symbols(f"s1:{l + 1}")
    return PlantModel(name="source", time=time, states=list(s), inputs=list(inputs),
                      outputs=list(s), dynamics=[0 if time == "continuous" else x for x in s])


def _step_via_simulator(observer, time, inputs, j, T):
    """The observer's response to a unit step in its j-th signal (y1, y2, …, u1, …),
    from the zero state, by the reference simulator."""
    names = [str(s) for s in observer.signals]
    l = sum(1 for n in names if n.startswith("y"))
    src = _source(time, inputs, l)
    sig = names[j]
    initial = {f"s{sig[1:]}": 1.0} if sig.startswith("y") else {}
    signals = {} if sig.startswith("y") else {sig: "1"}
    spec = {"initial": initial, "signals": signals,
            "observer_initial": {str(x): 0 for x in observer.states}}
    spec.update({"t_end": T[-1], "dt": T[1] - T[0]} if time == "continuous" else {"steps": len(T)})
    res = simulate(src, observer, scenario_from_dict(spec))
    return np.stack([res[n] for n in observer.output_names])


@pytest.mark.parametrize("kw", [dict(), dict(form="canonical", eigenvalues=["-1", "-2"]),
                                dict(form="canonical", variant="004", eigenvalues=["-1", "-3"])],
                         ids=["jordan", "canonical", "canonical-004"])
def test_statespace_step_response_equals_simulator(tank_lin, kw):
    ct = pytest.importorskip("control")
    d = design(tank_lin, observer="virtual-sensor", estimate="x1", **kw)
    ob = build_observer(tank_lin, d)
    sys = to_statespace(ob)
    assert sys.isctime() and sys.nstates == d.k
    assert [sys.input_labels[i] for i in range(sys.ninputs)] == ["y1", "y2", "u1", "u2"]
    assert list(sys.output_labels) == ["x1_hat"]
    T = np.arange(0, 8.0 + 1e-9, 0.01)
    resp = ct.step_response(sys, T)
    for j in range(sys.ninputs):
        ref = _step_via_simulator(ob, "continuous", tank_lin.inputs, j, T)
        got = np.asarray(resp.outputs)[:, j, :] if sys.noutputs > 1 else \
            np.asarray(resp.outputs).reshape(sys.ninputs, -1)[j][None, :]
        assert np.max(np.abs(got - ref)) < 1e-8, (sys.input_labels[j], np.max(np.abs(got - ref)))
    # the Jordan sensor is seed 002's x*' = -x* + y1 + u1 (λ = -1): A = -1, B = (1, 0, 1, 0)
    if not kw:
        assert np.allclose(sys.A, [[-1]]) and np.allclose(sys.B, [[1, 0, 1, 0]])
        assert np.allclose(sys.C, [[1]]) and np.allclose(sys.D, 0)


def test_statespace_discrete_residual_generator(drive):
    ct = pytest.importorskip("control")
    d = design(drive, observer="diagnostic", form="jordan")
    ob = build_observer(drive, d)
    sys = to_statespace(ob)
    assert sys.isdtime() and sys.dt == 1
    T = np.arange(40)
    resp = ct.step_response(sys, T)
    for j in range(sys.ninputs):
        ref = _step_via_simulator(ob, "discrete", drive.inputs, j, T)
        got = np.asarray(resp.outputs).reshape(sys.ninputs, -1)[j]
        assert np.max(np.abs(got - ref[0])) < 1e-12


def test_linear_matrices_exact_and_affine(tank_lin):
    d = design(tank_lin, observer="interval", estimate="x1")
    ob = build_observer(tank_lin, d)
    with pytest.raises(UsageError, match="affine"):
        linear_matrices(ob)
    A, B, C, D, inputs = linear_matrices(ob, constant_input=True)
    assert inputs[-1] == "1" and A == -sp.eye(2)
    # the constant column holds the noise margins ∓ w*: lower copy −w*, upper +w*
    assert list(B[:, -1]) == [-sp.Rational(1, 50), sp.Rational(1, 50)]


def test_nonlinear_observer_refused(models_dir):
    tank = load_model(models_dir / "three_tank.py")
    ob = build_observer(tank, design(tank, observer="virtual-sensor", estimate="x1"))
    with pytest.raises(UsageError, match="not linear"):
        linear_matrices(ob)


def test_statespace_without_control_is_one_line(monkeypatch, tank_lin):
    import builtins
    real = builtins.__import__

    def fake(name, *a, **k):
        if name == "control" or name.startswith("control."):
            raise ModuleNotFoundError("No module named 'control'")
        return real(name, *a, **k)
    monkeypatch.setattr(builtins, "__import__", fake)
    d = design(tank_lin, observer="virtual-sensor", estimate="x1")
    with pytest.raises(UsageError, match=r"pip install control") as exc:
        to_statespace(d, tank_lin)
    assert "\n" not in str(exc.value)


def test_design_needs_model_for_statespace(tank_lin):
    pytest.importorskip("control")
    d = design(tank_lin, observer="virtual-sensor", estimate="x1")
    with pytest.raises(UsageError, match="pass the model"):
        to_statespace(d)
    assert to_statespace(d, tank_lin).nstates == 1


def test_latex_contains_every_entry(drive):
    k1, k2, k4 = sp.symbols("k1 k2 k4")
    d = design(drive, observer="unknown-input", faults=["rho"], symbolic=True)
    tex = design_latex(d)
    assert set(tex) == set(d.matrices.as_dict())
    assert tex["Phi"].startswith(r"\Phi = ") and tex["F_star"].startswith("F^{*} = ")
    for name, M in d.matrices.items():
        for e in sp.Matrix(M):
            assert sp.latex(e) in tex[name], (name, e)
    # K = k1 (1 + k2) / k4 of seed 000 §9 appears in J*
    assert r"\frac{k_{1} \left(k_{2} + 1\right)}{k_{4}}" in tex["J_star"]
    doc = design_latex_document(d)
    assert doc.startswith(r"\documentclass") and doc.rstrip().endswith(r"\end{document}")
    assert doc.count(r"\begin{align*}") == doc.count(r"\end{align*}") >= 1
    assert doc.count("{") == doc.count("}")
    snippet = design_latex_document(d, standalone=False)
    assert r"\documentclass" not in snippet and tex["Phi"].split(" = ")[1] in snippet


def test_latex_parses_back_when_available(tank_lin):
    parse_latex = pytest.importorskip("sympy.parsing.latex").parse_latex
    try:
        parse_latex("x + 1")
    except Exception:  # noqa: BLE001 - the ANTLR runtime is an optional extra of sympy
        pytest.skip("sympy's LaTeX parser needs antlr4-python3-runtime")
    d = design(tank_lin, observer="virtual-sensor", estimate="x1", form="canonical",
               eigenvalues=["-1", "-2"])
    for name, M in d.matrices.items():
        M = sp.Matrix(M)
        if M.rows == 0 or M.cols == 0:
            continue
        for e in M:
            assert sp.simplify(parse_latex(sp.latex(e)) - e) == 0


def test_json_file_round_trip(tmp_path, drive):
    d = design(drive, observer="unknown-input", faults=["rho"], symbolic=True)
    p = write_design_json(d, tmp_path / "sub" / "rho.json")
    assert p.is_file() and not list(p.parent.glob(".*tmp"))
    data = read_design_json(p)
    assert data == json.loads(json.dumps(d.to_json()))
    back = matrices_from_json(data)
    assert set(back) == set(d.matrices.as_dict())
    for name, M in d.matrices.items():
        assert sp.simplify(back[name] - sp.Matrix(M)) == sp.zeros(*sp.Matrix(M).shape), name
    with pytest.raises(UsageError, match="no such design file"):
        read_design_json(tmp_path / "missing.json")
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(UsageError, match="not valid JSON"):
        read_design_json(tmp_path / "bad.json")

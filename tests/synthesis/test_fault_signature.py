"""Full fault signatures: every design with a residual reports, for
EVERY declared fault, whether the residual responds — checked here against an
independent oracle: the fault columns read off the model's right-hand side by
differentiation (not from the extracted structure), and the transfer function
H* (sI − F*)⁻¹ Φ D_j computed symbolically in s (not the observability matrix the
implementation uses). Also: the 3-tank case of the issue (a residual designed for f1 that
f2 also moves must say so), refusals that name the fault and the reason, a
symbolic sensitivity that needs a parameter nonzero, and the JSON round trip."""
from __future__ import annotations

import json

import numpy as np
import pytest
import sympy as sp

from observer_cad import Design, PlantModel, design, load_model
from observer_cad.errors import InfeasibleDesignError, UsageError
from observer_cad.reporting import format_design

from signature_oracle import oracle_signature, three_tanks


EXAMPLES = [
    ("electric_drive.py", dict(observer="diagnostic")),
    ("electric_drive.py", dict(observer="diagnostic", form="canonical", eigenvalues=["1/2"])),
    ("electric_drive.py", dict(observer="unknown-input", faults=["d"])),
    ("electric_drive.py", dict(observer="unknown-input", faults=["rho"])),
    ("sliding_example.py", dict(observer="sliding-mode", faults=["d"])),
]


@pytest.mark.parametrize("path,kw", EXAMPLES, ids=lambda v: str(v))
def test_signature_of_example_models_matches_oracle(models_dir, path, kw):
    m = load_model(models_dir / path)
    d = design(m, **kw)
    assert d.signature, "a design with a residual carries its signature"
    assert [s.name for s in d.signature][:len(m.faults)] == [f.name for f in m.faults]
    assert d.signature_map == {k: v for k, v in oracle_signature(m, d).items()
                               if k in d.signature_map}
    js = d.to_json()
    assert js["signature"] == d.signature_map
    assert "Fault signature" in format_design(d)


def test_designs_without_residual_have_no_signature(models_dir):
    m = load_model(models_dir / "three_tank.py")
    d = design(m, observer="virtual-sensor", estimate="x1")
    assert d.signature == ()
    assert d.to_json()["signature"] == {}
    assert "Fault signature" not in format_design(d)


def test_three_tank_f1_residual_says_it_also_sees_f2():
    """The issue's case: designed for f1 (f2, f3 assumed zero), the residual moves with
    f2 too (Φ D2 ≠ 0), and f3 (beside the decoupled ρ) does not reach it."""
    m = three_tanks()
    d = design(m, observer="diagnostic", faults=["f1"])
    assert d.signature_map == {"f1": True, "f2": True, "f3": False}
    assert d.signature_map == oracle_signature(m, d)
    roles = {s.name: s.role for s in d.signature}
    assert roles == {"f1": "detected", "f2": "assumed zero", "f3": "assumed zero"}
    text = format_design(d)
    assert "yet a nonzero f2 moves r" in text


def test_refusal_names_the_undetectable_fault_and_the_reason():
    m = three_tanks()
    with pytest.raises(InfeasibleDesignError) as exc:
        design(m, observer="diagnostic", faults=["f1", "f2", "f3"])
    msg = str(exc.value)
    assert "f3 is undetectable with rho decoupled" in msg
    assert "every row Φ with Φ L = 0" in msg and "Φ D_f3 = 0" in msg
    assert "fault column" not in msg


def test_refusal_when_no_reduced_model_exists_names_the_fault():
    m = three_tanks()
    with pytest.raises(InfeasibleDesignError) as exc:
        design(m, observer="diagnostic", faults=["f2"], disturbances=["f1"])
    assert "f2 cannot be detected with rho, f1 decoupled" in str(exc.value)


def _random_multi_fault(seed, n=4, l=2, q=3, p=1):
    """A random integer plant with q faults (own generator: random_model has one fault)."""
    rng = np.random.default_rng(seed)
    x = sp.symbols(f"x1:{n + 1}")
    fs = sp.symbols(f"f1:{q + 1}")
    rs = sp.symbols(f"rho1:{p + 1}")
    u = sp.Symbol("u")
    F = rng.integers(-2, 3, (n, n))
    H = rng.integers(-1, 2, (l, n))
    D = rng.integers(-1, 2, (n, q))
    L = rng.integers(-1, 2, (n, p))
    G = rng.integers(-1, 2, (n, 1))
    for M in (H, D, L):  # no zero output row / fault column
        for j in range(M.shape[1]):
            if not M[:, j].any():
                M[rng.integers(0, M.shape[0]), j] = 1
        for i in range(M.shape[0] if M is H else 0):
            if not M[i].any():
                M[i, rng.integers(0, n)] = 1
    dyn = [sum(int(F[i, j]) * x[j] for j in range(n)) + int(G[i, 0]) * u
           + sum(int(D[i, j]) * fs[j] for j in range(q))
           + sum(int(L[i, j]) * rs[j] for j in range(p)) for i in range(n)]
    outs = [sum(int(H[i, j]) * x[j] for j in range(n)) for i in range(l)]
    return PlantModel(name=f"rand{seed}", time="continuous", states=list(x), inputs=[u],
                      faults=list(fs), disturbances=list(rs), outputs=outs, dynamics=dyn)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(8))
def test_signature_on_random_systems_matches_oracle(seed):
    m = _random_multi_fault(seed)
    checked = 0
    for targets in (["f1"], ["f2"], ["f3"], ["f1", "f2", "f3"]):
        try:
            d = design(m, observer="diagnostic", faults=targets)
        except InfeasibleDesignError:
            continue
        oracle = oracle_signature(m, d)
        assert d.signature_map == oracle, (targets, d.matrices.Phi)
        for t in targets:  # a target the residual does not see is never returned
            assert oracle[t], (targets, t)
        checked += 1
    if not checked:
        pytest.skip(f"seed {seed}: no diagnostic design for this plant")


def test_random_systems_give_some_non_target_sensitivity():
    """Across the seeds at least one residual responds to a fault it was not designed for
    (the signature says more than the targets)."""
    found = False
    for seed in range(8):
        m = _random_multi_fault(seed)
        try:
            d = design(m, observer="diagnostic", faults=["f1"])
        except InfeasibleDesignError:
            continue
        if d.signature_map.get("f2") or d.signature_map.get("f3"):
            found = True
            break
    assert found


def test_symbolic_sensitivity_needs_the_parameter_nonzero():
    """f2 enters through k: the residual for f1 responds to f2 only if k ≠ 0 (reported
    as conditional); detecting f2 makes k ≠ 0 an assumption of the design."""
    x1, x2, x3 = sp.symbols("x1:4")
    u, f1, f2, rho, k = sp.symbols("u f1 f2 rho k")
    m = PlantModel(name="sym", time="continuous", states=[x1, x2, x3], inputs=[u],
                   faults=[f1, f2], disturbances=[rho], outputs=[x2, x3],
                   dynamics=[-x1 + x2 + u + f1, x1 - 2 * x2 + x3 + k * f2,
                             x2 - 2 * x3 + rho], parameters={k: sp.Rational(1, 2)})
    d = design(m, observer="diagnostic", faults=["f1"], symbolic=True)
    s2 = {s.name: s for s in d.signature}["f2"]
    assert s2.sensitive and s2.conditions == (sp.Ne(k, 0),)
    assert "sensitive if Ne(k, 0)" in format_design(d)
    assert sp.Ne(k, 0) not in d.assumptions  # f2 is not a target: conditional only
    d2 = design(m, observer="diagnostic", faults=["f2"], symbolic=True)
    assert sp.Ne(k, 0) in d2.assumptions
    assert d2.signature_map["f2"] is True


def test_signature_survives_json_and_is_recomputed(models_dir):
    m = three_tanks()
    d = design(m, observer="diagnostic", faults=["f1"])
    data = json.loads(json.dumps(d.to_json()))
    again = Design.from_json(data, m)
    assert again.signature_map == d.signature_map
    data["signature"]["f2"] = False  # tampered: the matrices say otherwise
    with pytest.raises(UsageError, match="f2"):
        Design.from_json(data, m)
    del data["signature"]  # older JSON without it: recomputed
    assert Design.from_json(data, m).signature_map == d.signature_map


def test_float_design_signature_agrees_with_exact():
    """The float path (SVD, Float matrices) decides 'nonzero' with a relative tolerance:
    roundoff in Φ D_j is not a sensitivity."""
    m = three_tanks()
    exact = design(m, observer="diagnostic", faults=["f1"], method="exact")
    flt = design(m, observer="diagnostic", faults=["f1"], method="float")
    assert flt.method.value == "float"
    assert flt.signature_map == exact.signature_map == {"f1": True, "f2": True, "f3": False}
    assert {s.name: s.enters for s in flt.signature}["f3"] is False


def test_float_path_refusal_names_the_fault():
    m = three_tanks()
    with pytest.raises(InfeasibleDesignError) as exc:
        design(m, observer="diagnostic", method="float")
    assert "f3 is undetectable with rho decoupled" in str(exc.value)


def test_float_rounding_of_an_output_only_fault_is_not_sensitivity():
    """A fault that enters the outputs only has a zero column of D: in a float design its
    terms J* Dy and R* Dy are judged against max(‖J*‖, ‖R*‖) ‖Dy‖, so rounding (1e-16) is
    not "sensitive" while a unit bias is."""
    from observer_cad.synthesis.certificates import fault_sensitivity
    Phi, Fs, Hs = sp.Matrix([[1.0, 0.0]]), sp.Matrix([[-1.0]]), sp.Matrix([[1.0]])
    zero = sp.Matrix([0, 0])
    noise = fault_sensitivity(Phi, Fs, Hs, zero, feed=sp.Matrix([2e-16]),
                              direct=sp.Matrix([3e-17]), feed_scale=1.0)
    assert not noise.sensitive and not noise.enters
    bias = fault_sensitivity(Phi, Fs, Hs, zero, feed=sp.Matrix([0.5]), direct=sp.Matrix([1.0]),
                             feed_scale=1.0)
    assert bias.sensitive and bias.enters

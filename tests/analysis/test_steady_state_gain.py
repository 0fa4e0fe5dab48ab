"""Steady-state gains of designed residuals: a fault a residual responds to with a zero
steady-state gain is reported as "transient only" in the fault signature, in agreement
with the strong detectability of the analysis (Varga 2017, Ch. 3; the examples of
FaultDetectionTools.jl, docs/REFERENCES.md)."""
from __future__ import annotations

from types import SimpleNamespace

import pytest
import sympy as sp

from observer_cad.analysis import analyze
from observer_cad.synthesis import design
from observer_cad.synthesis.certificates import steady_state_gain

from .varga_examples import yuan_1997


def _first_order(F_star, time="continuous", K=None):
    """x' = −x + d, y = x and the residual x*' = F* x* + J* y, r = y − x*, with
    J* = F* + 1 (Φ = 1: Φ F − F* Φ − J* H = 0)."""
    m = SimpleNamespace(Phi=sp.Matrix([[1]]), F_star=sp.Matrix([[F_star]]),
                        J_star=sp.Matrix([[F_star + 1]]), R_star=sp.Matrix([[1]]),
                        H_star=sp.Matrix([[1]]), K=K)
    return m, SimpleNamespace(model=SimpleNamespace(time=time))


def test_gain_by_hand():
    m, st = _first_order(-2)
    # r = (1/(s + 2)) d: gain 1/2; a sensor bias (dy = 1) enters r directly, and its
    # effect through J* y cancels the first part: b = Φ D − J* Dy
    assert steady_state_gain(m, st, [1]) == (sp.Rational(1, 2),)
    assert steady_state_gain(m, st, [0], [1]) == (1 - sp.Rational(-1, 2),)
    assert steady_state_gain(m, st, [-1], [1]) == (1,)
    assert steady_state_gain(m, st, [-3], [1]) == (0,)  # 1 + (−3 + 1)/2
    # output injection changes the pole, not whether the gain vanishes
    k, _ = _first_order(-2, K=sp.Matrix([[3]]))
    assert steady_state_gain(k, st, [1]) == (sp.Rational(1, 5),)
    # with K, the injected residual K r carries the sensor bias too: by hand,
    # x*' = −2 x* − y + 3 (y − x*) = −5 x* + 2 y with y = 1 (a bias, x stays 0): x* = 2/5,
    # r = y − x* = 3/5
    assert steady_state_gain(k, st, [0], [1]) == (sp.Rational(3, 5),)
    # discrete time: the gain at z = 1
    d, dt = _first_order(sp.Rational(1, 2), time="discrete")
    assert steady_state_gain(d, dt, [1]) == (2,)
    # on the stability boundary there is no steady state
    z, _ = _first_order(0)
    assert steady_state_gain(z, st, [1]) is None
    assert steady_state_gain(SimpleNamespace(R_star=None, H_star=None), st, [1]) is None


@pytest.mark.parametrize("decoupled", [("f5",), ("f4", "f6")])
def test_transient_only_faults_agree_with_the_analysis(decoupled):
    """Yuan 1997: with these faults decoupled a weak structure row loses a fault at
    ω = 0. Every residual realising the row sees that fault only as a transient, and
    its signature says so; the faults the analysis finds strongly detectable keep a
    nonzero gain in the designed residual."""
    st = yuan_1997()
    rest = [f.name for f in st.model.faults if f.name not in decoupled]
    a = analyze(st.model, structure=st, faults=rest, disturbances=list(decoupled),
                frequencies=[0])
    weak_only = set(a.transient_only)
    assert weak_only, "the published strong structure matrix lacks this row"
    on = [f for f in a.faults if a.detectable[f]]
    d = design(st.model, observer="diagnostic", faults=on, disturbances=list(decoupled),
               form="jordan")
    sig = {s.name: s for s in (d.signature or d.with_signature().signature)}
    assert {n for n, s in sig.items() if s.transient_only} == weak_only
    assert all(sig[f].sensitive for f in on)
    for f in weak_only:
        assert sig[f].describe().startswith("transient only")

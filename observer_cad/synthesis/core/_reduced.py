"""The reduced model's names and equations, shared by every designer: the symbols of
x* and y, the estimate z = M x, stability of a λ, and the observer equations
F* x* + J* y + G* u + C* Ψ*(x*, y, u) with their outputs."""
from __future__ import annotations

from typing import Mapping

import sympy as sp


__all__ = ["observer_symbols", "output_symbols", "is_stable", "jordan_equations",
           "reduced_equations", "residual_outputs", "estimate_outputs", "named_outputs",
           "sliding_equations", "K1", "EPS", "TAU", "INJECTIONS"]

#: the sliding-mode observer's gain, boundary-layer width and filter time constant (their
#: values are the observer's parameters)
K1, EPS, TAU = sp.symbols("k_sm eps_sm tau_sm")
#: how a sliding-mode observer injects sign(e): "regularised" e/(|e| + ε), or "sign"
#: (sign(e), its estimate through a first-order filter with the state vf)
INJECTIONS = ("regularised", "sign")


def observer_symbols(k: int):
    """Names of the reduced model's states: xs1, xs2, …"""
    return sp.symbols(f"xs1:{k + 1}")


def output_symbols(l: int):
    return sp.symbols(f"y1:{l + 1}")


def is_stable(lam, time: str):
    """True / False, or None when it depends on symbolic parameters."""
    lam = sp.sympify(lam)
    if lam.free_symbols:
        return None
    if not lam.is_real:
        return False
    return bool(lam < 0) if time == "continuous" else bool(abs(lam) < 1)


def _get(mats, name):
    return mats.get(name) if isinstance(mats, Mapping) else getattr(mats, name)


def reduced_equations(mats, inputs, xs, ys, *, nonlinear=(), q: int | None = None,
                      feedback: bool = True, deep: bool = False, measured=None) -> tuple:
    """The one builder of a reduced model's right-hand sides (METHOD §2):

        F* x* + J* y + G* u + C* Ψ*(x*, y, u) + K (R* y − H* x*)

    ``mats`` is a design's matrices (a :class:`DesignMatrices` or the designers' working
    mapping); the K term is added when K is present and ``feedback``; Ψ*_j is the
    argument-substituted term of each :class:`NonlinearSubstitution` (``q`` columns of C*).
    The unknown input is omitted (it is what the observer does not know). ``measured``:
    the outputs the residual in the K term reads (y − Gy u when inputs enter the outputs;
    default ``ys``).
    """
    F, J = sp.Matrix(_get(mats, "F_star")), sp.Matrix(_get(mats, "J_star"))
    rhs = F * sp.Matrix(len(xs), 1, list(xs)) + J * sp.Matrix(ys)
    if inputs:
        rhs += sp.Matrix(_get(mats, "G_star")) * sp.Matrix(inputs)
    if nonlinear:
        Cs = sp.Matrix(_get(mats, "C_star"))
        psi = sp.zeros(Cs.cols if q is None else q, 1)
        for ns in nonlinear:
            psi[ns.index - 1, 0] = ns.function
        rhs += Cs * psi
    K = _get(mats, "K")
    if feedback and K is not None:
        rhs += sp.Matrix(K) * residual_outputs(mats, xs, ys if measured is None else measured)
    return tuple(sp.expand(e, deep=deep) for e in rhs)


def residual_outputs(mats, xs, ys) -> sp.Matrix:
    """r = R* y − H* x* (one entry per measured combination)."""
    return sp.Matrix(_get(mats, "R_star")) * sp.Matrix(ys) \
        - sp.Matrix(_get(mats, "H_star")) * sp.Matrix(len(xs), 1, list(xs))


def estimate_outputs(mats, xs, ys) -> sp.Matrix:
    """z = H_z x* + Q y."""
    return sp.Matrix(_get(mats, "Hz")) * sp.Matrix(xs) + sp.Matrix(_get(mats, "Q")) * sp.Matrix(ys)


def named_outputs(prefix: str, values) -> tuple:
    """(``z``, e) for one output, (``z1``, e1), (``z2``, e2), … for several."""
    values = list(values)
    return tuple((prefix if len(values) == 1 else f"{prefix}{i + 1}", sp.expand(e))
                 for i, e in enumerate(values))


def jordan_equations(mats, inputs, xs, ys, observer, M, nonlinear=(), q=0):
    """Right-hand sides and outputs (z = H_z x* + Q y, or the residual r = R* y − H* x* for
    diagnostic observers) of a Jordan design."""
    equations = reduced_equations(mats, inputs, xs, ys, nonlinear=nonlinear, q=q or None)
    outputs = ()
    if M is not None:
        outputs = named_outputs("z", estimate_outputs(mats, xs, ys))
    if observer == "diagnostic":
        outputs = named_outputs("r", residual_outputs(mats, xs, ys))
    return equations, outputs


def sliding_equations(mats, inputs, xs, ys, fault_name: str, injection: str, *,
                      nonlinear=(), q: int | None = None, measured=None) -> tuple:
    """(states, update, outputs) of a one-row sliding-mode observer (seed 002 §5): the
    reduced model's right-hand side minus K1·v, v the injection of e = x*_1 − R* y —
    e/(abs(e) + ε) ("regularised") or sign(e), filtered by the state vf ("sign") —
    with the estimate ``<fault>_hat`` = −K1 v / D* and the residual r = R* y − x*_1
    (``measured``: y − Gy u in place of y in e and r, inputs in the outputs)."""
    x = xs[0]
    ystar = (sp.Matrix(_get(mats, "R_star"))
             * sp.Matrix(ys if measured is None else measured))[0, 0]
    e = x - ystar
    model_rhs = reduced_equations(mats, inputs, xs, ys, nonlinear=nonlinear, q=q, deep=True)[0]
    Dst = sp.Matrix(_get(mats, "D_star"))[0, 0]
    if injection == "regularised":
        veq = e / (sp.Abs(e) + EPS)
        states, update, dhat = tuple(xs), (model_rhs - K1 * veq,), -K1 / Dst * veq
    else:
        vf = sp.Symbol("vf")
        states = (x, vf)
        update = (model_rhs - K1 * sp.sign(e), (sp.sign(e) - vf) / TAU)
        dhat = -K1 / Dst * vf
    return states, update, ((f"{fault_name}_hat", dhat), ("r", sp.expand(ystar - x)))
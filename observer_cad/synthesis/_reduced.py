"""The reduced model's names and equations, shared by every designer: the symbols of
x* and y, the estimate z = M x, stability of a λ, and the observer equations
F* x* + J* y + G* u + C* Ψ*(x*, y, u) with their outputs."""
from __future__ import annotations

import sympy as sp

from ..errors import ExpressionError, ModelError
from ..model import PlantModel, parse_expression

__all__ = ["observer_symbols", "output_symbols", "parse_estimate", "is_stable", "jordan_equations"]


def observer_symbols(k: int):
    """Names of the reduced model's states: xs1, xs2, …"""
    return sp.symbols(f"xs1:{k + 1}")


def output_symbols(l: int):
    return sp.symbols(f"y1:{l + 1}")


def parse_estimate(model: PlantModel, expr) -> sp.Matrix:
    """z = M x from an expression in the state names (``"x1"``, ``"x1 - x2"``)."""
    where = model.where
    if isinstance(expr, sp.MatrixBase):
        M = sp.Matrix(expr)
        if M.cols != len(model.states):
            raise ModelError(f"{where}: M must have {len(model.states)} columns")
        return M
    exprs = expr if isinstance(expr, (list, tuple)) else [expr]
    rows = []
    loc = {s.name: s for s in model.states}
    loc.update({p.name: p for p in model.parameters})
    for e in exprs:
        if isinstance(e, str):  # text: the safe reader (never evaluated)
            try:
                e = parse_expression(e, loc, where=f"{where}: --estimate")
            except ExpressionError as exc:
                reason = exc.reason if exc.reason.startswith("not a valid expression") \
                    else f"not a valid expression: {exc.reason}"
                raise ModelError(f"{where}: cannot parse --estimate {e!r}: {reason}") from None
        elif not isinstance(e, sp.Basic):
            raise ModelError(f"{where}: --estimate {e!r} must be one expression in the"
                             " states, e.g. x1 or 'x1 - x2'")
        if not isinstance(e, sp.Expr):
            raise ModelError(f"{where}: --estimate {expr!r} must be one expression in the"
                             " states, e.g. x1 or 'x1 - x2'")
        if e == 0:
            raise ModelError(f"{where}: --estimate is identically zero")
        extra = e.free_symbols - set(model.states) - set(model.parameters)
        if extra:
            raise ModelError(f"{where}: --estimate {e} uses '{sorted(extra, key=str)[0]}',"
                             " which is not a state of the model")
        row = [sp.diff(e, x) for x in model.states]
        if any(c.free_symbols & set(model.states) for c in row) or \
                sp.expand(e - sum(c * x for c, x in zip(row, model.states))) != 0:
            raise ModelError(f"{where}: --estimate {e} is not linear in the states")
        rows.append(row)
    return sp.Matrix(rows)


def is_stable(lam, time: str):
    """True / False, or None when it depends on symbolic parameters."""
    lam = sp.sympify(lam)
    if lam.free_symbols:
        return None
    if not lam.is_real:
        return False
    return bool(lam < 0) if time == "continuous" else bool(abs(lam) < 1)


def jordan_equations(mats, inputs, xs, ys, observer, M, nonlinear=(), q=0):
    """Right-hand sides F* x* + J* y + G* u + C* Ψ* and the outputs (z = H_z x* + Q y, or
    the residual r = R* y − H* x* for diagnostic observers) of a Jordan design."""
    rhs = mats["F_star"] * sp.Matrix(xs) + mats["J_star"] * sp.Matrix(ys)
    if inputs:
        rhs += mats["G_star"] * sp.Matrix(inputs)
    if nonlinear:
        psi = sp.zeros(q, 1)
        for ns in nonlinear:
            psi[ns.index - 1, 0] = ns.function
        rhs += mats["C_star"] * psi
    equations = tuple(sp.expand(e, deep=False) for e in rhs)
    outputs = []
    if M is not None:
        z = mats["Hz"] * sp.Matrix(xs) + mats["Q"] * sp.Matrix(ys)
        outputs = [("z" if z.rows == 1 else f"z{i + 1}", sp.expand(e)) for i, e in enumerate(z)]
    if observer == "diagnostic":
        r = mats["R_star"] * sp.Matrix(ys) - mats["H_star"] * sp.Matrix(xs)
        outputs = [("r" if r.rows == 1 else f"r{i + 1}", sp.expand(e)) for i, e in enumerate(r)]
    return equations, tuple(outputs)

"""Independent oracle for a symbolic design's assumptions.

Written with plain sympy (``together``, ``fraction``, ``factor_list``, ``solve``), not
with the package's condition helpers: for every entry of every matrix a design
reports, every observer equation and output and every gain, each factor f of its
denominator that involves only the model's parameters must be excluded by the
assumptions —

1. *by divisibility*: some assumption ``Ne(g, 0)`` has f | g (so f = 0 ⇒ g = 0);
2. *by its zero set*: a point with f = 0 (the other parameters random) makes some
   assumption false;
3. *by random points*: parameter values satisfying every assumption leave every
   denominator nonzero.
"""
from __future__ import annotations

import random

import sympy as sp


def reported_expressions(design):
    """(where, expression) for everything the design reports."""
    out = []
    for name, M in design.matrices.items():
        M = sp.Matrix(M)
        for i in range(M.rows):
            for j in range(M.cols):
                out.append((f"{name}[{i + 1},{j + 1}]", M[i, j]))
    for i, e in enumerate(design.equations):
        out.append((f"equation {i + 1}", e))
    for name, e in design.outputs:
        out.append((f"output {name}", e))
    for p, v in design.parameters.items():
        out.append((f"gain {p}", v))
    return out


def parameter_factors(expr, params):
    """Factors of expr's denominator that involve the parameters only."""
    expr = sp.sympify(expr)
    if not (expr.free_symbols & params):
        return []
    _, den = sp.fraction(sp.together(expr))
    _, factors = sp.factor_list(sp.expand(den))
    return [f for f, _ in factors if f.free_symbols and f.free_symbols <= params]


def _divides(f, g, gens) -> bool:
    try:
        return sp.rem(sp.Poly(g, *gens), sp.Poly(f, *gens)).is_zero
    except sp.PolynomialError:
        return sp.simplify(sp.cancel(g / f)).is_polynomial(*gens)


def _holds(assumption, point) -> bool | None:
    """Whether an assumption holds at a point; for ``Ne(g, 0)`` at an algebraic point (a
    root found by ``solve``, possibly with surds or the imaginary unit) g is expanded and,
    if that does not show 0, evaluated to 50 digits: sympy does not reduce a
    surd expression that equals 0 to 0 by itself."""
    if isinstance(assumption, sp.Ne) and assumption.rhs == 0:
        g = sp.expand(assumption.lhs.subs(point))
        if g == 0:
            return False
        if g.is_number:
            return abs(complex(g.evalf(50))) > 1e-30
        return None
    v = assumption.subs(point)
    return None if not isinstance(v, (bool, sp.logic.boolalg.BooleanAtom)) else bool(v)


def check_design(design, *, seed: int = 0, points: int = 3) -> list:
    """Problems found (empty list: the assumptions exclude every denominator's zeros)."""
    params = set(design.structure.model.parameters)
    if not params:
        return []
    rng = random.Random(seed)
    gens = sorted(params, key=str)
    nes = [a for a in design.assumptions
           if isinstance(a, sp.Ne) and a.rhs == 0 and a.lhs.free_symbols <= params]
    problems = []
    dens = []
    for where, e in reported_expressions(design):
        for f in parameter_factors(e, params):
            dens.append((where, f))
            if not any(_divides(f, a.lhs, gens) for a in nes):
                problems.append(f"{where}: denominator factor {f} is in no assumption"
                                f" (assumptions: {list(map(str, design.assumptions))})")
                continue
            # its zero set: solve f = 0 for one parameter, the others random
            s = sorted(f.free_symbols, key=str)[0]
            others = {p: sp.Rational(rng.randint(1, 97), rng.randint(1, 13))
                      for p in gens if p != s}
            roots = sp.solve(f.subs(others), s)
            for r in roots[:1]:
                point = dict(others)
                point[s] = r
                if all(_holds(a, point) is not False for a in nes):
                    problems.append(f"{where}: at {point} the denominator factor {f} vanishes"
                                    " but every assumption holds")
    # random points that satisfy the assumptions: every denominator nonzero
    for _ in range(points):
        for _try in range(50):
            point = {p: sp.Rational(rng.randint(-97, 97), rng.randint(1, 13)) for p in gens}
            if all(_holds(a, point) is not False for a in design.assumptions
                   if isinstance(a, sp.Basic)):
                break
        for where, f in dens:
            if f.subs(point) == 0:
                problems.append(f"{where}: the denominator factor {f} vanishes at {point},"
                                " where every assumption holds")
    return problems

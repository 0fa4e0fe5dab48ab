"""Range analysis (METHOD §4): exact ranges of expressions over a domain, on which the
nonlinear checks (Lipschitz constant, monotonicity) and the interval observers' sign
tests stand.

A *domain* is a set of sympy relations (``x1 >= x2``, ``x3 >= 0``) in some base
variables. ``definitions`` maps further symbols to affine expressions in the base
variables (``xs1 → x1``, ``y1 → x2`` for a reduced model with x* = Φ x, y = H x), and
``ranges`` gives boxes for symbols the domain does not constrain (inputs).

How a range is obtained
-----------------------
An expression is split into additive groups by the *atoms* it depends on — the maximal
affine subexpressions (the arguments A_j x of the nonlinear functions; a bare variable
is its own atom). The range of an atom over the domain is a linear program, solved by
scipy and then certified in exact rational arithmetic (a dual certificate for the
optimum, a ray for an unbounded side). A group that depends on a single atom t is a
univariate function g(t); its range over the open interval of t is computed exactly by
sympy (``function_range``) and cross-checked against samples. Groups in several atoms
are enclosed by interval arithmetic (``AccumBounds``). The range of an expression is then

- ``exact`` when it is a constant plus at most one single-atom group (the image of
  the domain is the whole atom interval),
- ``enclosure`` when it is a rigorous outer bound (a sum of independently bounded
  groups),
- ``sampled`` when sympy could not bound a group and only samples are available.

:meth:`RangeAnalyzer.group_point` and :meth:`RangeAnalyzer.blowup` find domain points
where a group approaches its bounds or grows without bound (the witnesses the
conditions report).
"""
from __future__ import annotations

import dataclasses
from fractions import Fraction

import numpy as np
import sympy as sp

from ..errors import UsageError
from ..numerics import rationalize_floats

__all__ = ["interval_scale", "range_sign", "format_number", "Domain", "RangeAnalyzer",
           "argument_range", "derivative_range"]

OO = sp.oo
_T = sp.Dummy("t_canonical", real=True)
_RANGE_CACHE: dict = {}  # (g(t), lo, hi) -> (lo, hi, kind): function_range is slow


# ================================================================== small helpers
def _num(v) -> sp.Expr:
    return sp.sympify(v)


def as_float(v) -> float:
    """A sympy number as a float, ±∞ for ±oo."""
    v = sp.sympify(v)
    if v is OO:
        return np.inf
    if v is -OO:
        return -np.inf
    return float(v)


def _rat(x: float) -> sp.Rational:
    f = Fraction(float(x)).limit_denominator(10 ** 9)
    return sp.Rational(f.numerator, f.denominator)


def affine_parts(e, syms=None):
    """(coefficients {symbol: number}, constant) if e is affine with numeric
    coefficients and not constant, else None."""
    if not isinstance(e, sp.Expr):
        return None
    fs = e.free_symbols
    if not fs:
        return None
    coeffs = {}
    for s in fs:
        c = sp.diff(e, s)
        if c.free_symbols or not c.is_number:
            return None
        if c != 0:
            coeffs[s] = c
    if not coeffs:
        return None
    const = sp.expand(e - sum(c * s for s, c in coeffs.items()))
    if const.free_symbols:
        return None
    return coeffs, const


def interval_scale(c, a):
    c = sp.sympify(c)
    if c == 0:
        return (sp.Integer(0), sp.Integer(0))
    lo, hi = c * a[0], c * a[1]
    return (lo, hi) if c > 0 else (hi, lo)


def range_sign(lo, hi) -> str:
    if lo == 0 and hi == 0:
        return "0"
    if bool(lo >= 0):
        return "+"
    if bool(hi <= 0):
        return "-"
    return "±"


def format_number(v) -> str:
    v = sp.sympify(v)
    if v in (OO, -OO):
        return "∞" if v is OO else "−∞"
    if v.is_Rational:
        return str(v)
    return f"{float(v):.6g}"


# ================================================================== the domain
class Domain:
    """Linear constraints G v ≥ h in base variables, exact LP ranges, sample points.

    Strict inequalities are taken as their closures (ranges and suprema do not change).
    Nonlinear relations are only checked at sample points; the LP ranges then cover a
    superset of the domain (still valid upper bounds)."""

    def __init__(self, relations, definitions, ranges, extra_symbols):
        self.definitions = {sp.sympify(k): sp.sympify(v) for k, v in (definitions or {}).items()}
        rels = list(relations or ())
        base = set()
        for r in rels:
            if not isinstance(r, sp.core.relational.Relational):
                raise UsageError(f"domain relation {r!r} is not a sympy relation")
            base |= r.free_symbols
        for v in self.definitions.values():
            base |= v.free_symbols
        ranges = {sp.sympify(k): v for k, v in (ranges or {}).items()}
        base |= set(ranges)
        base |= set(extra_symbols) - set(self.definitions)
        self.base = sorted(base, key=str)
        self.index = {s: i for i, s in enumerate(self.base)}
        rows, h, self.nonlinear = [], [], []
        self.text = []
        for r in rels:
            if isinstance(r, sp.Eq):
                parts = [(r.lhs - r.rhs, 1), (r.rhs - r.lhs, 1)]
            elif isinstance(r, (sp.GreaterThan, sp.StrictGreaterThan)):
                parts = [(r.lhs - r.rhs, 1)]
            elif isinstance(r, (sp.LessThan, sp.StrictLessThan)):
                parts = [(r.rhs - r.lhs, 1)]
            else:
                raise UsageError(f"domain relation {r} is not =, ≥, ≤, > or <")
            self.text.append(str(r))
            for g, _ in parts:
                g = sp.expand(g)
                aff = affine_parts(g)
                if aff is None:
                    if g.free_symbols:
                        self.nonlinear.append(sp.lambdify(self.base, g, "numpy"))
                        continue
                    if bool(g < 0):
                        raise UsageError(f"domain relation {r} is never satisfied")
                    continue
                coeffs, const = aff
                rows.append([sp.sympify(coeffs.get(s, 0))
                             for s in self.base])
                h.append(-const)
        for s, (lo, hi) in ranges.items():
            i = self.index[s]
            if lo is not None and _num(lo) != -OO:
                rows.append([sp.Integer(1 if j == i else 0) for j in range(len(self.base))])
                h.append(_num(lo))
            if hi is not None and _num(hi) != OO:
                rows.append([sp.Integer(-1 if j == i else 0) for j in range(len(self.base))])
                h.append(-_num(hi))
            self.text.append(f"{lo} ≤ {s} ≤ {hi}")
        for row in rows:
            for c in row:
                if not c.is_number:
                    raise UsageError(f"domain coefficient {c} is not a number (substitute parameters)")
        self.G = sp.Matrix(rows) if rows else sp.zeros(0, len(self.base))
        self.h = sp.Matrix(h) if h else sp.zeros(0, 1)
        self.Gf = np.array(self.G.tolist(), dtype=float).reshape(self.G.rows, len(self.base))
        self.hf = np.array([float(v) for v in self.h], dtype=float)
        self.describe = ", ".join(self.text) if self.text else "all of Rⁿ"
        self._x0 = None
        self._cache = {}

    # ---------------------------------------------------------- substitution
    def to_base(self, e):
        return sp.sympify(e).xreplace(self.definitions)

    def lam(self, exprs):
        return sp.lambdify(self.base, [self.to_base(e) for e in exprs], "numpy")

    def feasible(self, X, tol=1e-9):
        """Boolean mask of points (rows of X) in the domain."""
        X = np.atleast_2d(X)
        ok = np.ones(X.shape[0], dtype=bool)
        if self.Gf.shape[0]:
            ok &= np.all(X @ self.Gf.T - self.hf >= -tol * (1 + np.abs(self.hf)), axis=1)
        for g in self.nonlinear:
            with np.errstate(all="ignore"):
                ok &= np.asarray(g(*X.T), dtype=float) >= -tol
        return ok

    # ---------------------------------------------------------- linear programs
    def _linprog(self, c, A_eq=None, b_eq=None, bounds=None, homogeneous=False):
        from scipy.optimize import linprog
        n = len(self.base)
        A_ub = -self.Gf if self.Gf.shape[0] else None
        b_ub = (np.zeros_like(self.hf) if homogeneous else -self.hf) if self.Gf.shape[0] else None
        return linprog(c, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq,
                       bounds=bounds or [(None, None)] * n, method="highs")

    def linear_range(self, e):
        """Exact (lo, hi, certified) of an affine expression over the domain's linear
        constraints (nonlinear relations are ignored: an outer range)."""
        e = sp.expand(self.to_base(e))
        key = ("range", e)
        if key in self._cache:
            return self._cache[key]
        aff = affine_parts(e)
        if aff is None:
            if not e.free_symbols:
                res = (e, e, True)
                self._cache[key] = res
                return res
            raise UsageError(f"{e} is not affine in the domain's variables")
        coeffs, const = aff
        c = sp.Matrix([coeffs.get(s, 0) for s in self.base])
        lo, clo = self._opt(c, 1)
        hi, chi = self._opt(c, -1)
        res = (lo + const if lo not in (OO, -OO) else lo, hi + const if hi not in (OO, -OO) else hi,
               clo and chi)
        self._cache[key] = res
        return res

    def _opt(self, c, sense):
        """min (sense=1) or max (sense=−1) of c·v; (value, certified)."""
        n = len(self.base)
        cs = c * sense
        cf = np.array([float(v) for v in cs])
        if not np.any(cf):
            return sp.Integer(0), True
        if self.G.rows == 0:
            return (-OO if sense == 1 else OO), True
        res = self._linprog(cf)
        if res.status == 2:
            raise UsageError(f"the domain {self.describe} is empty")
        if res.status == 3:
            # certify a ray d: G d ≥ 0, c·d < 0
            r2 = self._linprog(cf, bounds=[(-1, 1)] * n, homogeneous=True)
            ok = False
            if r2.status == 0 and r2.fun < -1e-12:
                d = sp.Matrix([_rat(v) for v in r2.x])
                ok = all(v >= 0 for v in self.G * d) and (cs.T * d)[0, 0] < 0
            return (-OO if sense == 1 else OO), ok
        if res.status != 0:  # pragma: no cover - numerical trouble
            return _rat(res.fun * sense), False
        # dual certificate: y ≥ 0, Gᵀ y = c·sense  ⇒  min ≥ hᵀ y;  primal x feasible ⇒ min ≤ c·x
        y = sp.Matrix([_rat(-v) for v in res.ineqlin.marginals])
        x = sp.Matrix([_rat(v) for v in res.x])
        dual_ok = all(v >= 0 for v in y) and (self.G.T * y - cs).applyfunc(rationalize_floats) == sp.zeros(n, 1)
        primal_ok = all(v >= 0 for v in (self.G * x - self.h))
        if dual_ok and primal_ok:
            lo = (self.h.T * y)[0, 0]
            up = (cs.T * x)[0, 0]
            if lo == up:
                return lo * sense, True
        if dual_ok:
            return (self.h.T * y)[0, 0] * sense, False
        # try the active set exactly
        act = [i for i in range(self.G.rows)
               if abs(self.Gf[i] @ res.x - self.hf[i]) <= 1e-7 * (1 + abs(self.hf[i]))]
        if act:
            GA = self.G.extract(act, list(range(n)))
            ys = sp.symbols(f"_y0:{len(act)}")
            sol = sp.linsolve((GA.T, cs), *ys)
            for s in sol:
                s = [v.subs({k: 0 for k in ys}) for v in s]
                if all(v >= 0 for v in s):
                    val = sum(self.h[i] * v for i, v in zip(act, s))
                    return val * sense, True
        return _rat(res.fun) * sense, False

    def point_with(self, targets):
        """A domain point (numpy, base order) with affine expressions at given values,
        as deep inside the domain as the targets allow; None if infeasible."""
        n = len(self.base)
        A_eq, b_eq = [], []
        for e, v in targets:
            aff = affine_parts(sp.expand(self.to_base(e)))
            if aff is None:
                continue
            coeffs, const = aff
            A_eq.append([float(coeffs.get(s, 0)) for s in self.base] + [0.0])
            b_eq.append(float(v) - float(const))
        m = self.Gf.shape[0]
        norms = np.linalg.norm(self.Gf, axis=1) if m else np.zeros(0)
        from scipy.optimize import linprog
        c = np.zeros(n + 1)
        c[-1] = -1.0  # maximise the slack s
        A_ub = np.hstack([-self.Gf, norms[:, None]]) if m else None
        b_ub = -self.hf if m else None
        bounds = [(None, None)] * n + [(0, 1)]
        res = linprog(c, A_ub=A_ub, b_ub=b_ub, A_eq=np.array(A_eq) if A_eq else None,
                      b_eq=np.array(b_eq) if b_eq else None, bounds=bounds, method="highs")
        if res.status != 0:
            return None
        x = res.x[:n]
        return x if self.feasible(x[None, :])[0] else None

    def interior_point(self):
        if self._x0 is None:
            x = self.point_with([])
            if x is None:
                raise UsageError(f"the domain {self.describe} is empty")
            self._x0 = x
        return self._x0

    def samples(self, count, rng):
        """Domain points: random, near every face, and far along the recession cone."""
        n = len(self.base)
        x0 = self.interior_point()
        pts = [x0[None, :]]
        d = rng.normal(size=(count, n))
        d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
        r = 10.0 ** rng.uniform(-4, 3, size=(count, 1))
        pts.append(x0 + d * r)
        from scipy.optimize import linprog
        eps = 10.0 ** -np.arange(1, 11)
        for i in range(self.Gf.shape[0]):  # approach every face
            res = linprog(self.Gf[i], A_ub=-self.Gf, b_ub=-self.hf,
                          bounds=[(v - 10, v + 10) for v in x0], method="highs")
            if res.status == 0:
                xb = res.x
                pts.append(xb + eps[:, None] * (x0 - xb))
        for _ in range(8):  # far points
            c = rng.normal(size=n)
            res = linprog(c, A_ub=-self.Gf if self.Gf.shape[0] else None,
                          b_ub=np.zeros(self.Gf.shape[0]) if self.Gf.shape[0] else None,
                          bounds=[(-1, 1)] * n, method="highs")
            if res.status == 0 and np.linalg.norm(res.x) > 1e-9:
                pts.append(x0 + np.array([1e1, 1e2, 1e4, 1e6])[:, None] * res.x)
        X = np.vstack(pts)
        return X[self.feasible(X)]


# ================================================================== range analysis
@dataclasses.dataclass
class _Group:
    atoms: tuple  # keys (normalised linear forms)
    func: sp.Expr  # in the atoms' dummies
    lo: object
    hi: object
    kind: str  # exact / enclosure / sampled


@dataclasses.dataclass
class _Entry:
    expr: sp.Expr
    const: sp.Expr
    groups: list
    lo: object
    hi: object
    kind: str


def _piecewise_range(f, t, lo, hi, function_range):
    """inf and sup of f over the open interval (lo, hi), exactly: sympy's function_range,
    on each piece between the zeros of the affine arguments of abs(·) and sign(·) in f
    (there abs(a) = ±a and sign(a) = ±1, so f is smooth and function_range can answer;
    e^(−|t|) and sign(t) e^(−|t|) are bounded exactly instead of from samples)."""
    atoms = [a for a in f.atoms(sp.Abs, sp.sign) if a.args[0].has(t)]
    if not atoms:
        r = function_range(f, t, sp.Interval.open(lo, hi))
        return r.inf, r.sup
    cuts = set()
    for a in atoms:
        arg = sp.expand(a.args[0])
        if not (arg.is_polynomial(t) and sp.degree(arg, t) == 1):
            raise ValueError("not an affine argument")
        r0 = sp.solve(arg, t)[0]
        if (lo == -OO or bool(r0 > lo)) and (hi == OO or bool(r0 < hi)):
            cuts.add(r0)
    ends = [lo] + sorted(cuts, key=float) + [hi]
    infs, sups = [], []
    for a, b in zip(ends[:-1], ends[1:]):
        mid = (sp.Integer(0) if (a == -OO and b == OO) else b - 1 if a == -OO
               else a + 1 if b == OO else (a + b) / 2)
        rep = {}
        for at in atoms:
            sg = sp.sign(at.args[0].subs(t, mid))
            rep[at] = sg * at.args[0] if isinstance(at, sp.Abs) else sg
        r = function_range(f.xreplace(rep), t, sp.Interval.open(a, b))
        infs.append(r.inf)
        sups.append(r.sup)
    return sp.Min(*infs), sp.Max(*sups)


class RangeAnalyzer:
    def __init__(self, dom: Domain, rng):
        self.dom = dom
        self.rng = rng
        self.atoms = {}  # key -> (dummy, lo, hi, certified)
        self._X = None

    def X(self):
        if self._X is None:
            self._X = self.dom.samples(300, self.rng)
        return self._X

    def _atom(self, e):
        aff = affine_parts(e)
        coeffs, const = aff
        syms = sorted(coeffs, key=str)
        c1 = coeffs[syms[0]]
        key = sp.expand(sum(coeffs[s] / c1 * s for s in syms))
        if key not in self.atoms:
            lo, hi, cert = self.dom.linear_range(key)
            self.atoms[key] = (sp.Dummy("t", real=True), lo, hi, cert)
        return key, c1, const

    def _collect(self, e, out):
        if not e.free_symbols:
            return
        if isinstance(e, sp.Expr) and affine_parts(e) is not None:
            out.add(e)
            return
        for a in e.args:
            self._collect(a, out)

    def entry(self, e) -> _Entry:
        e = sp.sympify(e)
        terms = sp.Add.make_args(sp.expand(e, deep=False))
        const = sp.Integer(0)
        groups = {}
        for term in terms:
            found = set()
            self._collect(term, found)
            if not found:
                const += term
                continue
            repl, keys = {}, set()
            for a in found:
                key, c1, c0 = self._atom(a)
                repl[a] = c1 * self.atoms[key][0] + c0
                keys.add(key)
            f = term.xreplace(repl)
            k = tuple(sorted(keys, key=str))
            groups[k] = groups.get(k, 0) + f
        out = []
        for k, f in groups.items():
            lo, hi, kind = self._group_range(k, f)
            out.append(_Group(k, f, lo, hi, kind))
        lo = hi = const
        kinds = set()
        for g in out:
            lo, hi = lo + g.lo, hi + g.hi
            kinds.add(g.kind)
        if "sampled" in kinds:
            kind = "sampled"
        elif len(out) <= 1 and kinds <= {"exact"}:
            kind = "exact"
        else:
            kind = "enclosure"
        return _Entry(e, const, out, sp.sympify(lo), sp.sympify(hi), kind)

    def _atom_values(self, keys, X):
        f = self.dom.lam(list(keys))
        with np.errstate(all="ignore"):
            return [np.asarray(v, dtype=float) * np.ones(X.shape[0]) for v in f(*X.T)]

    def _t_grid(self, lo, hi):
        lo_f, hi_f = as_float(lo), as_float(hi)
        eps = 10.0 ** -np.arange(1, 13)
        big = 10.0 ** np.arange(0, 13)
        if np.isfinite(lo_f) and np.isfinite(hi_f):
            w = hi_f - lo_f
            if w == 0:
                return np.array([lo_f])
            return np.concatenate([lo_f + w * eps, lo_f + w * np.linspace(0.01, 0.99, 99),
                                   hi_f - w * eps])
        if np.isfinite(lo_f):
            return np.concatenate([lo_f + eps, lo_f + big, lo_f + np.linspace(0.01, 10, 200)])
        if np.isfinite(hi_f):
            return np.concatenate([hi_f - eps, hi_f - big, hi_f - np.linspace(0.01, 10, 200)])
        return np.concatenate([-big, big, np.linspace(-10, 10, 401)])

    def _group_range(self, keys, f):
        dummies = [self.atoms[k][0] for k in keys]
        ranges = [(self.atoms[k][1], self.atoms[k][2]) for k in keys]
        if len(keys) == 1:
            canon = f.xreplace({dummies[0]: _T})
            ck = (canon, ranges[0][0], ranges[0][1])
            if ck not in _RANGE_CACHE:
                _RANGE_CACHE[ck] = self._range_1d(dummies[0], ranges[0], f)
            return _RANGE_CACHE[ck]
        return self._range_multi(keys, f, dummies, ranges)

    def _range_1d(self, t, rng_, f):
        from sympy.calculus.util import function_range
        if True:
            lo, hi = rng_
            grid = self._t_grid(lo, hi)
            try:
                with np.errstate(all="ignore"):
                    vals = np.asarray(sp.lambdify(t, f, "numpy")(grid), dtype=complex) * np.ones(grid.size)
            except Exception:  # noqa: BLE001 - not evaluable numerically
                return -OO, OO, "sampled"
            real = np.abs(vals.imag) <= 1e-12 * (1 + np.abs(vals.real))
            vals = vals.real[real & np.isfinite(vals.real)]
            try:
                if lo == hi:
                    v = f.subs(t, lo)
                    if v.is_finite:
                        return v, v, "exact"
                    raise ValueError
                rlo, rhi = _piecewise_range(f, t, lo, hi, function_range)
                if not (rlo.is_extended_real and rhi.is_extended_real):
                    raise ValueError
                tol = 1e-9
                flo, fhi = as_float(rlo), as_float(rhi)
                if vals.size and (np.any(vals < flo - tol * (1 + abs(flo) if np.isfinite(flo) else 1))
                                  or np.any(vals > fhi + tol * (1 + abs(fhi) if np.isfinite(fhi) else 1))):
                    raise ValueError  # sympy's range disagrees with the samples
                return rlo, rhi, "exact"
            except Exception:  # noqa: BLE001 - any failure: fall back to samples
                if not vals.size:
                    return -OO, OO, "sampled"
                return _rat(vals.min()), _rat(vals.max()), "sampled"
    def _range_multi(self, keys, f, dummies, ranges):
        """Several atoms: interval arithmetic, checked against samples."""
        X = self.X()
        tv = self._atom_values(keys, X)
        with np.errstate(all="ignore"):
            fv = np.asarray(sp.lambdify(dummies, f, "numpy")(*tv), dtype=float) * np.ones(X.shape[0])
        fv = fv[np.isfinite(fv)]
        try:
            sub = {}
            for t, (lo, hi) in zip(dummies, ranges):
                sub[t] = lo if lo == hi else sp.AccumBounds(lo, hi)
            r = f.xreplace(sub)
            if isinstance(r, sp.AccumBounds):
                rlo, rhi = r.min, r.max
            elif r.is_number and r.is_extended_real:
                rlo = rhi = r
            else:
                raise ValueError
            if fv.size and (np.any(fv < as_float(rlo) - 1e-9 * (1 + np.abs(fv)))
                            or np.any(fv > as_float(rhi) + 1e-9 * (1 + np.abs(fv)))):
                raise ValueError
            return rlo, rhi, "enclosure"
        except Exception:  # noqa: BLE001
            if not fv.size:
                return -OO, OO, "sampled"
            return _rat(fv.min()), _rat(fv.max()), "sampled"

    # ---------------------------------------------------------- witnesses
    def group_point(self, g: _Group, target: str):
        """Domain points where a single-atom group approaches its inf (target="lo")
        or sup ("hi"): list of (t value, point)."""
        if len(g.atoms) != 1:
            return []
        key = g.atoms[0]
        t, lo, hi, _ = self.atoms[key]
        grid = self._t_grid(lo, hi)
        with np.errstate(all="ignore"):
            vals = np.asarray(sp.lambdify(t, g.func, "numpy")(grid), dtype=float) * np.ones(grid.size)
        ok = np.isfinite(vals)
        if not ok.any():
            return []
        grid, vals = grid[ok], vals[ok]
        order = np.argsort(vals if target == "lo" else -vals)
        out = []
        for idx in order[:3]:
            x = self.dom.point_with([(key, grid[idx])])
            if x is not None:
                out.append((grid[idx], x))
        return out

    def blowup(self, g: _Group):
        """Sequence of (t, point) along which a single-atom group is unbounded."""
        key = g.atoms[0]
        t, lo, hi, _ = self.atoms[key]
        fn = sp.lambdify(t, g.func, "numpy")
        cands = []
        eps = 10.0 ** -np.arange(2, 11, 2)
        if as_float(lo) > -np.inf:
            cands.append(as_float(lo) + eps)
        if as_float(hi) < np.inf:
            cands.append(as_float(hi) - eps)
        big = 10.0 ** np.arange(2, 11, 2)
        cands += [(as_float(lo) if as_float(lo) > -np.inf else 0) + big,
                  (as_float(hi) if as_float(hi) < np.inf else 0) - big]
        best = None
        for seq in cands:
            with np.errstate(all="ignore"):
                v = np.abs(np.asarray(fn(seq), dtype=float)) * np.ones(seq.size)
            if np.all(np.isfinite(v)) and v[-1] > 10 * max(v[0], 1e-300):
                if best is None or v[-1] > best[1]:
                    best = (seq, v[-1])
        if best is None:
            return []
        out = []
        for tv in best[0]:
            x = self.dom.point_with([(key, tv)])
            if x is not None:
                out.append((tv, x))
        return out


# ================================================================== model level
def argument_range(model, row, domain=None):
    """Exact range (lo, hi) of A x over the model's domain (or ``domain``)."""
    m = model.substitute_parameters() if model.parameters else model
    dom = Domain(m.domain if domain is None else domain, None, None, set(m.states))
    if isinstance(row, (sp.MatrixBase, list, tuple)):
        e = (sp.Matrix(row).reshape(1, len(m.states)) * sp.Matrix(m.states))[0, 0]
    else:
        e = sp.sympify(row)
    lo, hi, _ = dom.linear_range(e)
    return lo, hi


def derivative_range(func, arg, lo, hi):
    """Range (lo, hi, kind) of dφ/ds over the open interval (lo, hi) of its argument s."""
    dom = Domain([], None, {arg: (lo, hi)}, {arg})
    an = RangeAnalyzer(dom, np.random.default_rng(0))
    en = an.entry(sp.diff(func, arg))
    return en.lo, en.hi, en.kind

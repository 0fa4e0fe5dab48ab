"""Certificates: a design's defining identities re-checked independently.

The synthesis code works on DomainMatrix elements and null-space members; this
module knows nothing of that. It takes the plant's matrices and the design's
matrices as plain sympy matrices, multiplies them out with ``sympy.Matrix``
arithmetic, and simplifies every residual entry (``cancel``, then ``simplify`` if
needed) to exactly zero — or, for float designs, measures the residual norms against
a stated tolerance. A design whose certificate fails is never returned.

Identities (METHOD §2)::

    Φ F − F* Φ − J* H = 0,   H* Φ − R* H = 0,   Φ G − G* = 0,
    Φ D − D* = 0,            Φ L = 0,           Φ C − C* = 0 (nonlinear)

with inputs, faults and disturbances in the outputs (y = H x + Gy u + Dy d + Ly ρ)::

    Φ G − J* Gy − G* = 0,    Φ D − J* Dy − D* = 0,    Φ L − J* Ly = 0,    R* Ly = 0,  Q Ly = 0
"""
from __future__ import annotations

import dataclasses

import numpy as np
import sympy as sp

from ...errors import CertificateError
from ...model import is_identically_zero
from ...numerics import as_rational, from_rational, number_field, readable

__all__ = ["Identity", "Certificate", "certify_reduced_model", "certify_design",
           "certify_against_model", "MODEL_PREFIX"]


@dataclasses.dataclass(frozen=True)
class Identity:
    """One identity: its name, whether it holds, and the evidence."""

    name: str
    holds: bool
    residual: str  # "0" (exact) or the residual norm (float)


@dataclasses.dataclass(frozen=True)
class Certificate:
    identities: tuple
    exact: bool
    tolerance: float | None = None

    @property
    def passed(self) -> bool:
        return all(i.holds for i in self.identities)

    def summary(self) -> str:
        mark = "exactly zero" if self.exact else f"below tolerance {self.tolerance:.1e}"
        return "; ".join(i.name for i in self.identities) + f": {mark}" if self.passed else \
            "FAILED: " + "; ".join(f"{i.name} (residual {i.residual})"
                                   for i in self.identities if not i.holds)


def _is_zero(e) -> bool:
    if e == 0:
        return True
    e = sp.cancel(sp.together(e))
    if e == 0:
        return True
    if not e.free_symbols and e.has(sp.CRootOf):  # an algebraic number: decide in its field
        zero = _algebraic_is_zero(e)
        if zero is not None:
            return zero
    return sp.simplify(e) == 0


def _algebraic_is_zero(e):
    """Exact zero test of a constant built from ``CRootOf`` roots (irrational λ of the Jordan
    form; ``simplify`` of such expressions takes minutes). Nonzero when a 50-digit
    evaluation is clearly away from 0. Zero when, with every root r_i of a polynomial p
    replaced by a symbol t_i, the numerator reduces to 0 modulo the Cauchy modules of p
    (p(t_1), p[t_1, t_2], p[t_1, t_2, t_3], … — relations every set of distinct roots
    satisfies; their leading terms are pure powers of distinct t_i, so they are a
    Groebner basis); else (dependent roots, e.g. of a cyclic cubic) in the number field
    QQ(roots). None when none of these decides."""
    if abs(complex(e.evalf(50))) > 1e-30:
        return False
    groups: dict = {}
    for r in sorted(e.atoms(sp.CRootOf), key=lambda r: (str(r.expr), r.index)):
        groups.setdefault(r.expr, []).append(r)
    subs, modules, gens = {}, [], []
    for expr, roots in groups.items():
        x = roots[0].poly.gen
        ts = [sp.Dummy(f"t{i}") for i in range(len(roots))]
        f = [expr.subs(x, ts[0])]
        for j in range(1, len(roots)):  # divided differences: p[t_1, …, t_(j+1)]
            prev = f[-1]
            f.append(sp.cancel((prev.subs(ts[j - 1], ts[j]) - prev) / (ts[j] - ts[j - 1])))
        subs.update(zip(roots, ts))
        modules += [sp.expand(m) for m in f]
        gens += ts
    num = sp.expand(sp.fraction(sp.together(e.xreplace(subs)))[0])
    if num == 0:
        return True
    try:
        _, rem = sp.reduced(num, modules, *reversed(gens), order="lex")
    except sp.polys.polyerrors.PolynomialError:  # pragma: no cover - not a polynomial
        return None
    if sp.expand(rem) == 0:
        return True
    try:  # the roots are dependent (e.g. a cyclic cubic): compute in the number field
        K = number_field(tuple(subs))  # the roots (the keys)
        return bool(K.is_zero(K.from_sympy(e)))
    except Exception:  # pragma: no cover - sympy could not build the field
        return None


def _exact_identity(name: str, residual) -> Identity:
    if isinstance(residual, _Q):  # rational: zero or not, no simplification to do
        if residual.q.is_zero_matrix:
            return Identity(name, True, "0")
        return Identity(name, False, readable(next(e for e in from_rational(residual.q) if e != 0)))
    bad = [e for e in residual if not _is_zero(e)]
    if not bad:
        return Identity(name, True, "0")
    return Identity(name, False, readable(sp.simplify(bad[0])))


def certify_reduced_model(*, F, G, H, C, D, L, Phi, F_star, J_star, R_star, H_star,
                          G_star, D_star, C_star=None, exact: bool = True,
                          tolerance: float = 1e-9, raise_on_failure: bool = True) -> Certificate:
    """Re-check Φ F = F*Φ + J*H, H*Φ = R*H, ΦG = G*, ΦD = D*, ΦL = 0 (and ΦC = C*).

    Exact mode: every residual entry simplifies to 0. Float mode: each residual's
    Frobenius norm is below ``tolerance`` times the norm of the terms it compares.
    Raises :class:`CertificateError` on failure unless ``raise_on_failure`` is False.
    """
    pairs = [
        ("Phi F - F* Phi - J* H", lambda M: M["Phi"] * M["F"] - M["F_star"] * M["Phi"] - M["J_star"] * M["H"],
         lambda M: [M["Phi"] * M["F"], M["F_star"] * M["Phi"], M["J_star"] * M["H"]]),
        ("H* Phi - R* H", lambda M: M["H_star"] * M["Phi"] - M["R_star"] * M["H"],
         lambda M: [M["H_star"] * M["Phi"], M["R_star"] * M["H"]]),
        ("Phi G - G*", lambda M: M["Phi"] * M["G"] - M["G_star"], lambda M: [M["Phi"] * M["G"], M["G_star"]]),
        ("Phi D - D*", lambda M: M["Phi"] * M["D"] - M["D_star"], lambda M: [M["Phi"] * M["D"], M["D_star"]]),
        ("Phi L", lambda M: M["Phi"] * M["L"], lambda M: [M["Phi"], M["L"]]),
    ]
    if C_star is not None:
        pairs.append(("Phi C - C*", lambda M: M["Phi"] * M["C"] - M["C_star"],
                      lambda M: [M["Phi"] * M["C"], M["C_star"]]))
    mats = dict(F=F, G=G, H=H, C=C, D=D, L=L, Phi=Phi, F_star=F_star, J_star=J_star,
                R_star=R_star, H_star=H_star, G_star=G_star, D_star=D_star, C_star=C_star)
    ids = []
    if exact:
        M = {k: sp.Matrix(v) for k, v in mats.items() if v is not None}
        for name, res, _ in pairs:
            ids.append(_exact_identity(name, res(M)))
        cert = Certificate(tuple(ids), True, None)
    else:
        M = {k: np.asarray(sp.Matrix(v).evalf() if isinstance(v, sp.MatrixBase) else v, dtype=float)
             for k, v in mats.items() if v is not None}
        M = {k: np.atleast_2d(v) for k, v in M.items()}
        Mw = {k: _Arr(v) for k, v in M.items()}
        for name, res, terms in pairs:
            r = res(Mw).a
            scale = max([np.linalg.norm(t.a) for t in terms(Mw)] + [1.0])
            rel = float(np.linalg.norm(r) / scale) if r.size else 0.0
            ids.append(Identity(name, rel <= tolerance, f"{rel:.2e} (relative)"))
        cert = Certificate(tuple(ids), False, tolerance)
    if raise_on_failure and not cert.passed:
        raise CertificateError(f"design failed its certificate: {cert.summary()}")
    return cert


def _floats(M) -> np.ndarray:
    """A numeric matrix as a float array (exact rationals correctly rounded)."""
    M = sp.ImmutableMatrix(M)
    r, c = M.shape
    if r == 0 or c == 0:
        return np.zeros((r, c))
    rep = getattr(M, "_rep", None)
    dom = getattr(rep, "domain", None)
    if dom is not None and (dom.is_ZZ or dom.is_QQ or dom.is_RR):
        return np.array([float(v) for v in rep.to_list_flat()], dtype=float).reshape(r, c)
    return np.array(M.evalf(), dtype=float)


class _Q:
    """A rational matrix whose ``*`` and ``-`` are exact products in FLINT (a dense
    DomainMatrix over QQ): the certificate of a rational design costs milliseconds."""

    def __init__(self, q):
        self.q = q

    def __mul__(self, o):
        return _Q(self.q * o.q)

    def __sub__(self, o):
        return _Q(self.q - o.q)


def _exact_wrapper(mats):
    """``_Q`` when every matrix is rational, else ``sympy.Matrix``."""
    qs = [as_rational(v) for v in mats]
    if all(q is not None for q in qs):
        return lambda v: _Q(as_rational(v))
    return sp.Matrix


class _Arr:
    """numpy matrix wrapper so that ``*`` is the matrix product, as in sympy."""

    def __init__(self, a):
        self.a = np.asarray(a, dtype=float)

    def __mul__(self, o):
        return _Arr(self.a @ o.a)

    def __sub__(self, o):
        return _Arr(self.a - o.a)


def _cols(A) -> int:
    return A.a.shape[1] if isinstance(A, _Arr) else A.q.shape[1] if isinstance(A, _Q) else A.cols


class _ExactProducts:
    """Exact arithmetic of a certificate: products in FLINT when every matrix is rational
    (:class:`_Q`), else sympy; an identity holds when its residual is exactly zero."""

    exact = True

    def __init__(self, mats):
        self.wrap = _exact_wrapper(mats)

    @staticmethod
    def identity(name: str, residual, scale=None) -> Identity:
        return _exact_identity(name, residual)

    @staticmethod
    def certificate(ids) -> "Certificate":
        return Certificate(tuple(ids), True, None)


class _FloatProducts:
    """Float arithmetic of a certificate: products in numpy (sympy Float products cost
    minutes at n = 300); an identity holds when its residual's norm — absolute, or relative
    to ``scale`` when given — is at most ``tolerance``."""

    exact = False

    def __init__(self, tolerance: float):
        self.tolerance = tolerance

    @staticmethod
    def wrap(v) -> _Arr:
        return _Arr(_floats(v))

    def identity(self, name: str, residual, scale=None) -> Identity:
        r = residual.a
        if scale is None:
            rel = float(np.linalg.norm(r if r.size else np.zeros(1)))
            return Identity(name, rel <= self.tolerance, f"{rel:.2e}")
        rel = float(np.linalg.norm(r)) / scale if r.size else 0.0
        return Identity(name, rel <= self.tolerance, f"{rel:.2e} (relative)")

    def certificate(self, ids) -> "Certificate":
        return Certificate(tuple(ids), False, self.tolerance)


def _products(exact: bool, mats, tolerance: float):
    """The certificate's arithmetic, chosen once: exact over ``mats`` or float."""
    return _ExactProducts(mats) if exact else _FloatProducts(tolerance)


def certify_design(plant: dict, mats: dict, *, M=None, substitutions=(), decoupled: bool = True,
                   exact: bool = True, tolerance: float = 1e-9,
                   raise_on_failure: bool = True) -> Certificate:
    """Re-check every identity that applies to a design, from its matrices alone.

    ``plant``: F, G, H, C, D, L (sympy). ``mats``: the design's matrices; which identities
    are checked depends on which are present:

    - always ``Φ F − F* Φ − J* H`` (Jordan form: row i reads Φ_i F = λ_i Φ_i + J*_i H);
    - ``H* Φ − R* H`` when R*, H* are present; ``Φ G − G*``; ``Φ D − D*`` when D* is;
    - ``Φ L`` (decoupled) or ``Φ L − L*`` (interval observers, not decoupled);
    - ``Φ C − C*`` for nonlinear models;
    - ``M − H_z Φ − Q H`` for an estimated z = M x;
    - with feedthrough (``plant`` holds ``Gy``, ``Dy`` for the D columns, ``Ly`` for the L
      columns): ``Φ G − J* Gy − G*``, ``Φ D − J* Dy − D*``, ``Φ L − J* Ly``, ``R* Ly``,
      ``Q Ly``;
    - ``A_j − A*_1j Φ − A*_2j H`` for each argument substitution (A_j, A*_1j, A*_2j).
    """
    pr = _products(exact, list(plant.values()) + list(mats.values()) + (
        [M] if M is not None else []) + [A for _, *As in substitutions for A in As], tolerance)
    P = {k: pr.wrap(v) for k, v in plant.items()}
    X = {k: pr.wrap(v) for k, v in mats.items() if v is not None or pr.exact}
    mat = pr.wrap
    Phi = X["Phi"]
    J = X["J_star"]
    checks = [("Phi F - F* Phi - J* H", Phi * P["F"] - X["F_star"] * Phi - J * P["H"])]
    if "R_star" in X and "H_star" in X:
        checks.append(("H* Phi - R* H", X["H_star"] * Phi - X["R_star"] * P["H"]))
    if "G_star" in X and _cols(P["G"]):
        if "Gy" in P:
            checks.append(("Phi G - J* Gy - G*", Phi * P["G"] - J * P["Gy"] - X["G_star"]))
        else:
            checks.append(("Phi G - G*", Phi * P["G"] - X["G_star"]))
    if "D_star" in X and _cols(P["D"]):
        if "Dy" in P:
            checks.append(("Phi D - J* Dy - D*", Phi * P["D"] - J * P["Dy"] - X["D_star"]))
        else:
            checks.append(("Phi D - D*", Phi * P["D"] - X["D_star"]))
    if _cols(P["L"]):
        if decoupled and "Ly" in P:
            checks.append(("Phi L - J* Ly", Phi * P["L"] - J * P["Ly"]))
            if "R_star" in X:
                checks.append(("R* Ly", X["R_star"] * P["Ly"]))
            if "Q" in X:
                checks.append(("Q Ly", X["Q"] * P["Ly"]))
        elif decoupled:
            checks.append(("Phi L", Phi * P["L"]))
        elif "L_star" in X:
            checks.append(("Phi L - L*", Phi * P["L"] - X["L_star"]))
    if "C_star" in X and _cols(P["C"]):
        checks.append(("Phi C - C*", Phi * P["C"] - X["C_star"]))
    if M is not None:
        checks.append(("M - Hz Phi - Q H", mat(M) - X["Hz"] * Phi - X["Q"] * P["H"]))
    for j, A, A1, A2 in substitutions:
        checks.append((f"A_{j} - A*_1,{j} Phi - A*_2,{j} H",
                       mat(A) - mat(A1) * Phi - mat(A2) * P["H"]))
    cert = pr.certificate(pr.identity(name, res) for name, res in checks)
    if raise_on_failure and not cert.passed:
        raise CertificateError(f"design failed its certificate: {cert.summary()}")
    return cert


#: the prefix of the identities re-checked against the model's own equations
MODEL_PREFIX = "model: "


def _model_jacobians(model):
    """``(jacobians, outputs)``: ∂f/∂v and ∂h/∂v for v in (x, u, d, ρ) straight from the
    model's expressions — sympy's ``linear_eq_to_matrix``, nothing of the extraction —
    when f and h are linear (every coefficient free of the variables, no constant term),
    else None; ``outputs`` are h with the noise at 0 (and f with the process noise at 0).
    The output Jacobians are ``h`` (∂h/∂x) and ``hu``, ``hd``, ``hrho`` (the feedthrough
    Gy, Dy, Ly)."""
    from sympy.solvers.solveset import NonlinearError
    groups = {"x": model.states, "u": model.inputs, "d": model.faults,
              "rho": model.disturbances}
    noise0 = {w: 0 for w in model.noise}
    outs = [h.xreplace(noise0) for h in model.outputs]
    order = [s for syms in groups.values() for s in syms]
    try:  # process noise (Bw w) is not decoupled: the identities hold with w = 0
        A, b = sp.linear_eq_to_matrix([f.xreplace(noise0) for f in model.dynamics], order)
        Hm, c = sp.linear_eq_to_matrix(outs, order) if outs else (None, None)
    except NonlinearError:
        return None, outs
    if not (b.is_zero_matrix and (c is None or c.is_zero_matrix)):
        return None, outs  # a constant term: affine, checked on the equation itself
    jac, start = {}, 0
    for key, syms in groups.items():
        jac[key] = A[:, start:start + len(syms)]
        jac["h" if key == "x" else "h" + key] = Hm[:, start:start + len(syms)]
        start += len(syms)
    return jac, outs


def certify_against_model(model, mats, task, *, nonlinear=(), observer_states=(),
                          exact: bool = True, tolerance: float = 1e-9,
                          approximate: bool = False) -> tuple:
    """A design's reduced model re-derived from the model's own right-hand side f and
    outputs h (noise at 0, in f and h), not from the extracted matrices::

        Φ f(x, u, d, ρ) − F* Φ x − J* h(x) − G* u − C* Ψ*(Φ x, h(x), u) − D* d_T − L* ρ_B ≡ 0
        R* h(x) − H* Φ x ≡ 0,        M x − H_z Φ x − Q h(x) ≡ 0

    with d_T the detected or estimated inputs (D*), ρ_B the bounded ones (interval
    observers, L*), the faults the task assumes zero set to 0, and the decoupled inputs
    left in f (so Φ L = 0 is checked again; for an approximate design they are set to 0:
    its ‖Φ L‖ is reported separately). For a linear model the first identity is checked
    block by block, with the Jacobians of f and h: Φ ∂f/∂x − F*Φ − J* ∂h/∂x,
    Φ ∂f/∂u − G*, Φ ∂f/∂d − D*, Φ ∂f/∂ρ (or − L*). Exact designs are decided by
    :func:`~observer_cad.model.is_identically_zero` (or exact rational products); float
    designs by relative norms below ``tolerance``. Returns the identities (names start
    with :data:`MODEL_PREFIX`); the caller decides what a failure means.
    """
    m = dict(mats)
    jac, outs = _model_jacobians(model)
    targets, bounded, zero = _roles(model, m, task, approximate)
    if jac is not None and not nonlinear:
        blocks, plant, m = _linear_blocks(model, jac, m, task, targets, bounded, zero)
        return _linear_identities(blocks, plant, m, exact, tolerance)
    checks = _equation_checks(model, m, task, outs, targets, bounded, zero, nonlinear,
                              observer_states)
    out = []
    for name, terms in checks:
        total = terms[0]
        for t in terms[1:]:
            total = total - t
        bad, how = None, "0"
        for e, parts in zip(total, zip(*[list(t) for t in terms])):
            test = is_identically_zero(e, scale=parts, rtol=None if exact else tolerance)
            if not test.holds:
                bad = e
                break
            if not test.exact:
                how = test.how
        residual = how if bad is None else readable(sp.simplify(bad) if exact else bad)
        out.append(Identity(MODEL_PREFIX + name, bad is None, residual))
    return tuple(out)


def _roles(model, m, task, approximate):
    """The inputs D* is for (``targets``), those L* bounds (interval observers), and those
    set to zero: the faults the task assumes zero, the targets of a design without D*,
    and the decoupled ones of an approximate design (its ‖Φ L‖ is reported apart)."""
    by_name = {s.name: s for s in model.faults + model.disturbances}
    targets = [by_name[t] for t in task.targets] if m.get("D_star") is not None else []
    bounded = [by_name[t] for t in task.bounded] if m.get("L_star") is not None else []
    zero = [by_name[t] for t in task.assumed_zero if t in by_name]
    if m.get("D_star") is None:
        zero += [by_name[t] for t in task.targets]
    if approximate:
        zero += [by_name[t] for t in task.decoupled]
    return targets, bounded, set(zero)


def _linear_blocks(model, jac, m, task, targets, bounded, zero):
    """The block identities of a linear model (see :func:`_linear_identities`), the
    Jacobian blocks they read and the design's matrices (with M when z = M x is
    estimated): ``(blocks, plant, matrices)``."""
    d_rest = [s for s in model.faults if s not in zero and s not in targets]
    r_rest = [s for s in model.disturbances if s not in zero and s not in targets
              and s not in bounded]

    def column(s, out=""):
        return jac[out + "d"][:, model.faults.index(s)] if s in model.faults else \
            jac[out + "rho"][:, model.disturbances.index(s)]
    feed = any(not jac[k].is_zero_matrix for k in ("hu", "hd", "hrho") if jac[k].cols)
    blocks = [("Phi df/dx - F* Phi - J* dh/dx",
               [("Phi", "x"), ("F_star", "Phi"), ("J_star", "h")])]
    plant = {"x": jac["x"], "h": jac["h"]}
    if model.inputs:
        if feed:
            blocks.append(("Phi df/du - J* dh/du - G*",
                           [("Phi", "u"), ("J_star", "hu"), ("G_star", None)]))
            plant["hu"] = jac["hu"]
        else:
            blocks.append(("Phi df/du - G*", [("Phi", "u"), ("G_star", None)]))
        plant["u"] = jac["u"]
    if targets:
        plant["T"] = sp.Matrix.hstack(*[column(s) for s in targets])
        if feed:
            blocks.append(("Phi df/dd - J* dh/dd - D*",
                           [("Phi", "T"), ("J_star", "hT"), ("D_star", None)]))
            plant["hT"] = sp.Matrix.hstack(*[column(s, "h") for s in targets])
        else:
            blocks.append(("Phi df/dd - D*", [("Phi", "T"), ("D_star", None)]))
    if bounded:
        blocks.append(("Phi df/drho - L*", [("Phi", "B"), ("L_star", None)]))
        plant["B"] = sp.Matrix.hstack(*[column(s) for s in bounded])
    if d_rest or r_rest:
        plant["R"] = sp.Matrix.hstack(*[column(s) for s in d_rest + r_rest])
        if feed:
            plant["hR"] = sp.Matrix.hstack(*[column(s, "h") for s in d_rest + r_rest])
            blocks.append(("Phi df/d(decoupled) - J* dh/d(decoupled)",
                           [("Phi", "R"), ("J_star", "hR")]))
            if m.get("R_star") is not None:
                blocks.append(("R* dh/d(decoupled)", [("R_star", "hR")]))
            if m.get("Q") is not None:
                blocks.append(("Q dh/d(decoupled)", [("Q", "hR")]))
        else:
            blocks.append(("Phi df/d(decoupled)", [("Phi", "R")]))
    if m.get("R_star") is not None and m.get("H_star") is not None:
        blocks.append(("R* dh/dx - H* Phi", [("R_star", "h"), ("H_star", "Phi")]))
    if task.M is not None and m.get("Hz") is not None:
        blocks.append(("M - Hz Phi - Q dh/dx", [("M", None), ("Hz", "Phi"), ("Q", "h")]))
        m = dict(m, M=task.M)
    return blocks, plant, m


def _equation_checks(model, m, task, outs, targets, bounded, zero, nonlinear,
                     observer_states) -> list:
    """The identities on the model's own equations (nonlinear or affine models):
    ``(name, [A, B, …])`` for A − B − … ≡ 0, with Ψ* the design's substitutions."""
    Phi = sp.Matrix(m["Phi"])
    k = Phi.rows
    x = sp.Matrix(model.states)
    xs = list(observer_states) if observer_states else list(sp.symbols(f"xs1:{k + 1}"))
    ys = sp.symbols(f"y1:{len(outs) + 1}")
    sub = {s: 0 for s in zero}
    sub.update({w: 0 for w in model.noise})  # process noise is bounded, not decoupled
    f = sp.Matrix([sp.sympify(e).xreplace(sub) for e in model.dynamics])
    outs = [sp.sympify(e).xreplace(sub) for e in outs]
    z = dict(zip(xs, list(Phi * x)))
    z.update(dict(zip(ys, outs)))
    h = sp.Matrix(outs)
    # the residual's identity reads the outputs without the inputs and the detected
    # faults (r = R* (y − Gy u) − H* x* has R* Dy d as its direct fault term)
    known0 = {s: 0 for s in list(model.inputs) + list(targets)}
    h_r = sp.Matrix([e.xreplace(known0) for e in outs])
    terms = [Phi * f, sp.Matrix(m["F_star"]) * Phi * x, sp.Matrix(m["J_star"]) * h]
    if model.inputs:
        terms.append(sp.Matrix(m["G_star"]) * sp.Matrix(model.inputs))
    if targets:
        terms.append(sp.Matrix(m["D_star"]) * sp.Matrix(targets))
    if bounded:
        terms.append(sp.Matrix(m["L_star"]) * sp.Matrix(bounded))
    if m.get("C_star") is not None:
        Cs = sp.Matrix(m["C_star"])
        psi = {ns.index: ns.function.xreplace(z) for ns in nonlinear}
        terms += [Cs[:, j] * psi[j + 1] for j in range(Cs.cols) if j + 1 in psi]
    checks = [("Phi f - F* Phi x - J* h - G* u - C* Psi* - D* d", terms)]
    if m.get("R_star") is not None and m.get("H_star") is not None:
        checks.append(("R* h - H* Phi x", [sp.Matrix(m["R_star"]) * h_r,
                                            sp.Matrix(m["H_star"]) * Phi * x]))
    if task.M is not None and m.get("Hz") is not None:
        checks.append(("M x - Hz Phi x - Q h", [sp.Matrix(task.M) * x,
                                                 sp.Matrix(m["Hz"]) * Phi * x,
                                                 sp.Matrix(m["Q"]) * h_r]))
    return checks


def _linear_identities(blocks, plant: dict, mats: dict, exact: bool, tolerance: float) -> tuple:
    """The block identities of :func:`certify_against_model` for a linear model. Each
    block is ``(name, [(design matrix, plant Jacobian or None), …])``: the first pair's
    product minus the others' is 0 (``None``: the design matrix alone; ``"Phi"`` as the
    plant key: the design's Φ on the right). Exact rational matrices multiply in FLINT,
    symbolic ones in sympy (each entry decided by ``is_identically_zero``), float designs
    in numpy (relative norm below ``tolerance``)."""
    pr = _products(exact, list(plant.values()) + [mats[a] for _, ps in blocks for a, _ in ps],
                   tolerance)
    P = {key: pr.wrap(v) for key, v in plant.items()}
    X = {key: pr.wrap(v) for key, v in mats.items() if v is not None}
    P["Phi"] = X["Phi"]
    out = []
    for name, pairs in blocks:
        terms = [X[a] * P[b] if b is not None else X[a] for a, b in pairs]
        total = terms[0]
        for t in terms[1:]:
            total = total - t
        scale = None
        if not pr.exact:  # relative to the size of the products without cancellation
            scale = max([1.0] + [float(np.linalg.norm(X[a].a)) * (
                float(np.linalg.norm(P[b].a)) if b is not None else 1.0) for a, b in pairs])
        out.append(pr.identity(MODEL_PREFIX + name, total, scale))
    return tuple(out)

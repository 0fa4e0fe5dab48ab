"""Interval observers with nonlinear terms, unknown inputs and full-state intervals
(METHOD §3; seed 002 §4, §6, §8).

The reduced model of a Jordan design is, with the noise-free outputs ỹ = H x = y − W w,

    x*' = f(x*, ỹ, u) + L* ρ + D* d,     f = F* x* + J* ỹ + G* u + C* Ψ*(x*, ỹ, u)

(x*(t+1) in discrete time), and z = H_z x* + Q ỹ. :func:`interval_observer_nonlinear`
runs two copies

    x̲*_i' = f_i(x̃, ỹ̲, u) + min (L* ρ + D* d)_i,     x̄*_i' = f_i(x̃', ỹ̄, u) + max (…)_i

where every argument is replaced by the bound that makes f_i smallest (largest):

- states x*_j, j ≠ i: x̲*_j where ∂f_i/∂x*_j ≥ 0, x̄*_j where ≤ 0 (the mixed-monotone
  embedding; with ∂f_i/∂x*_j ≥ 0 everywhere — the cooperative case of seed 002, F*
  Metzler and C*Ψ* monotone — both copies are plain copies). In continuous time
  x*_i itself stays x̲*_i (the comparison principle needs no sign there); in discrete
  time it follows its sign too, which for a linear F* is the F*⁺/F*⁻ split;
- outputs ỹ_k: the end of the noise box [y − max W w, y − min W w] given by the sign
  of ∂f_i/∂ỹ_k. This is the "∓ k* w*" margin of seed 002 §6 computed as the exact
  worst case over the noise box — valid without a Lipschitz constant (for the
  three-tank, f = u1 − √(x* − ỹ1) is increasing in ỹ1 but not Lipschitz at 0);
- the unknown inputs ρ, d and the process noise w (x' = … + Bw w, not decoupled: it
  enters the reduced model as Φ Bw w): the ⁺/⁻ split over their declared bounds.

The signs are proven on all of the observer's state space, not only on the plant's
domain: each nonlinear argument is clipped to its range over the domain (x1 − x2 ≥ 0
becomes √max(x1 − x2, 0)), which leaves the plant's equations unchanged on the domain
and makes the derivative of φ_j either φ_j' on its range or 0 — so the sign of
∂f_i/∂v = (F*, J*)_iv + Σ_j C*_ij ∂a_j/∂v · (range of φ_j' ∪ {0}) is decided by interval
arithmetic (:func:`observer_cad.synthesis.derivative_range`). When a row is not
sign-definite jointly, the linear part and every φ_j term are bounded separately
(needs φ_j monotone in its argument).

When that fails too (a Lipschitz but non-monotone φ_j: sin x*, exp(−|x1 − x2|)), the row
is bounded by the γ-shift (``decomposition="auto"``, the default): for each argument v
with ∂f_i/∂v ∈ [a, b], a < 0 < b, f_i + γ v (γ = −a) is nondecreasing, or f_i − γ v
(γ = b) nonincreasing, so

    f_i(…, v̲, …) − γ (v̄ − v̲) ≤ f_i ≤ f_i(…, v̄, …) + γ (v̄ − v̲)

— a mixed-monotone decomposition function from interval Jacobian bounds. The ranges must
be proven (not sampled) and finite. The width w = x̄* − x̲* then obeys w' ≤ M w + c
(discrete: w(t+1) ≤ M w(t) + c), and the observer is built only when M is provably stable
(α(M) < 0, resp. ρ(M) < 1; exact M-matrix test); otherwise InfeasibleDesignError names
every γ, M and α(M) / ρ(M). Both are listed as required conditions (METHOD §3).

Outputs: z̲ = H_z⁺ x̲* − H_z⁻ x̄* + Q y − max(Q W w), z̄ likewise.

The γ-shift decomposition lives in :mod:`._interval_decomposition`; full-state intervals
(measured states from y, the others from an interval observer) in :mod:`._full_state`.
"""
from __future__ import annotations

import dataclasses

import sympy as sp

from ..synthesis import Condition, Design
from ..errors import ModelError, UsageError
from ..model import PlantModel
from ._observer import Observer, output_symbols
from ..numerics import box_max, box_min, neg, pos, rationalize_floats
from ..analysis import (Domain, RangeAnalyzer, argument_range, derivative_range, format_number,
                        interval_scale, lipschitz, nonlinear_conditions, range_sign,
                        reduced_nonlinearity)
from ._interval_decomposition import decomposed_row, decomposition_conditions, interval_text
from ._interval_feedthrough import output_feedthrough

__all__ = ["interval_observer_nonlinear"]


def _work(model: PlantModel) -> PlantModel:
    return model.substitute_parameters() if model.parameters else model


def bounds_box(model, syms, what):
    """(lows, highs) of the declared bounds of ``syms``; a one-line ModelError naming the
    first symbol without bounds."""
    lo, hi = [], []
    for s in syms:
        if s not in model.bounds:
            raise ModelError(f"{model.where}: the interval observer needs bounds on {what} '{s}'"
                             f" (declare bounds={{{s}: (low, high)}} in the model)")
        a, b = model.bounds[s]
        lo.append(a)
        hi.append(b)
    return sp.Matrix(lo), sp.Matrix(hi)


def _clip(arg, lo, hi):
    e = arg
    if hi not in (sp.oo, -sp.oo):
        e = sp.Min(e, hi)
    if lo not in (sp.oo, -sp.oo):
        e = sp.Max(e, lo)
    return e


def _output_names(model, M):
    """Names of the bounded outputs: the state's name when a row of M is a unit
    vector, else z / z1, z2, …"""
    names = []
    for i in range(M.rows):
        row = list(M[i, :])
        nz = [j for j, v in enumerate(row) if v != 0]
        if len(nz) == 1 and row[nz[0]] == 1:
            names.append(str(model.states[nz[0]]))
        else:
            names.append("z" if M.rows == 1 else f"z{i + 1}")
    return names


@dataclasses.dataclass(frozen=True)
class _Reduced:
    """The reduced model an interval observer bounds (module docstring): its symbols
    (x*, the measured y, the noise-free ỹ, u, the two copies x̲*, x̄*), matrices, the
    unknown inputs' box through Φ [L D], the noise box of ỹ − y, and the nonlinear
    terms on their clipped extension."""

    time: str
    k: int
    l: int
    Fs: sp.Matrix
    Js: sp.Matrix
    Gs: sp.Matrix
    Phi: sp.Matrix
    Hz: sp.Matrix
    Q: sp.Matrix
    H: sp.Matrix
    W: sp.Matrix
    xs: list
    ys: list  # the measured outputs read: y, or y − Gy u with output feedthrough
    yt: list
    us: list
    xl: list
    xu: list
    unk: list  # unknown inputs entering the reduced model
    Bu: sp.Matrix  # Φ [L D] restricted to them
    ulo: sp.Matrix | None
    uhi: sp.Matrix | None
    bmin: sp.Matrix  # min / max of Bu times the unknown inputs, per row
    bmax: sp.Matrix
    wlo: sp.Matrix  # the noise box
    whi: sp.Matrix
    off_lo: sp.Matrix  # ỹ − y = −W w ∈ [off_lo, off_hi]
    off_hi: sp.Matrix
    terms: list  # (j, C*_col, arg (in xs, yt), clipped arg, phi(s), s, φ' range (lo, hi, kind))
    args_info: list  # (j, argument text, its range (lo, hi), φ' range (lo, hi, kind))
    through: tuple = ()  # faults, disturbances in the outputs read (columns of W past w)

    def f_row(self, i, xv, yv):
        """f_i at states xv, outputs yv (lists of expressions)."""
        k, l, us = self.k, self.l, self.us
        sub = dict(zip(self.xs, xv))
        sub.update(dict(zip(self.yt, yv)))
        e = sum((self.Fs[i, j] * xv[j] for j in range(k)), sp.Integer(0))
        e += sum((self.Js[i, m] * yv[m] for m in range(l)), sp.Integer(0))
        e += sum((self.Gs[i, m] * us[m] for m in range(len(us))), sp.Integer(0))
        for (_, ccol, _, carg, fn, s, _) in self.terms:
            if ccol[i] != 0:
                e += ccol[i] * fn.xreplace({s: carg.xreplace(sub)})
        return e

    def d_range(self, i, v, only=None):
        """Range of ∂f_i/∂v (v a state or ỹ symbol) on the clipped extension."""
        if v in self.xs:
            lin = self.Fs[i, self.xs.index(v)]
        else:
            lin = self.Js[i, self.yt.index(v)]
        lo = hi = sp.sympify(lin) if only is None else sp.Integer(0)
        kinds = set()
        for (j, ccol, arg, _, _, _, (plo, phi_, pkind)) in self.terms:
            if only is not None and j != only:
                continue
            c = ccol[i] * sp.diff(arg, v)
            if c == 0:
                continue
            a, b = interval_scale(c, (plo, phi_))
            lo, hi = lo + a, hi + b
            kinds.add(pkind)
        return sp.sympify(lo), sp.sympify(hi), kinds


@dataclasses.dataclass(frozen=True)
class _Row:
    """How row i is bounded: the lower and upper right-hand sides (before the unknown
    inputs' box is added), the sign of ∂f_i/∂v per argument, how (``"joint"``,
    ``"per-term"``, ``"decomposed"``), the noise margin's text, the conditions a user
    margin adds, the γ-shifts, whether some sign is known from samples only."""

    lower: sp.Expr
    upper: sp.Expr
    signs: dict
    how: str
    margin: str
    notes: tuple = ()
    shifts: tuple = ()
    sampled: bool = False


def _check_design(design: Design) -> None:
    if design.matrices.Hz is None or design.matrices.Phi is None:
        raise UsageError("interval_observer_nonlinear needs a design with z = H_z x* + Q y"
                         " (design_jordan(..., observer='interval', estimate=...))")
    if design.symbolic:
        raise UsageError("interval_observer_nonlinear needs a numeric design (the signs of"
                         " its matrices decide the bounds); design without --symbolic")
    if design.matrices.K is not None:
        raise UsageError("interval_observer_nonlinear takes the reduced model without output"
                         " feedback (a Jordan design); this design has a gain K")


def _unknown_inputs(work, st, Phi, k):
    """The unknown inputs entering the reduced model through Φ L ρ + Φ D d + Φ Bw w (the
    process noise, bounded like them), their box and the per-row min / max of that term:
    (names, Φ [L D Bw] on them, lo, hi, min, max)."""
    unk = [s for s in work.disturbances] + [s for s in work.faults] + list(work.noise)
    Bu = (Phi * sp.Matrix.hstack(sp.Matrix(st.L), sp.Matrix(st.D), sp.Matrix(st.Bw))
          if unk else sp.zeros(k, 0))
    Bu = Bu.applyfunc(rationalize_floats)  # floats (float designs) only: exact stays exact
    used = [j for j in range(Bu.cols) if any(Bu[i, j] != 0 for i in range(k))]
    Bu = Bu.extract(list(range(k)), used) if used else sp.zeros(k, 0)
    unk = [unk[j] for j in used]
    ulo = uhi = None
    if unk:
        noise = set(work.noise)
        for what, syms in (("the unknown input", [s for s in unk if s not in noise]),
                           ("the process noise", [s for s in unk if s in noise])):
            bounds_box(work, syms, what)  # a missing bound named by its role
        ulo, uhi = bounds_box(work, unk, "the unknown input")
        bmin, bmax = box_min(Bu, ulo, uhi), box_max(Bu, ulo, uhi)
    else:
        bmin = bmax = sp.zeros(k, 1)
    return unk, Bu, ulo, uhi, bmin, bmax


def _noise_offsets(work, W, l, through=()):
    """The noise box and the range of ỹ − y = −W w: (w lo, w hi, offset lo, offset hi);
    with output feedthrough, W holds [W E] and ``through`` the faults and disturbances of
    E, bounded like the noise (see :mod:`._interval_feedthrough`)."""
    if W.cols:
        if through:  # a missing bound named by its role
            bounds_box(work, through, "the fault or disturbance in the outputs")
        wlo, whi = bounds_box(work, list(work.noise) + list(through), "noise")
        return wlo, whi, -box_max(W, wlo, whi), -box_min(W, wlo, whi)
    wlo = whi = sp.zeros(0, 1)
    off_lo = off_hi = sp.zeros(l, 1)
    return wlo, whi, off_lo, off_hi


def _nonlinear_terms(work, d, st, xs, yt, dom):
    """φ_j of every nonlinear term with its argument, the argument clipped to its range
    over the domain and the range of φ_j' on the clipped extension: (terms, args_info)
    as :class:`_Reduced` holds them."""
    terms, args_info = [], []
    if not d.nonlinear:
        return terms, args_info
    k, l = d.k, len(yt)
    Cs = sp.Matrix(d.matrices.C_star)
    in_ranges = {u: work.bounds[u] for u in work.inputs if u in work.bounds}
    for ns in d.nonlinear:
        t = st.terms[ns.index - 1]
        A1, A2 = sp.Matrix(ns.A1), sp.Matrix(ns.A2)
        arg = ((A1 * sp.Matrix(xs))[0, 0] if k else 0) + ((A2 * sp.Matrix(yt))[0, 0] if l else 0)
        lo, hi = argument_range(work, t.row, dom)
        plo, phi_, pkind = _derivative_range(t.function, t.argument, lo, hi, in_ranges)
        if lo != -sp.oo or hi != sp.oo:  # clipped outside the range: derivative 0 there
            plo, phi_ = sp.Min(plo, 0), sp.Max(phi_, 0)
        terms.append((ns.index, Cs[:, ns.index - 1], sp.expand(arg), _clip(arg, lo, hi),
                      t.function, t.argument, (plo, phi_, pkind)))
        args_info.append((ns.index, str(sp.expand(arg)), (lo, hi), (plo, phi_, pkind)))
    return terms, args_info


def _reduced(work: PlantModel, d: Design, dom) -> _Reduced:
    """The reduced model of a Jordan design as the interval observer needs it."""
    st = d.structure  # extracted once, by the design (parameters substituted)
    k, l = d.k, len(work.outputs)
    m = d.matrices
    Phi = sp.Matrix(m.Phi)
    ft = output_feedthrough(work, d)  # y − Gy u; faults, disturbances in y bounded like w
    W = sp.Matrix.hstack(sp.Matrix(st.W), ft.E) if ft.names else sp.Matrix(st.W)
    xs = list(d.observer_states) or list(sp.symbols(f"xs1:{k + 1}"))
    yt = list(sp.symbols(f"ytilde1:{l + 1}"))  # noise-free outputs H x
    unk, Bu, ulo, uhi, bmin, bmax = _unknown_inputs(work, st, Phi, k)
    wlo, whi, off_lo, off_hi = _noise_offsets(work, W, l, ft.names)
    terms, args_info = _nonlinear_terms(work, d, st, xs, yt, dom)
    return _Reduced(
        time=work.time, k=k, l=l, Fs=sp.Matrix(m.F_star), Js=sp.Matrix(m.J_star),
        Gs=ft.Gs, Phi=Phi, Hz=sp.Matrix(m.Hz), Q=sp.Matrix(m.Q),
        H=sp.Matrix(st.H), W=W, xs=xs, ys=ft.measured, yt=yt,
        us=list(work.inputs), xl=list(sp.symbols(f"xl1:{k + 1}")),
        xu=list(sp.symbols(f"xu1:{k + 1}")), unk=unk, Bu=Bu, ulo=ulo, uhi=uhi, bmin=bmin,
        bmax=bmax, wlo=wlo, whi=whi, off_lo=off_lo, off_hi=off_hi, terms=terms,
        args_info=args_info, through=tuple(ft.names))


def _margin_mode(margin, k):
    """("exact" | "lipschitz" | "user", the user's margins per row or None)."""
    if margin is None or margin == "exact":
        return "exact", None
    if margin == "lipschitz":
        return "lipschitz", None
    vals = list(margin) if isinstance(margin, (list, tuple)) else [margin] * k
    if len(vals) != k:
        raise UsageError(f"margin: give one value or {k} values")
    return "user", [rationalize_floats(v) for v in vals]


def _state_ends(red: _Reduced, i, sg):
    """The copies' states row i is evaluated at for its lower and upper bound: x̲*_j where
    ∂f_i/∂x*_j is not ≤ 0, x̄*_j where it is (x*_i itself stays on its own copy in
    continuous time), and the reverse."""
    k, time, xs, xl, xu = red.k, red.time, red.xs, red.xl, red.xu
    lo_x = [xl[j] if (j == i and time == "continuous") or sg[xs[j]] != "-" else xu[j]
            for j in range(k)]
    hi_x = [xu[j] if (j == i and time == "continuous") or sg[xs[j]] != "-" else xl[j]
            for j in range(k)]
    return lo_x, hi_x


def _joint_exact(red: _Reduced, i, sg) -> tuple:
    """Row i sign-definite jointly: the exact worst case over the noise box (the ends of
    ỹ by the signs of ∂f_i/∂ỹ). Returns (lower, upper)."""
    lo_x, hi_x = _state_ends(red, i, sg)
    ys, yt, off_lo, off_hi = red.ys, red.yt, red.off_lo, red.off_hi
    lo_y = [ys[m] + (off_lo[m] if sg[yt[m]] != "-" else off_hi[m]) for m in range(red.l)]
    hi_y = [ys[m] + (off_hi[m] if sg[yt[m]] != "-" else off_lo[m]) for m in range(red.l)]
    return red.f_row(i, lo_x, lo_y), red.f_row(i, hi_x, hi_y)


def _joint_lipschitz(red: _Reduced, i, sg, rng) -> tuple:
    """Row i sign-definite in the states, the noise by f_i(x, y) ∓ Σ_k K_ik r_k with
    K_ik = sup|∂f_i/∂ỹ_k|. Returns (lower, upper, margin text)."""
    lo_x, hi_x = _state_ends(red, i, sg)
    l, yt, ys = red.l, red.yt, red.ys
    r = [sp.Max(abs(red.off_lo[m]), abs(red.off_hi[m])) for m in range(l)]
    K = []
    for m in range(l):
        lo, hi = rng[yt[m]]
        if lo == -sp.oo or hi == sp.oo:
            raise UsageError(
                f"margin='lipschitz': ∂f{i + 1}/∂y{m + 1} is unbounded on the clipped"
                f" extension (range {interval_text(lo, hi)}): not Lipschitz in y; use the"
                " exact worst case (margin=None)")
        K.append(sp.Max(abs(lo), abs(hi)))
    mg = sum((K[m] * r[m] for m in range(l)), sp.Integer(0))
    text = f"Σ_k K_k r_k = {format_number(mg)} with K = {[format_number(v) for v in K]}"
    return red.f_row(i, lo_x, ys) - mg, red.f_row(i, hi_x, ys) + mg, text


def _joint_user(red: _Reduced, i, sg, mg) -> tuple:
    """Row i sign-definite in the states, the noise by the user's k* w* for the nonlinear
    part plus abs(J*) W w* for the linear one; a condition compares k* w* with the Lipschitz
    bound when there is one. Returns (lower, upper, margin text, condition)."""
    lo_x, hi_x = _state_ends(red, i, sg)
    W, wlo, whi = red.W, red.wlo, red.whi
    r = [sp.Max(abs(red.off_lo[m]), abs(red.off_hi[m])) for m in range(red.l)]
    Jw = (-red.Js[i, :] * W) if W.cols else sp.zeros(1, 0)
    jmin = box_min(Jw, wlo, whi)[0] if W.cols else 0
    jmax = box_max(Jw, wlo, whi)[0] if W.cols else 0
    # the Lipschitz bound of the nonlinear part in y, for comparison
    bound = _nonlinear_y_bound(red, i, r)
    name = f"row {i + 1}: the given margin k* w* = {mg} covers the noise through Ψ*"
    if bound is None:
        note = Condition(name, False, "not verifiable: C*Ψ* is not Lipschitz in y on the"
                         " clipped extension (√ at 0); the inclusion is not guaranteed — use"
                         " margin=None", "seed 002 §6", required=True)
    else:
        note = Condition(name, bool(mg >= bound), f"Lipschitz bound of the nonlinear part:"
                         f" Σ_k k*_k r_k = {format_number(bound)}", "seed 002 §6", required=True)
    return (red.f_row(i, lo_x, red.ys) + jmin - mg, red.f_row(i, hi_x, red.ys) + jmax + mg,
            f"user k* w* = {mg} plus |J*| W w*", note)


def _row(red: _Reduced, i, mode, user, decomposition) -> _Row:
    """Row i bounded: jointly by the signs of ∂f_i/∂v when they are definite, else term
    by term, else by the γ-shift decomposition (unless ``decomposition="none"``)."""
    sg, rng, sampled = {}, {}, False
    for v in red.xs + red.yt:
        lo, hi, kinds = red.d_range(i, v)
        rng[v] = (lo, hi)
        sampled = sampled or "sampled" in kinds
        sg[v] = range_sign(lo, hi)
    signs = {str(v): sg[v] for v in red.xs + red.yt}
    x_need = [v for j, v in enumerate(red.xs) if j != i or red.time == "discrete"]
    joint_ok = all(sg[v] in ("+", "-", "0") for v in x_need)
    y_ok = all(sg[v] in ("+", "-", "0") for v in red.yt)
    if mode == "exact" and joint_ok and y_ok:
        lo_e, hi_e = _joint_exact(red, i, sg)
        return _Row(lo_e, hi_e, signs, "joint", "exact worst case over the noise box (corners"
                    " by the signs of ∂f/∂ỹ)", sampled=sampled)
    if mode == "lipschitz" and joint_ok:
        lo_e, hi_e, text = _joint_lipschitz(red, i, sg, rng)
        return _Row(lo_e, hi_e, signs, "joint", text, sampled=sampled)
    if mode == "user" and joint_ok:
        lo_e, hi_e, text, note = _joint_user(red, i, sg, user[i])
        return _Row(lo_e, hi_e, signs, "joint", text, (note,), sampled=sampled)
    # ---- per-term fallback, then the γ-shift decomposition
    try:
        lo_e, hi_e = _per_term(red, i)
        return _Row(lo_e, hi_e, signs, "per-term", "exact worst case per term (each φ_j"
                    " monotone in its argument)", sampled=sampled)
    except _NotMonotone:
        if decomposition == "none":
            raise
    lo_e, hi_e, row_shifts = decomposed_row(red, i)
    return _Row(lo_e, hi_e, signs, "decomposed", "exact worst case over the noise box after"
                " the γ-shift", shifts=tuple(row_shifts), sampled=sampled)


def _bounded_outputs(work, red: _Reduced) -> tuple:
    """z̲ = H_z⁺ x̲* − H_z⁻ x̄* + Q y − max(Q W w), z̄ likewise: (names, outputs)."""
    Hz, Q = red.Hz, red.Q
    M = (Hz * red.Phi + Q * red.H).applyfunc(rationalize_floats)
    Hp, Hm = pos(Hz), neg(Hz)
    QW = Q * red.W
    if QW.cols:
        qmin, qmax = box_min(QW, red.wlo, red.whi), box_max(QW, red.wlo, red.whi)
    else:
        qmin = qmax = sp.zeros(Hz.rows, 1)
    xl, xu, ys = sp.Matrix(red.xl), sp.Matrix(red.xu), sp.Matrix(red.ys)
    zl = Hp * xl - Hm * xu + Q * ys - qmax
    zu = Hp * xu - Hm * xl + Q * ys - qmin
    names = _output_names(work, M)
    outputs = []
    for nm, a, b in zip(names, zl, zu):
        outputs += [(f"{nm}_lower", sp.expand(a)), (f"{nm}_upper", sp.expand(b))]
    return names, outputs


def _embedding_condition(red: _Reduced, rows, sampled_only) -> Condition:
    """The sign-definite (mixed-monotone) embedding, or which rows the γ-shift bounds."""
    time, xs = red.time, red.xs
    sign_text = "; ".join(f"row {i + 1}: " + ", ".join(f"∂f/∂{v} {s}" for v, s in r.signs.items())
                          for i, r in enumerate(rows))
    if time == "continuous":
        cname = "mixed-monotone embedding: ∂f_i/∂x*_j sign-definite for j ≠ i (cooperative when all ≥ 0)"
    else:
        cname = "monotone embedding: ∂f_i/∂x*_j sign-definite for all i, j (discrete time; F*⁺/F*⁻ split)"
    coop = all(s != "-" for i, r in enumerate(rows) for j, v in enumerate(xs)
               for s in [r.signs[str(v)]] if (j != i or time == "discrete"))
    decomposed = [i for i, r in enumerate(rows) if r.how == "decomposed"]
    if decomposed:
        rows_txt = ", ".join(str(i + 1) for i in decomposed)
        return Condition(cname, False, sign_text + f"; row(s) {rows_txt} not sign-definite"
                         " (± above): bounded by the γ-shift decomposition below instead",
                         "METHOD §3; seed 002 §4, §6", required=False)
    return Condition(cname, True, sign_text + ("; cooperative (all ≥ 0)" if coop else
                                               "; some ≤ 0: the bounds are mixed")
                     + (" — some signs from samples only, not proven" if sampled_only else ""),
                     "METHOD §3; seed 002 §4, §6")


def _nonlinear_part_conditions(work, d, dom, decomposed) -> list:
    """The METHOD §4 conditions of C*Ψ* (monotonicity noted as not needed when the
    observer rests on its embedding) and k*, its Lipschitz constant in y."""
    conds = []
    expr, rx, ry, defs = reduced_nonlinearity(work, d)
    for c in nonlinear_conditions(work, d, dom):
        if c.name.startswith("C*Ψ* monotone") and not c.holds:
            rests = ("the γ-shift decomposition and the stable comparison system above"
                     if decomposed else "the sign-definite embedding above")
            c = dataclasses.replace(c, detail=c.detail + f"; not needed here: the observer rests"
                                    f" on {rests} (seed 002 §6 asks for it as a sufficient"
                                    " condition)")
        conds.append(c)
    liy = lipschitz(list(expr), ry, dom, definitions=defs)
    conds.append(Condition(
        "k*: Lipschitz constant of C*Ψ* in y on the domain", bool(liy.lipschitz),
        liy.evidence + ("" if liy.lipschitz else
                        "; the ∓k* w* margin is therefore the exact worst case over the"
                        " noise box, which needs only monotonicity in y"),
        "seed 002 §6", required=False))
    return conds


def _conditions(work, d, red: _Reduced, rows, dom) -> list:
    """What the observer rests on, after the design's own conditions: the embedding (or
    the γ-shift decomposition and its stable comparison system), the clipped arguments,
    the nonlinear part, the noise, the unknown inputs, H_z ≥ 0, the user margins."""
    conds = list(d.conditions)
    sampled_only = any(r.sampled for r in rows)
    conds.append(_embedding_condition(red, rows, sampled_only))
    how_rows = [r.how for r in rows]
    decomposed = "decomposed" in how_rows
    if decomposed:
        shifts = [sh for r in rows for sh in r.shifts]
        conds += decomposition_conditions(red, how_rows, shifts, dom, sampled_only)
    for (j, arg, (lo, hi), (plo, phi_, pkind)) in red.args_info:
        conds.append(Condition(
            f"argument of Ψ*_{j} clipped to its domain range", True,
            f"{arg} ∈ {interval_text(lo, hi)} on the domain {', '.join(map(str, dom)) or 'Rⁿ'};"
            f" φ_{j}' on the clipped extension ∈ {interval_text(plo, phi_)} ({pkind})",
            "METHOD §3"))
    if d.nonlinear:
        conds += _nonlinear_part_conditions(work, d, dom, decomposed)
    conds.append(Condition(
        "noise through y bounded", True,
        "; ".join(f"row {i + 1} ({r.how}): {r.margin}" for i, r in enumerate(rows))
        + f"; ỹ − y ∈ [{list(red.off_lo)}, {list(red.off_hi)}]", "METHOD §3; seed 002 §4, §6"))
    if red.through:  # output feedthrough: the faults and disturbances in y, bounded like w
        conds.append(Condition(
            "inputs of the outputs bounded", True,
            f"ỹ = H x = y − Gy u − E e − W w; E = {red.W[:, len(work.noise):].tolist()} over"
            f" {[str(s) for s in red.through]} ∈ [{list(red.wlo[len(work.noise):, :])},"
            f" {list(red.whi[len(work.noise):, :])}], bounded with the noise",
            "METHOD §3 (output feedthrough)"))
    if red.unk:
        what = "Φ [L D Bw]" if set(red.unk) & set(work.noise) else "Φ [L D]"
        conds.append(Condition("unknown inputs bounded", True,
                               f"{what} = {red.Bu.tolist()} over {[str(s) for s in red.unk]} ∈"
                               f" [{list(red.ulo)}, {list(red.uhi)}]", "METHOD §3"))
    if not any(c.name == "H_z ≥ 0" for c in conds):
        nonneg = all(e >= 0 for e in red.Hz)
        conds.append(Condition("H_z ≥ 0", nonneg, f"H_z = {red.Hz.tolist()}" +
                               ("" if nonneg else "; the bounds use H_z⁺ x̲* − H_z⁻ x̄*"),
                               "METHOD §3", required=False))
    conds.extend(note for r in rows for note in r.notes)
    return conds


def interval_observer_nonlinear(model: PlantModel, design: Design, *, margin=None,
                                domain=None, decomposition: str = "auto",
                                name: str | None = None) -> Observer:
    """Interval observer for z = M x from a Jordan (or diagonal) design, with or without
    nonlinear terms, continuous or discrete; see the module docstring.

    Parameters
    ----------
    margin : None, ``"exact"``, ``"lipschitz"``, or numbers
        How the noise entering through y is bounded. ``None``/``"exact"``: the exact
        worst case over the noise box (needs f_i monotone in each ỹ_k; no Lipschitz
        constant). ``"lipschitz"``: f_i(x, y) ∓ Σ_k K_ik r_k with K_ik = sup|∂f_i/∂ỹ_k|
        (fails when that is infinite, as for √ at 0). Numbers (one, or one per row):
        the paper's "k* w*" for the nonlinear part, added to the linear abs(J*) W w*
        term; a Condition compares it with the Lipschitz bound when there is one.
    domain : relations, optional
        Override the model's state domain (for the clipping ranges and the checks).
    decomposition : ``"auto"`` (default) or ``"none"``
        What to do with a row whose right-hand side is monotone neither jointly nor term
        by term (sin x*, exp(−|x1 − x2|)). ``"auto"``: the γ-shift (mixed-monotone)
        decomposition of the module docstring, with the stability of the interval-width
        comparison system checked (refused, naming γ and the spectral abscissa or
        radius, when it cannot be proven); ``"none"``: refuse, as before.
    """
    _check_design(design)
    work = _work(model)
    dom = tuple(work.domain if domain is None else domain)
    d = design
    red = _reduced(work, d, dom)
    mode, user = _margin_mode(margin, red.k)
    if decomposition not in ("auto", "none"):
        raise UsageError(f"decomposition: expected 'auto' or 'none', got {decomposition!r}")
    rows = [_row(red, i, mode, user, decomposition) for i in range(red.k)]
    upd_l = [r.lower + red.bmin[i] for i, r in enumerate(rows)]
    upd_u = [r.upper + red.bmax[i] for i, r in enumerate(rows)]
    names, outputs = _bounded_outputs(work, red)
    conds = _conditions(work, d, red, rows, dom)
    assumptions = list(d.assumptions)
    assumptions.append("x̲*(0) ≤ Φ x(0) ≤ x̄*(0)")
    if red.terms:
        assumptions.append(f"the plant stays in its domain {', '.join(map(str, dom))}"
                           " (there the clipped arguments equal the true ones)")
    zdesc = ", ".join(names)
    xl, xu = red.xl, red.xu
    return Observer(
        name=name or f"{work.name}_interval", kind="interval", time=work.time,
        states=tuple(xl) + tuple(xu), signals=tuple(output_symbols(red.l)) + tuple(red.us),
        parameters={},
        update=tuple(upd_l) + tuple(upd_u), outputs=tuple(outputs),
        initial=_initial(work, red.Phi, xl, xu), conditions=tuple(conds),
        assumptions=tuple(assumptions), design=d,
        description=f"interval observer for {zdesc} = {d.estimate}"
                    + (" with nonlinear terms" if red.terms else ""))


class _NotMonotone(UsageError):
    """A row is monotone neither jointly nor term by term (the γ-shift decomposition
    takes over unless decomposition='none')."""


def _derivative_range(fn, s, lo, hi, in_ranges):
    extra = fn.free_symbols - {s}
    if not extra:
        # differentiate with a real variable: d|s|/ds = sign(s), not a complex Derivative
        r = sp.Symbol(s.name, real=True)
        return derivative_range(fn.xreplace({s: r}), r, lo, hi)
    dom = Domain([], None, {s: (lo, hi), **in_ranges}, fn.free_symbols)
    import numpy as np
    an = RangeAnalyzer(dom, np.random.default_rng(0))
    en = an.entry(sp.diff(fn, s))
    return en.lo, en.hi, en.kind


def _nonlinear_y_bound(red: _Reduced, i, r):
    """Σ_k sup|∂(C*Ψ*)_i/∂ỹ_k| r_k, the Lipschitz bound of row i's nonlinear part in y
    over the noise radii r; None when a derivative is unbounded."""
    tot = sp.Integer(0)
    for m, v in enumerate(red.yt):
        acc_lo = acc_hi = sp.Integer(0)
        for (j, *_rest) in red.terms:
            lo, hi, _ = red.d_range(i, v, only=j)
            acc_lo, acc_hi = acc_lo + lo, acc_hi + hi
        if acc_lo == -sp.oo or acc_hi == sp.oo:
            return None
        tot += sp.Max(abs(acc_lo), abs(acc_hi)) * r[m]
    return tot


def _per_term(red: _Reduced, i):
    """Row i bounded term by term: the linear part by the signs of its coefficients,
    each C*_ij φ_j(a_j) by the sign of its own derivative (φ_j monotone)."""
    k, l, time, xs, yt, ys = red.k, red.l, red.time, red.xs, red.yt, red.ys
    xl, xu, us, Fs, Js, Gs = red.xl, red.xu, red.us, red.Fs, red.Js, red.Gs
    terms, off_lo, off_hi, d_range = red.terms, red.off_lo, red.off_hi, red.d_range
    lo_e = sum((Gs[i, m] * us[m] for m in range(len(us))), sp.Integer(0))
    hi_e = lo_e
    for j in range(k):
        c = Fs[i, j]
        if (j == i and time == "continuous") or c >= 0:
            own_l, own_u = (xl[j], xu[j])
        else:
            own_l, own_u = (xu[j], xl[j])
        lo_e += c * own_l
        hi_e += c * own_u
    for m in range(l):
        c = Js[i, m]
        a, b = ys[m] + off_lo[m], ys[m] + off_hi[m]
        lo_e += c * (a if c >= 0 else b)
        hi_e += c * (b if c >= 0 else a)
    for (j, ccol, arg, carg, fn, s, _) in terms:
        if ccol[i] == 0:
            continue
        sub_l, sub_u = {}, {}
        for jj, v in enumerate(xs):
            lo, hi, _ = d_range(i, v, only=j)
            sg = range_sign(lo, hi)
            if jj == i and time == "continuous":
                sub_l[v], sub_u[v] = xl[jj], xu[jj]
            elif sg in ("+", "0"):
                sub_l[v], sub_u[v] = xl[jj], xu[jj]
            elif sg == "-":
                sub_l[v], sub_u[v] = xu[jj], xl[jj]
            else:
                raise _NotMonotone(
                    f"interval observer: row {i + 1}, nonlinear term Ψ*_{j} = {fn} is not monotone in"
                    f" {v} on the clipped extension (∂ ∈ {interval_text(lo, hi)}): no sign-definite"
                    " embedding; try another design (λ, rows), a domain bounded away from the"
                    " non-monotone region, or decomposition='auto' (the γ-shift)")
        for m, v in enumerate(yt):
            lo, hi, _ = d_range(i, v, only=j)
            sg = range_sign(lo, hi)
            a, b = ys[m] + off_lo[m], ys[m] + off_hi[m]
            if sg in ("+", "0"):
                sub_l[v], sub_u[v] = a, b
            elif sg == "-":
                sub_l[v], sub_u[v] = b, a
            else:
                raise _NotMonotone(
                    f"interval observer: row {i + 1}, nonlinear term Ψ*_{j} is not monotone in the"
                    f" output {ys[m]} (∂ ∈ {interval_text(lo, hi)}): the noise margin cannot be bounded"
                    " by its corners")
        lo_e += ccol[i] * fn.xreplace({s: carg.xreplace(sub_l)})
        hi_e += ccol[i] * fn.xreplace({s: carg.xreplace(sub_u)})
    return lo_e, hi_e


def _initial(model, Phi, xl, xu, margin=1):
    """Default initial bounds Φ x(0) ∓ margin (a scenario's observer_initial overrides)."""
    xs0 = Phi * sp.Matrix(model.states)
    init = {}
    for i in range(Phi.rows):
        init[xl[i]] = xs0[i] - margin
        init[xu[i]] = xs0[i] + margin
    return init

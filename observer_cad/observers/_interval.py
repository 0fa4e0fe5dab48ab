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
- the unknown inputs ρ, d: the ⁺/⁻ split over their declared bounds.

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

:func:`full_state_intervals`: with H = (H0 0) up to a permutation of the states, the
measured states come from y through H0⁻¹ (⁺/⁻ split of H0⁻¹ over the noise box — the
split removes the assumption H0⁻¹ ≥ 0, which is reported), the others from an
interval observer for z = (the unmeasured states).
"""
from __future__ import annotations

import dataclasses

import sympy as sp

from ..synthesis import Condition, Design
from ..errors import InfeasibleDesignError, ModelError, UsageError
from ..model import PlantModel
from ._observer import Observer, output_symbols
from ..numerics import box_max, box_min, comparison_stability, neg, pos, rationalize_floats
from ..model import extract_structure
from ..analysis import (Domain, RangeAnalyzer, argument_range, derivative_range, format_number,
                        interval_scale, lipschitz, nonlinear_conditions, range_sign,
                        reduced_nonlinearity)

__all__ = ["interval_observer_nonlinear", "full_state_intervals"]


def _work(model: PlantModel) -> PlantModel:
    return model.substitute_parameters() if model.parameters else model


def _box(model, syms, what):
    lo, hi = [], []
    for s in syms:
        if s not in model.bounds:
            raise ModelError(f"{model.where}: the interval observer needs bounds on {what} '{s}'"
                             f" (declare bounds={{{s}: (low, high)}} in the model)")
        a, b = model.bounds[s]
        lo.append(a)
        hi.append(b)
    return sp.Matrix(lo), sp.Matrix(hi)


def _fmt_iv(lo, hi):
    return f"[{format_number(lo)}, {format_number(hi)}]"


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
        the paper's "k* w*" for the nonlinear part, added to the linear |J*| W w*
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
    if design.matrices.Hz is None or design.matrices.Phi is None:
        raise UsageError("interval_observer_nonlinear needs a design with z = H_z x* + Q y"
                         " (design_jordan(..., observer='interval', estimate=...))")
    if design.symbolic:
        raise UsageError("interval_observer_nonlinear needs a numeric design (the signs of"
                         " its matrices decide the bounds); design without --symbolic")
    if design.matrices.K is not None:
        raise UsageError("interval_observer_nonlinear takes the reduced model without output"
                         " feedback (a Jordan design); this design has a gain K")
    work = _work(model)
    st = design.structure  # extracted once, by the design (parameters substituted)
    time = work.time
    dom = tuple(work.domain if domain is None else domain)
    d = design
    k, l = d.k, len(work.outputs)
    m = d.matrices
    Fs, Js, Gs = sp.Matrix(m.F_star), sp.Matrix(m.J_star), sp.Matrix(m.G_star)
    Phi, Hz, Q = sp.Matrix(m.Phi), sp.Matrix(m.Hz), sp.Matrix(m.Q)
    H, W = sp.Matrix(st.H), sp.Matrix(st.W)
    xs = list(d.observer_states) or list(sp.symbols(f"xs1:{k + 1}"))
    ys = list(output_symbols(l))
    yt = list(sp.symbols(f"ytilde1:{l + 1}"))  # noise-free outputs H x
    us = list(work.inputs)
    xl = list(sp.symbols(f"xl1:{k + 1}"))
    xu = list(sp.symbols(f"xu1:{k + 1}"))

    # ---- unknown inputs entering the reduced model: Φ L ρ + Φ D d
    unk = [s for s in work.disturbances] + [s for s in work.faults]
    Bu = Phi * sp.Matrix.hstack(sp.Matrix(st.L), sp.Matrix(st.D)) if unk else sp.zeros(k, 0)
    Bu = Bu.applyfunc(rationalize_floats)  # floats (float designs) only: exact stays exact
    used = [j for j in range(Bu.cols) if any(Bu[i, j] != 0 for i in range(k))]
    Bu = Bu.extract(list(range(k)), used) if used else sp.zeros(k, 0)
    unk = [unk[j] for j in used]
    if unk:
        ulo, uhi = _box(work, unk, "the unknown input")
        bmin, bmax = box_min(Bu, ulo, uhi), box_max(Bu, ulo, uhi)
    else:
        bmin = bmax = sp.zeros(k, 1)

    # ---- noise box of ỹ − y = −W w
    if W.cols:
        wlo, whi = _box(work, work.noise, "noise")
        off_lo = -box_max(W, wlo, whi)
        off_hi = -box_min(W, wlo, whi)
    else:
        wlo = whi = sp.zeros(0, 1)
        off_lo = off_hi = sp.zeros(l, 1)

    # ---- nonlinear terms: φ_j, clipped argument, derivative range
    terms = []  # (j, C*_col, arg (in xs, yt), clipped arg, phi(s), s, P range (lo, hi, kind))
    args_info = []
    if d.nonlinear:
        Cs = sp.Matrix(d.matrices.C_star)
        in_ranges = {u: work.bounds[u] for u in us if u in work.bounds}
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

    def f_row(i, xv, yv):
        """f_i at states xv, outputs yv (lists of expressions)."""
        sub = dict(zip(xs, xv))
        sub.update(dict(zip(yt, yv)))
        e = sum((Fs[i, j] * xv[j] for j in range(k)), sp.Integer(0))
        e += sum((Js[i, m] * yv[m] for m in range(l)), sp.Integer(0))
        e += sum((Gs[i, m] * us[m] for m in range(len(us))), sp.Integer(0))
        for (_, ccol, _, carg, fn, s, _) in terms:
            if ccol[i] != 0:
                e += ccol[i] * fn.xreplace({s: carg.xreplace(sub)})
        return e

    def d_range(i, v, only=None):
        """Range of ∂f_i/∂v (v a state or ỹ symbol) on the clipped extension."""
        if v in xs:
            lin = Fs[i, xs.index(v)]
        else:
            lin = Js[i, yt.index(v)]
        lo = hi = sp.sympify(lin) if only is None else sp.Integer(0)
        kinds = set()
        for (j, ccol, arg, _, _, _, (plo, phi_, pkind)) in terms:
            if only is not None and j != only:
                continue
            c = ccol[i] * sp.diff(arg, v)
            if c == 0:
                continue
            a, b = interval_scale(c, (plo, phi_))
            lo, hi = lo + a, hi + b
            kinds.add(pkind)
        return sp.sympify(lo), sp.sympify(hi), kinds

    def lin_only(i, v):
        c = Fs[i, xs.index(v)] if v in xs else Js[i, yt.index(v)]
        return sp.sympify(c)

    # ---- margin option
    if margin is None or margin == "exact":
        mode = "exact"
        user = None
    elif margin == "lipschitz":
        mode, user = "lipschitz", None
    else:
        mode = "user"
        vals = list(margin) if isinstance(margin, (list, tuple)) else [margin] * k
        if len(vals) != k:
            raise UsageError(f"margin: give one value or {k} values")
        user = [rationalize_floats(v) for v in vals]

    if decomposition not in ("auto", "none"):
        raise UsageError(f"decomposition: expected 'auto' or 'none', got {decomposition!r}")
    upd_l, upd_u, signs_all, how_rows, margins, notes = [], [], [], [], [], []
    shifts = []  # _Shift of every γ-shifted (row, variable)
    sampled_only = False
    for i in range(k):
        sg = {}
        rng = {}
        for v in xs + yt:
            lo, hi, kinds = d_range(i, v)
            rng[v] = (lo, hi)
            s = range_sign(lo, hi)
            if "sampled" in kinds:
                sampled_only = True
            sg[v] = s
        signs_all.append({str(v): sg[v] for v in xs + yt})
        x_need = [v for j, v in enumerate(xs) if j != i or time == "discrete"]
        joint_ok = all(sg[v] in ("+", "-", "0") for v in x_need)
        y_ok = all(sg[v] in ("+", "-", "0") for v in yt)
        if mode == "exact" and joint_ok and y_ok:
            lo_x = [xl[j] if (j == i and time == "continuous") or sg[xs[j]] != "-" else xu[j]
                    for j in range(k)]
            hi_x = [xu[j] if (j == i and time == "continuous") or sg[xs[j]] != "-" else xl[j]
                    for j in range(k)]
            lo_y = [ys[m] + (off_lo[m] if sg[yt[m]] != "-" else off_hi[m]) for m in range(l)]
            hi_y = [ys[m] + (off_hi[m] if sg[yt[m]] != "-" else off_lo[m]) for m in range(l)]
            upd_l.append(f_row(i, lo_x, lo_y) + bmin[i])
            upd_u.append(f_row(i, hi_x, hi_y) + bmax[i])
            how_rows.append("joint")
            margins.append("exact worst case over the noise box (corners by the signs of ∂f/∂ỹ)")
            continue
        if mode in ("lipschitz", "user") and joint_ok:
            lo_x = [xl[j] if (j == i and time == "continuous") or sg[xs[j]] != "-" else xu[j]
                    for j in range(k)]
            hi_x = [xu[j] if (j == i and time == "continuous") or sg[xs[j]] != "-" else xl[j]
                    for j in range(k)]
            r = [sp.Max(abs(off_lo[m]), abs(off_hi[m])) for m in range(l)]
            if mode == "lipschitz":
                K = []
                for m in range(l):
                    lo, hi = rng[yt[m]]
                    if lo == -sp.oo or hi == sp.oo:
                        raise UsageError(
                            f"margin='lipschitz': ∂f{i + 1}/∂y{m + 1} is unbounded on the clipped"
                            f" extension (range {_fmt_iv(lo, hi)}): not Lipschitz in y; use the"
                            " exact worst case (margin=None)")
                    K.append(sp.Max(abs(lo), abs(hi)))
                mg = sum((K[m] * r[m] for m in range(l)), sp.Integer(0))
                margins.append(f"Σ_k K_k r_k = {format_number(mg)} with K = {[format_number(v) for v in K]}")
                upd_l.append(f_row(i, lo_x, ys) - mg + bmin[i])
                upd_u.append(f_row(i, hi_x, ys) + mg + bmax[i])
            else:
                Jw = (-Js[i, :] * W) if W.cols else sp.zeros(1, 0)
                jmin = box_min(Jw, wlo, whi)[0] if W.cols else 0
                jmax = box_max(Jw, wlo, whi)[0] if W.cols else 0
                mg = user[i]
                # the Lipschitz bound of the nonlinear part in y, for comparison
                bound = _nonlinear_y_bound(i, terms, yt, r, d_range)
                if bound is None:
                    notes.append(Condition(
                        f"row {i + 1}: the given margin k* w* = {mg} covers the noise through Ψ*",
                        False, "not verifiable: C*Ψ* is not Lipschitz in y on the clipped extension"
                        " (√ at 0); the inclusion is not guaranteed — use margin=None",
                        "seed 002 §6", required=True))
                else:
                    notes.append(Condition(
                        f"row {i + 1}: the given margin k* w* = {mg} covers the noise through Ψ*",
                        bool(mg >= bound), f"Lipschitz bound of the nonlinear part: Σ_k k*_k r_k ="
                        f" {format_number(bound)}", "seed 002 §6", required=True))
                margins.append(f"user k* w* = {mg} plus |J*| W w*")
                upd_l.append(f_row(i, lo_x, ys) + jmin - mg + bmin[i])
                upd_u.append(f_row(i, hi_x, ys) + jmax + mg + bmax[i])
            how_rows.append("joint")
            continue
        # ---- per-term fallback, then the γ-shift decomposition
        try:
            lo_e, hi_e = _per_term(i, k, l, time, xs, yt, ys, xl, xu, us, Fs, Js, Gs, terms,
                                   off_lo, off_hi, d_range)
            how_rows.append("per-term")
            margins.append("exact worst case per term (each φ_j monotone in its argument)")
        except _NotMonotone:
            if decomposition == "none":
                raise
            lo_e, hi_e, row_shifts = _decomposed_row(i, time, xs, yt, ys, xl, xu, off_lo,
                                                     off_hi, f_row, d_range)
            shifts.extend(row_shifts)
            how_rows.append("decomposed")
            margins.append("exact worst case over the noise box after the γ-shift")
        upd_l.append(lo_e + bmin[i])
        upd_u.append(hi_e + bmax[i])

    # ---- outputs
    M = (Hz * Phi + Q * H).applyfunc(rationalize_floats)
    Hp, Hm = pos(Hz), neg(Hz)
    QW = Q * W
    if QW.cols:
        qmin, qmax = box_min(QW, wlo, whi), box_max(QW, wlo, whi)
    else:
        qmin = qmax = sp.zeros(Hz.rows, 1)
    zl = Hp * sp.Matrix(xl) - Hm * sp.Matrix(xu) + Q * sp.Matrix(ys) - qmax
    zu = Hp * sp.Matrix(xu) - Hm * sp.Matrix(xl) + Q * sp.Matrix(ys) - qmin
    names = _output_names(work, M)
    outputs = []
    for nm, a, b in zip(names, zl, zu):
        outputs += [(f"{nm}_lower", sp.expand(a)), (f"{nm}_upper", sp.expand(b))]

    # ---- conditions
    conds = list(d.conditions)
    sign_text = "; ".join(f"row {i + 1}: " + ", ".join(f"∂f/∂{v} {s}" for v, s in sg.items())
                          for i, sg in enumerate(signs_all))
    if time == "continuous":
        cname = "mixed-monotone embedding: ∂f_i/∂x*_j sign-definite for j ≠ i (cooperative when all ≥ 0)"
    else:
        cname = "monotone embedding: ∂f_i/∂x*_j sign-definite for all i, j (discrete time; F*⁺/F*⁻ split)"
    coop = all(s != "-" for i, sg in enumerate(signs_all) for j, v in enumerate(xs)
               for s in [sg[str(v)]] if (j != i or time == "discrete"))
    decomposed = [i for i, how in enumerate(how_rows) if how == "decomposed"]
    if decomposed:
        rows_txt = ", ".join(str(i + 1) for i in decomposed)
        conds.append(Condition(cname, False, sign_text + f"; row(s) {rows_txt} not sign-definite"
                               " (± above): bounded by the γ-shift decomposition below instead",
                               "METHOD §3; seed 002 §4, §6", required=False))
    else:
        conds.append(Condition(cname, True, sign_text + ("; cooperative (all ≥ 0)" if coop else
                                                         "; some ≤ 0: the bounds are mixed")
                               + (" — some signs from samples only, not proven" if sampled_only else ""),
                               "METHOD §3; seed 002 §4, §6"))
    if decomposed:
        conds += _decomposition_conditions(k, time, xs, how_rows, shifts, Fs, terms, d_range,
                                           dom, args_info, sampled_only)
    for (j, arg, (lo, hi), (plo, phi_, pkind)) in args_info:
        conds.append(Condition(
            f"argument of Ψ*_{j} clipped to its domain range", True,
            f"{arg} ∈ {_fmt_iv(lo, hi)} on the domain {', '.join(map(str, dom)) or 'Rⁿ'};"
            f" φ_{j}' on the clipped extension ∈ {_fmt_iv(plo, phi_)} ({pkind})",
            "METHOD §3"))
    if d.nonlinear:
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
    conds.append(Condition(
        "noise through y bounded", True,
        "; ".join(f"row {i + 1} ({how}): {mg}" for i, (how, mg) in enumerate(zip(how_rows, margins)))
        + f"; ỹ − y ∈ [{list(off_lo)}, {list(off_hi)}]", "METHOD §3; seed 002 §4, §6"))
    if unk:
        conds.append(Condition("unknown inputs bounded", True,
                               f"Φ [L D] = {Bu.tolist()} over {[str(s) for s in unk]} ∈"
                               f" [{list(ulo)}, {list(uhi)}]", "METHOD §3"))
    if not any(c.name == "H_z ≥ 0" for c in conds):
        nonneg = all(e >= 0 for e in Hz)
        conds.append(Condition("H_z ≥ 0", nonneg, f"H_z = {Hz.tolist()}" +
                               ("" if nonneg else "; the bounds use H_z⁺ x̲* − H_z⁻ x̄*"),
                               "METHOD §3", required=False))
    conds.extend(notes)
    assumptions = list(d.assumptions)
    assumptions.append("x̲*(0) ≤ Φ x(0) ≤ x̄*(0)")
    if terms:
        assumptions.append(f"the plant stays in its domain {', '.join(map(str, dom))}"
                           " (there the clipped arguments equal the true ones)")
    zdesc = ", ".join(names)
    return Observer(
        name=name or f"{work.name}_interval", kind="interval", time=time,
        states=tuple(xl) + tuple(xu), signals=tuple(ys) + tuple(us), parameters={},
        update=tuple(upd_l) + tuple(upd_u), outputs=tuple(outputs),
        initial=_initial(work, Phi, xl, xu), conditions=tuple(conds),
        assumptions=tuple(assumptions), design=d,
        description=f"interval observer for {zdesc} = {d.estimate}"
                    + (" with nonlinear terms" if terms else ""))


class _NotMonotone(UsageError):
    """A row is monotone neither jointly nor term by term (the γ-shift decomposition
    takes over unless decomposition='none')."""


@dataclasses.dataclass(frozen=True)
class _Shift:
    """One γ-shift: row i, variable v, ∂f_i/∂v ∈ [lo, hi] (proven), γ and its direction
    ("+": f_i + γ v nondecreasing, "−": f_i − γ v nonincreasing)."""
    row: int
    var: sp.Symbol
    lo: sp.Expr
    hi: sp.Expr
    gamma: sp.Expr
    direction: str

    def text(self) -> str:
        g = "f + γ·v" if self.direction == "+" else "f − γ·v"
        return (f"row {self.row + 1}, {self.var}: ∂f/∂{self.var} ∈ {_fmt_iv(self.lo, self.hi)},"
                f" γ = {format_number(self.gamma)} ({g} monotone; Lipschitz bound"
                f" {format_number(sp.Max(abs(self.lo), abs(self.hi)))})")


def _decomposed_row(i, time, xs, yt, ys, xl, xu, off_lo, off_hi, f_row, d_range):
    """Row i by the γ-shift (METHOD §3): for every argument v whose ∂f_i/∂v ∈ [a, b]
    changes sign, f_i + γ v with γ = −a is nondecreasing in v (or f_i − γ v with γ = b
    nonincreasing; the smaller γ is taken), so with v ∈ [v̲, v̄]

        f_i ≥ (f_i + γ v)(v̲) − γ v̄ = f_i(v̲) − γ (v̄ − v̲),   f_i ≤ f_i(v̄) + γ (v̄ − v̲)

    and the −γ v part joins the linear part. The other arguments take the end their
    sign gives, as in the joint embedding. Returns (lower, upper, shifts)."""
    out_shifts = []
    lo_x, hi_x, lo_y, hi_y = [], [], [], []
    pen = sp.Integer(0)
    for v, lo_v, hi_v, width, lo_out, hi_out in (
            [(xs[j], xl[j], xu[j], xu[j] - xl[j], lo_x, hi_x) for j in range(len(xs))]
            + [(yt[m], ys[m] + off_lo[m], ys[m] + off_hi[m], off_hi[m] - off_lo[m], lo_y, hi_y)
               for m in range(len(yt))]):
        a, b, kinds = d_range(i, v)
        sg = range_sign(a, b)
        if (time == "continuous" and v == xs[i]) or sg in ("+", "0"):
            lo_out.append(lo_v)
            hi_out.append(hi_v)
            continue
        if sg == "-":
            lo_out.append(hi_v)
            hi_out.append(lo_v)
            continue
        if "sampled" in kinds:
            raise InfeasibleDesignError(
                f"interval observer: row {i + 1} is not monotone in {v} and ∂f{i + 1}/∂{v} ∈"
                f" {_fmt_iv(a, b)} is known from samples only: no proven γ for the γ-shift")
        if a == -sp.oo and b == sp.oo:
            raise InfeasibleDesignError(
                f"interval observer: row {i + 1} is not monotone in {v} and not Lipschitz in it"
                f" (∂f{i + 1}/∂{v} ∈ {_fmt_iv(a, b)}): no finite γ for the γ-shift")
        if bool(-a <= b):
            gamma, direction = -a, "+"
            lo_out.append(lo_v)
            hi_out.append(hi_v)
        else:
            gamma, direction = b, "−"
            lo_out.append(hi_v)
            hi_out.append(lo_v)
        pen += gamma * width
        out_shifts.append(_Shift(i, v, a, b, gamma, direction))
    return f_row(i, lo_x, lo_y) - pen, f_row(i, hi_x, hi_y) + pen, out_shifts


def _width_matrix(k, time, xs, how_rows, shifts, Fs, terms, d_range):
    """M of the comparison system for the width w = x̄* − x̲* ≥ 0: w' ≤ M w + c
    (continuous, M Metzler) or w(t+1) ≤ M w(t) + c (discrete, M ≥ 0). By the mean value
    theorem along the corners of each row, with [a, b] the proven range of ∂f_i/∂x*_j:
    M_ii = b in continuous time (the comparison principle keeps x*_i on its face),
    b for a nondecreasing argument, −a for a nonincreasing one, b − a + γ for a
    γ-shifted one, and for a row bounded term by term the sum over its pieces."""
    gam = {(sh.row, sh.var): sh.gamma for sh in shifts}
    M = sp.zeros(k, k)
    for i in range(k):
        for j, v in enumerate(xs):
            own = time == "continuous" and j == i
            if how_rows[i] == "per-term":
                pieces = [(Fs[i, j], Fs[i, j])] + [d_range(i, v, only=t[0])[:2] for t in terms]
            else:
                pieces = [d_range(i, v)[:2]]
            tot = sp.Integer(0)
            for a, b in pieces:
                a, b = sp.sympify(a), sp.sympify(b)
                if own:
                    tot += b
                elif (i, v) in gam:
                    tot += b - a + gam[(i, v)]
                else:
                    tot += sp.Max(abs(a), abs(b))
            M[i, j] = tot
    return M


def _comparison_stability(M, time):
    """(stable, figure, text) of :func:`observer_cad.numerics.comparison_stability`."""
    stable, fig, minors = comparison_stability(M, time)
    if not minors and fig == float("inf"):
        return False, fig, "M has unbounded entries (a derivative is unbounded)"
    return stable, fig, "leading principal minors of " + ("−M" if time == "continuous" else "I − M") \
        + f": {[format_number(m) for m in minors]}"


def _decomposition_conditions(k, time, xs, how_rows, shifts, Fs, terms, d_range, dom,
                              args_info, sampled_only):
    """The two required conditions of a decomposed observer (the γ used, with the
    derivative bounds and the domain they hold on; the comparison system's stability),
    or a one-line refusal when the comparison system is not provably stable."""
    M = _width_matrix(k, time, xs, how_rows, shifts, Fs, terms, d_range)
    stable, fig, minors = _comparison_stability(M, time)
    gam_txt = "; ".join(sh.text() for sh in shifts)
    what = "spectral abscissa α(M)" if time == "continuous" else "spectral radius ρ(M)"
    need = "< 0" if time == "continuous" else "< 1"
    Mtxt = "[" + "; ".join(", ".join(format_number(e) for e in M[i, :]) for i in range(k)) + "]"
    if not stable:
        raise InfeasibleDesignError(
            f"interval observer: the γ-shift decomposition gives an unstable comparison system"
            f" for the interval width ({gam_txt}): M = {Mtxt}, {what} = {fig:.6g}, not {need};"
            " the bounds would diverge — try another design (λ, rows) or a smaller nonlinear gain")
    where = ("arguments clipped to their domain ranges: " + ", ".join(
        f"Ψ*_{j}: {arg} ∈ {_fmt_iv(lo, hi)}" for (j, arg, (lo, hi), _) in args_info)) \
        if any(lo != -sp.oo or hi != sp.oo for (_, _, (lo, hi), _) in args_info) else \
        "no clipping (the arguments range over R)"
    dom_txt = ", ".join(map(str, dom)) or "Rⁿ"
    kind = "comparison principle, x*_i on its face" if time == "continuous" else "corners"
    return [
        Condition(
            "γ-shift decomposition: f_i ± γ v monotone in every argument v where f_i is not",
            True, f"{gam_txt}; the derivative ranges are proven (interval evaluation of"
            f" ∂f/∂v, exact on each smooth piece) on the observer's whole state space"
            f" (domain {dom_txt}; {where})"
            + (" — some other signs from samples only, not proven" if sampled_only else ""),
            "METHOD §3 (mixed-monotone decomposition)"),
        Condition(
            "comparison system of the interval width stable: w" + ("' ≤ M w + c, α(M) < 0"
                                                                    if time == "continuous" else
                                                                    "(t+1) ≤ M w(t) + c, ρ(M) < 1"),
            True, f"w = x̄* − x̲*, M = {Mtxt} ({kind}), {what} = {fig:.6g} {need}; exact check:"
            f" {minors} all > 0", "METHOD §3"),
    ]


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


def _nonlinear_y_bound(i, terms, yt, r, d_range):
    tot = sp.Integer(0)
    for m, v in enumerate(yt):
        acc_lo = acc_hi = sp.Integer(0)
        for (j, *_rest) in terms:
            lo, hi, _ = d_range(i, v, only=j)
            acc_lo, acc_hi = acc_lo + lo, acc_hi + hi
        if acc_lo == -sp.oo or acc_hi == sp.oo:
            return None
        tot += sp.Max(abs(acc_lo), abs(acc_hi)) * r[m]
    return tot


def _per_term(i, k, l, time, xs, yt, ys, xl, xu, us, Fs, Js, Gs, terms, off_lo, off_hi, d_range):
    """Row i bounded term by term: the linear part by the signs of its coefficients,
    each C*_ij φ_j(a_j) by the sign of its own derivative (φ_j monotone)."""
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
                    f" {v} on the clipped extension (∂ ∈ {_fmt_iv(lo, hi)}): no sign-definite"
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
                    f" output {ys[m]} (∂ ∈ {_fmt_iv(lo, hi)}): the noise margin cannot be bounded"
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


# ================================================================== full-state intervals
def full_state_intervals(model: PlantModel, *, lambdas=None, margin=None, domain=None) -> Observer:
    """Intervals for every state (seed 002 §4): measured states from y, the others from
    an interval observer. Outputs ``x1_lower``, ``x1_upper``, … in state order.

    Needs H = (H0 0) up to a permutation of the states with H0 invertible (the
    measured states are the columns where H is nonzero). The paper assumes H0⁻¹ ≥ 0;
    here H0⁻¹ is split into ⁺/⁻ over the noise box, so the assumption is only reported.
    """
    from ..synthesis import design_jordan
    work = _work(model)
    st = extract_structure(work)
    H, W = sp.Matrix(st.H), sp.Matrix(st.W)
    n, l = len(work.states), H.rows
    meas = [j for j in range(n) if any(H[i, j] != 0 for i in range(l))]
    rest = [j for j in range(n) if j not in meas]
    H0 = H.extract(list(range(l)), meas)
    if H0.rows != H0.cols or H0.rank() < H0.rows:
        raise UsageError(f"{work.where}: full-state intervals need H = (H0 0) with H0 square and"
                         f" invertible; H has {l} rows and is nonzero in {len(meas)} state columns")
    H0i = H0.inv()
    ys = list(output_symbols(l))
    if W.cols:
        wlo, whi = _box(work, work.noise, "noise")
        off_lo, off_hi = -box_max(W, wlo, whi), -box_min(W, wlo, whi)
    else:
        off_lo = off_hi = sp.zeros(l, 1)
    ylo = sp.Matrix(ys) + off_lo
    yhi = sp.Matrix(ys) + off_hi
    x1lo, x1hi = box_min(H0i, ylo, yhi), box_max(H0i, ylo, yhi)
    bounds = {}
    for r, j in enumerate(meas):
        bounds[j] = (sp.expand(x1lo[r]), sp.expand(x1hi[r]))
    conds = [Condition("H = (H0 0) with H0 invertible", True,
                       f"measured states {[str(work.states[j]) for j in meas]}, H0 = {H0.tolist()}",
                       "seed 002 §4, eq. (4.6)"),
             Condition("H0⁻¹ ≥ 0", all(e >= 0 for e in H0i), f"H0⁻¹ = {H0i.tolist()}"
                       + ("" if all(e >= 0 for e in H0i) else
                          "; the bounds use the ⁺/⁻ split of H0⁻¹ instead"), "seed 002 §4, Remark 5",
                       required=False)]
    update, initial, assumptions = [], {}, []
    parts = []
    if rest:
        est = [str(work.states[j]) for j in rest]
        try:
            designs = [design_jordan(work, observer="interval", estimate=est, lambdas=lambdas)]
            groups = [rest]
        except InfeasibleDesignError:
            designs = [design_jordan(work, observer="interval", estimate=str(work.states[j]),
                                     lambdas=lambdas) for j in rest]
            groups = [[j] for j in rest]
        offset = 0
        for dsg, grp in zip(designs, groups):
            obs = interval_observer_nonlinear(work, dsg, margin=margin, domain=domain)
            kk = dsg.k
            ren = {}
            for i in range(kk):
                ren[sp.Symbol(f"xl{i + 1}")] = sp.Symbol(f"xl{offset + i + 1}")
                ren[sp.Symbol(f"xu{i + 1}")] = sp.Symbol(f"xu{offset + i + 1}")
            offset += kk
            sl = [ren[s] for s in obs.states[:kk]]
            su = [ren[s] for s in obs.states[kk:]]
            update += [e.xreplace(ren) for e in obs.update[:kk]]
            parts.append((sl, su, [e.xreplace(ren) for e in obs.update[kk:]]))
            for s, v in obs.initial.items():
                initial[ren[s]] = v
            outs = dict(obs.outputs)
            for j in grp:
                nm = str(work.states[j])
                bounds[j] = (outs[f"{nm}_lower"].xreplace(ren), outs[f"{nm}_upper"].xreplace(ren))
            conds += [c for c in obs.conditions if c not in conds]
            assumptions += [a for a in obs.assumptions if a not in assumptions]
    # states: all lower copies first, then all upper copies
    all_l = [s for p in parts for s in p[0]]
    all_u = [s for p in parts for s in p[1]]
    upd_u = [e for p in parts for e in p[2]]
    outputs = []
    for j in range(n):
        nm = str(work.states[j])
        outputs += [(f"{nm}_lower", bounds[j][0]), (f"{nm}_upper", bounds[j][1])]
    return Observer(
        name=f"{work.name}_full_state_interval", kind="interval", time=work.time,
        states=tuple(all_l) + tuple(all_u), signals=tuple(ys) + tuple(work.inputs), parameters={},
        update=tuple(update) + tuple(upd_u), outputs=tuple(outputs), initial=initial,
        conditions=tuple(conds), assumptions=tuple(assumptions),
        design=None, description="full-state intervals: measured states from y ∓ w*, the others"
        " from an interval observer (seed 002 §4)")

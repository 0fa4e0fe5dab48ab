"""Sliding-mode fault estimation (METHOD §3; seed 002 §5), continuous time.

Reduced model
-------------
One Jordan row whose state is *measured*: Φ_1 = R* H, so that x* = Φ_1 x = R* (y − W w).
The defining identities (METHOD §2) for k = 1, F* = λ, H* = 1 become

    R* H F = λ R* H + J* H,     R* H L = 0,

i.e. (R*, −J*) lies in the left null space of the pencil

    Q(λ) = [ H (F − λI)   H L ]
           [ H             0  ]                     (2l × (n + p)).

λ is admissible when Q(λ) loses row rank. For a measured row this is every λ or none:
with N spanning the null space of H, R* H (F − λI) N = R* H F N, so the λ-free
conditions R* H F N = 0, R* H L = 0 decide; then Φ_1 F = c H with c = J* + λ R*
independent of λ, and J* = c − λ R*. (The general gcd-of-minors computation is kept
as a check.) Among the null-space members one with Φ_1 D ≠ 0 is taken (fault
sensitivity). Φ_1 D = R* (H D) ≠ 0 needs H D ≠ 0: the
matching condition rank(H D) = rank(D) is necessary (for one fault column it says
H D ≠ 0); it is not sufficient — the pencil must also admit a member, which is
checked separately. Then, with G* = Φ_1 G, D* = Φ_1 D (a nonzero scalar),

    x*' = λ x* + G* u + J* H x + D* d = λ x* + G* u + J* y − J* W w + D* d.

Other faults of the model are decoupled like disturbances (they are added to L).

Observer and sign conventions (derived here, checked by simulation in the tests)
-----------------------------------------------------------------------------------
    x̂*' = λ x̂* + G* u + J* y − k1 v,     e = x̂* − R* y,     v ≈ sign(e).

Noise-free, e = x̂* − x* and  e' = λ e − k1 v − D* d. On the sliding surface
(e = e' = 0) the equivalent injection satisfies k1 v_eq = −D* d, hence

    d̂ = −k1 D*⁻¹ v_eq,     v_eq = e / (abs(e) + ε)          (seed 002 eq. (5.4)).

The printed sign is right: d̂ → d (verified in tests/test_sliding.py).

Injection. ``injection="regularised"`` (default) uses v = e/(abs(e) + ε) in the observer
too (a boundary-layer sliding mode): the right-hand side is continuous, the fixed-step
RK4 reference simulator integrates it without chattering, and the same v is the v_eq of
the estimate. The error then settles in the layer abs(e) ≲ ε b/(k1 − b) (b = the bound
below) instead of e = 0, and d̂ − d = (e' − λ e)/D* = O(ε). The slope of v at e = 0 is
k1/ε: explicit RK4 needs dt < 2.78 ε/k1 (reported as a condition).
``injection="sign"`` is the paper's discontinuous v = sign(e). Under a fixed step it
chatters with amplitude ≈ k1·dt, and e/(abs(e) + ε) of that chattering e is no estimate of
v_eq (measured: errors of order 1). Its equivalent injection is therefore taken by a
first-order low-pass filter, a second observer state v_f' = (sign(e) − v_f)/τ, and
d̂ = −k1 D*⁻¹ v_f (filter lag ≈ τ ḋ, ripple ≈ dt/τ).

Gain bound (derived; the printed one is corrected)
--------------------------------------------------
With the measured sliding variable e = x̂* − R* y, noise w and a Lipschitz
nonlinearity (abs(C*ΔΨ) ≤ N*|x̂* − x*|):

    e' = λ e − k1 v − D* d + (J* + λ R*) W w − R* W w' + C* ΔΨ

and V = e²/2 gives V' ≤ abs(e) (λ|e| − k1 + d*|D*| + Σ_i abs(((J* + λR*) W)_i) w*_i
+ abs(R* W) ẇ* + N* δ). Since λ < 0 the term λ|e| is ≤ 0 and can only help: the
sufficient condition is

    k1 > d*|D*| + Σ_i abs(((J* + λR*) W)_i) w*_i + δ N*      (+ abs(R* W) ẇ* for smooth noise).

Process noise in the dynamics (x' = … + Bw w, not decoupled) adds −Φ_1 Bw w to e' and
Σ_i |(Φ_1 Bw)_i| w*_i to the bound.

The printed bound k1 > λδ + d*‖D*‖ (+ w*‖J*‖ + δN*) is *not* sufficient for λ < 0: it
lowers the bound by |λ|δ, but on the sliding surface abs(v_eq) = abs(D* d)/k1 ≤ 1 forces
k1 ≥ sup abs(D* d) = d*|D*| whatever λ and δ are (a test shows tracking failing at the
printed value). Reading the printed term as |λ|δ gives a valid but conservative bound;
both values are reported for information. The printed noise term w*‖J*‖ bounds J* w for
the unmeasurable error x̂* − x*; for the measured e the coefficient is J* + λR*, and a
noise that is not differentiable (sampled noise) makes an exact sliding mode on e
impossible — the estimate is then approximate (seed 002 says so too).

δ bounds the initial estimation error abs(x̂*(0) − x*(0)); with k1 above the bound abs(e) is
non-increasing, so δ bounds it for all t. Reaching time (pure sign, noise-free, linear):
abs(e(t)) ≤ (δ + η/abs(λ)) e^{λt} − η/abs(λ) with η = k1 − b, so e = 0 by
t_r = ln(1 + |λ|δ/η)/abs(λ). With the regularised injection the same argument bounds the
time to enter the band abs(e) ≤ e_th = 3 ε b/(k1 − b): outside it k1|e|/(abs(e) + ε) ≥
k_th = 3 k1 b/(k1 + 2b) > b, so t_r ≤ ln((δ + η_th/abs(λ))/(e_th + η_th/abs(λ)))/abs(λ) with
η_th = k_th − b. Inside the band the injection's slope is ≥ k1 ε/(ε + e_th)², so e
settles on the layer with time constant τ_L ≤ (ε + e_th)²/(k1 ε); d̂ = d + (e' − λe)/D*
tracks d once e' has died out, a few τ_L after t_r. Steady error (noise-free):
abs(d̂ − d) ≲ ε (abs(λ) d*/η + ḋ* k1/η²) with η = k1 − d*|D*| (plus ḋ*·dt from the simulator
holding signals over a step).

Default gain: k1 = 2 × the bound (``gain_margin``).

References: seed 002 §5 (eqs. (5.1)–(5.6)), §6 (δN*); METHOD §3, §4.
"""
from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import sympy as sp

from ..core import Condition, Design, SlidingGainInputs
from ...errors import InfeasibleDesignError, ModelError, UsageError
from ..jordan import Admissible
from ..core import (EPS, INJECTIONS, K1, TAU, is_stable, observer_symbols, output_symbols,
                    sliding_equations)
from ..core import arithmetic_for, prepare, task_for
from ...model import PlantModel, Task
from ..core import substitute_arguments
from ...numerics import echelon_rows, exact_rank
from ...numerics import rationalize_floats

__all__ = ["K1", "EPS", "TAU", "design_sliding", "sliding_pencil", "admissible_sliding_lambdas",
           "GainBound", "GainTerm", "gain_bound", "reaching_time", "RK4_STABILITY"]

LAMBDA = sp.Symbol("lambda")
#: the observer's parameters: the paper's k1, ε, and the filter constant τ (sign injection);
#: named apart from plant parameters (a model may call one of its own k1)
#: |h μ| below which classical RK4 is stable for a real negative eigenvalue μ.
RK4_STABILITY = 2.785


def sliding_pencil(F, H, L, lam) -> sp.Matrix:
    """Q(λ) = [H(F − λI), H L; H, 0]; (R*, −J*) Q(λ) = 0 is the sliding-row equation."""
    F, H = sp.Matrix(F), sp.Matrix(H)
    n, l = F.rows, H.rows
    L = sp.Matrix(L) if L is not None and sp.Matrix(L).cols else sp.zeros(n, 0)
    top = sp.Matrix.hstack(H * (F - lam * sp.eye(n)), H * L)
    bottom = sp.Matrix.hstack(H, sp.zeros(l, L.cols))
    return sp.Matrix.vstack(top, bottom)


def admissible_sliding_lambdas(F, H, L) -> Admissible:
    """λ where Q(λ) loses row rank: every λ, or the exact real roots of the gcd of its
    maximal minors (complex roots are reported, not used)."""
    P = sliding_pencil(F, H, L, LAMBDA)
    r, c = P.shape
    if r > c:
        return Admissible(True, (), (), f"Q(λ) has {r} rows > {c} columns: a left null"
                                        " vector exists for every λ")
    gr = exact_rank(P)
    if gr.rank < r:
        return Admissible(True, (), (), f"rank Q(λ) = {gr.rank} < {r} rows for λ as a free"
                                        " symbol")
    g = None
    for cols in itertools.combinations(range(c), r):
        m = sp.expand(sp.cancel(P[:, list(cols)].det(method="berkowitz")))
        if m != 0:
            g = m if g is None else sp.gcd(g, m)
    g = sp.factor(g)
    if not g.has(LAMBDA):
        return Admissible(False, (), (), f"gcd of the maximal minors of Q(λ) is {g}, free"
                                         " of λ: no admissible λ")
    real, other = [], []
    for f, _ in sp.factor_list(g, LAMBDA)[1]:
        if sp.degree(f, LAMBDA) == 0:
            continue
        if sp.degree(f, LAMBDA) <= 2:
            rts = list(sp.roots(sp.Poly(f, LAMBDA)).keys())
        elif not f.free_symbols - {LAMBDA}:
            rts = list(sp.Poly(f, LAMBDA).all_roots())
        else:
            rts = []
        for rt in rts:
            (real if rt.is_real else other).append(rt)
    real.sort(key=lambda v: (sp.re(v) if v.is_number else 0, str(v)))
    return Admissible(False, tuple(real), tuple(other),
                      f"gcd of the maximal minors of Q(λ) = {g}")


# ---------------------------------------------------------------- gain bound
@dataclasses.dataclass(frozen=True)
class GainTerm:
    """One term of the gain bound: its value, its formula with numbers, and whether the
    (derived) bound uses it."""

    name: str
    value: float
    formula: str
    included: bool = True
    note: str = ""


@dataclasses.dataclass(frozen=True)
class GainBound:
    """k1 > Σ included terms (derived); ``printed`` is seed 002's value for comparison."""

    terms: tuple
    bound: float
    printed: float
    conservative: float  # with |λ|δ added
    delta: float
    lam: float
    d_star: float
    D_star: float

    def term(self, name: str) -> GainTerm:
        return next(t for t in self.terms if t.name == name)

    def reaching_time_bound(self, k1: float, eps: float | None = None) -> float:
        """Upper bound on the reaching time from abs(e(0)) ≤ δ (noise-free, linear);
        ``eps``: the regularised injection's band abs(e) ≤ 3 ε b/(k1 − b)."""
        b, lam = self.bound, abs(self.lam)
        if k1 <= b:
            return math.inf
        if not eps:
            return math.log1p(lam * self.delta / (k1 - b)) / lam
        e_th = self.band(k1, eps)
        if e_th >= self.delta:
            return 0.0
        k_th = k1 * e_th / (e_th + eps)
        eta = k_th - b
        return math.log((self.delta + eta / lam) / (e_th + eta / lam)) / lam

    def band(self, k1: float, eps: float) -> float:
        """e_th = 3 ε b/(k1 − b): the regularised sliding mode stays in abs(e) ≤ e_th."""
        return 3 * eps * self.bound / (k1 - self.bound) if k1 > self.bound else math.inf

    def layer_time_constant(self, k1: float, eps: float) -> float:
        """τ_L = (ε + e_th)²/(k1 ε): inside the band the injection's slope is at least
        k1 ε/(ε + e_th)², so e settles on the layer (and d̂ on d) within a few τ_L."""
        return (eps + self.band(k1, eps)) ** 2 / (k1 * eps)

    def conditions(self, k1: float, eps: float | None) -> list:
        out = []
        for t in self.terms:
            out.append(Condition(f"gain term {t.name}", True,
                                 f"{t.formula} = {t.value:.6g}"
                                 + ("" if t.included else " (not in the bound)")
                                 + (f"; {t.note}" if t.note else ""),
                                 "seed 002 §5–6; derived in observer_cad.synthesis",
                                 required=False))
        incl = " + ".join(t.name for t in self.terms if t.included)
        out.append(Condition("sliding gain bound k1 > " + incl, k1 > self.bound,
                             f"k1 = {k1:.6g}, bound = {self.bound:.6g}"
                             + ("" if k1 > self.bound else
                                " — below the bound: no sliding mode, d̂ saturates at k1/|D*|"),
                             "seed 002 eq. (5.5) corrected"))
        out.append(Condition("printed bound λδ + d*‖D*‖ + w*‖J*‖ + δN* (seed 002)", True,
                             f"= {self.printed:.6g} (λδ = {self.lam * self.delta:.6g} < 0 lowers"
                             f" it below d*|D*| = {self.d_star * abs(self.D_star):.6g}, which"
                             " is necessary: not sufficient); with |λ|δ instead:"
                             f" {self.conservative:.6g} (sufficient, conservative)",
                             "seed 002 eq. (5.5)", required=False))
        tr = self.reaching_time_bound(k1, eps)
        out.append(Condition("reaching time bound", math.isfinite(tr),
                             (f"t_r ≤ {tr:.4g} from |e(0)| ≤ δ = {self.delta:g}"
                              + (f" into |e| ≤ {self.band(k1, eps):.3g}; layer time constant"
                                 f" τ_L ≤ {self.layer_time_constant(k1, eps):.3g}" if eps else ""))
                             if math.isfinite(tr) else "no reaching: k1 ≤ bound",
                             "derived (comparison with e' ≤ λe − η)", required=False))
        return out


def _abs_bound(model: PlantModel, sym, what: str) -> float:
    if sym not in model.bounds:
        raise ModelError(f"{model.where}: the sliding-mode gain needs a bound on {what}"
                         f" '{sym}' (declare bounds={{{sym}: (low, high)}} in the model)")
    lo, hi = model.bounds[sym]
    return float(max(abs(sp.sympify(lo)), abs(sp.sympify(hi))))


def gain_bound(model: PlantModel, design: Design, *, delta: float = 1.0,
               lipschitz: float | None = None) -> GainBound:
    """Evaluate the gain bound's terms for a sliding-mode design (see the module doc)."""
    problem = prepare(model, method="exact")
    work, st = problem.work, problem.structure
    mats = design.matrices
    lam = float(sp.Matrix(mats.F_star)[0, 0])
    Ds = float(sp.Matrix(mats.D_star)[0, 0])
    Js, Rs = sp.Matrix(mats.J_star), sp.Matrix(mats.R_star)
    W = sp.Matrix(st.W)
    fault = work.symbol(design.unknown_input)
    d_star = _abs_bound(work, fault, "fault")
    terms = [GainTerm("d*|D*|", d_star * abs(Ds), f"{d_star:g}·|{Ds:g}|")]
    wst = [_abs_bound(work, w, "noise") for w in work.noise] if W.cols else []
    if W.cols:
        coef = (Js + sp.Float(lam) * Rs) * W
        printed_c = Js * W
        nv = sum(abs(float(c)) * w for c, w in zip(coef, wst))
        pv = sum(abs(float(c)) * w for c, w in zip(printed_c, wst))
        terms.append(GainTerm("w*|J* + λR*|", nv,
                              f"Σ_i |((J* + λR*) W)_i| w*_i = Σ |{[float(c) for c in coef]}|·{wst}",
                              note=f"seed 002 prints w*‖J*‖ = {pv:.6g} (error x̂* − x*, not"
                                   " measurable); non-differentiable noise adds |R* W| ẇ*,"
                                   " unbounded for sampled noise: the estimate is then"
                                   " approximate"))
    else:
        pv = 0.0
        terms.append(GainTerm("w*|J* + λR*|", 0.0, "no measurement noise declared"))
    PBw = sp.Matrix(mats.Phi) * sp.Matrix(st.Bw)  # process noise: not decoupled, bounded
    if any(e != 0 for e in PBw):
        terms.append(GainTerm("w*|Φ_1 Bw|", sum(abs(float(c)) * w for c, w in zip(PBw, wst)),
                              f"process noise: Σ_i |(Φ_1 Bw)_i| w*_i = Σ |{[float(c) for c in PBw]}|"
                              f"·{wst}"))
    Cs = sp.Matrix(mats.C_star) if mats.C_star is not None else sp.zeros(1, 0)
    nonlin = any(e != 0 for e in Cs)
    if nonlin:
        if lipschitz is None:
            raise UsageError(f"{model.where}: C* = Φ_1 C = {Cs.tolist()} ≠ 0: give the Lipschitz"
                             " constant N* of C*Ψ* in x* (lipschitz=...) for the δN* term")
        terms.append(GainTerm("δN*", float(delta) * float(lipschitz),
                              f"{delta:g}·{float(lipschitz):g}"))
    else:
        terms.append(GainTerm("δN*", 0.0, "C* = Φ_1 C = 0 (no nonlinear term reaches x*)"))
    lam_term = GainTerm("λδ", lam * float(delta), f"{lam:g}·{float(delta):g}", included=False,
                        note="printed in seed 002 (5.5); λ < 0 so λ|e| ≤ 0 helps and is dropped")
    terms.append(lam_term)
    bound = sum(t.value for t in terms if t.included)
    nstar = next(t.value for t in terms if t.name == "δN*")
    printed = lam * float(delta) + d_star * abs(Ds) + pv + nstar
    return GainBound(tuple(terms), bound, printed, bound + abs(lam) * float(delta),
                     float(delta), lam, d_star, Ds)


# ---------------------------------------------------------------- design
def design_sliding(model: PlantModel, *, fault: str | None = None, lam=None, k1=None,
                   eps: float = 1e-3, delta: float = 1.0, gain_margin: float = 2.0,
                   injection: str = "regularised", tau: float = 0.02,
                   lipschitz: float | None = None, decouple=(), task: Task | None = None):
    """Sliding-mode fault estimator for one fault (seed 002 §5): the certified design;
    :func:`observer_cad.observers.sliding_observer` builds its observer.

    Parameters
    ----------
    fault : name of the fault to estimate (default: the model's only fault). Other
        faults and every disturbance are decoupled (Φ_1 L = 0).
    lam : requested λ < 0 (checked: admissible, stable); default −1 when every λ is
        admissible, else the admissible stable values in increasing abs(λ).
    k1 : sliding gain; default ``gain_margin`` × the derived bound (see the module doc).
        A k1 below the bound is accepted (the condition is reported as failing).
    eps : ε of v_eq = e/(abs(e) + ε) (and of the regularised injection).
    delta : δ, a bound on the initial estimation error abs(x̂*(0) − x*(0)).
    injection : ``"regularised"`` (v = v_eq; default) or ``"sign"`` (paper's sign(e),
        with v_eq from the low-pass filter v_f' = (sign(e) − v_f)/τ, ``tau``).
    lipschitz : N*, the Lipschitz constant of C*Ψ* in x*, needed when C* ≠ 0.
    decouple : further disturbances or faults to decouple from.

    Raises InfeasibleDesignError when the matching condition fails or no admissible
    stable λ gives a fault-sensitive measured row; UsageError for discrete models.

    The design's ``parameters`` hold the gains (``k_sm``, ``eps_sm`` or ``tau_sm``).
    The observer's states: ``xs1`` (x̂*), plus ``vf`` for the sign injection. Its
    outputs: ``<fault>_hat`` (d̂ = −k1 D*⁻¹ v_eq) and ``r = R* y − x̂*`` (= −e, the
    sliding variable). Its parameters: ``k_sm`` (the paper's k1), ``eps_sm`` (ε) or
    ``tau_sm`` (τ). Initial state 0; δ must bound abs(x̂*(0) − x*(0)) = abs(R* y(0)) then
    (a scenario's ``observer_initial`` overrides it; x̂*(0) = R* y(0) gives e(0) = 0).
    """
    if injection not in INJECTIONS:
        raise UsageError(f"injection must be 'regularised' or 'sign', not {injection!r}")
    problem = prepare(model, method="exact")  # parameters substituted; exact arithmetic only
    work, ar = problem.work, arithmetic_for(problem)
    where = model.where
    if work.time != "continuous":
        raise UsageError(f"{where}: the sliding-mode observer is continuous-time (seed 002 §5);"
                         f" the model is {work.time}-time")
    task = task_for(work, task, observer="sliding-mode",
                    faults=[] if fault is None else [str(fault)], disturbances=decouple)
    fsym = work.symbol(task.targets[0])
    if not eps > 0 or not delta > 0 or not tau > 0:
        raise UsageError("eps, delta and tau must be positive")
    st = problem.structure
    F, G, H, C = (sp.Matrix(M) for M in (st.F, st.G, st.H, st.C))
    D = sp.Matrix(st.unknown_input_columns([fsym]))
    dec = [work.symbol(nm) for nm in task.decoupled]
    L = sp.Matrix(st.unknown_input_columns(dec)) if dec else sp.zeros(st.n, 0)
    conds = [_matching(ar, H, D, where, fsym)]
    adm = admissible_sliding_lambdas(F, H, L)
    conds.append(Condition("admissible λ (Q(λ) = [H(F − λI), HL; H, 0] loses row rank)",
                           adm.generic or bool(adm.values), f"{adm.describe()}; {adm.evidence}",
                           "derived from seed 002 eq. (2.5) with Φ_1 = R* H"))
    lv, Rs, Js, Phi, tried = _sliding_row(ar, F, H, D, L, _lambdas(adm, lam, where), where)
    # normalise D* = 1 (any nonzero multiple of the row is a solution)
    scale = sp.cancel(1 / (Phi * D)[0, 0])
    Rs, Js, Phi = (M.applyfunc(lambda e: sp.cancel(e * scale)) for M in (Rs, Js, Phi))
    mats = {"Phi": Phi, "F_star": sp.Matrix([[lv]]), "J_star": Js, "R_star": Rs,
            "H_star": sp.Matrix([[1]]), "G_star": (Phi * G).applyfunc(sp.cancel),
            "D_star": (Phi * D).applyfunc(sp.cancel)}
    if L.cols:
        mats["L_star"] = (Phi * L).applyfunc(sp.cancel)
    xs, ys = observer_symbols(1), output_symbols(st.l)
    subs_ids, nonlinear = [], []
    if C.cols:
        mats["C_star"] = (Phi * C).applyfunc(sp.cancel)
        ok, why, subs_ids, nonlinear = substitute_arguments(st, Phi, xs, ys)
        if not ok:
            raise InfeasibleDesignError(f"{where}: sliding row Φ_1 = {list(Phi)}: {why}")
    plant = dict(F=F, G=G, H=H, C=C, D=D, L=L)
    cert = ar.certify(plant, mats, substitutions=subs_ids, decoupled=True)
    conds += _row_conditions(lv, Phi, Rs, mats, fsym, dec, cert)
    states, update, outputs = sliding_equations(mats, work.inputs, xs, ys, fsym.name, injection,
                                                nonlinear=nonlinear, q=C.cols)
    design0 = Design(
        model_name=work.name, form="jordan", k=1, matrices=mats, conditions=tuple(conds),
        assumptions=(), certificate=cert, task=task, structure=st, symbolic=False,
        method="exact", choice="", attempts=tuple(tried), time="continuous",
        lambdas=(lv,), nonlinear=tuple(nonlinear), equations=update,
        observer_states=states, outputs=outputs)
    gb = gain_bound(work, design0, delta=delta, lipschitz=lipschitz)
    k1v = float(k1) if k1 is not None else gain_margin * gb.bound
    if not k1v > 0:
        raise UsageError(f"k1 must be positive, got {k1v}")
    choice = (f"λ = {lv}, Φ_1 = R* H with R* = {list(Rs)} (normalised to D* = 1); k1 = {k1v:.6g}"
              + (" (given)" if k1 is not None else f" = {gain_margin:g} × bound {gb.bound:.6g}")
              + f", ε = {eps:g}, δ = {delta:g}, injection {injection}")
    params = {K1: sp.Float(k1v), EPS: sp.Float(eps)}
    if injection == "sign":
        params = {K1: sp.Float(k1v), TAU: sp.Float(tau)}
    return dataclasses.replace(design0, conditions=tuple(conds) + _gain_conditions(
                                   gb, k1v, eps, tau, injection), choice=choice,
                               parameters=params,
                               sliding_inputs=SlidingGainInputs(
                                   float(delta), None if lipschitz is None else float(lipschitz)))


def _matching(ar, H, D, where, fsym) -> Condition:
    """The matching condition rank(H D) = rank(D), necessary: refused when it fails."""
    rHD, rD = ar.rank(H * D), ar.rank(D)
    if rD == 0:
        raise InfeasibleDesignError(f"{where}: fault '{fsym}' does not enter the dynamics (D = 0)")
    if rHD != rD:
        raise InfeasibleDesignError(
            f"{where}: matching condition rank(HD) = rank(D) fails for fault '{fsym}'"
            f" (rank HD = {rHD}, rank D = {rD}): it does not enter a measured direction,"
            " no sliding-mode observer on a measured row exists")
    return Condition("matching condition rank(HD) = rank(D)", True,
                     f"rank HD = {rHD} = rank D (H D = {list(H * D)})", "seed 002 §5; METHOD §4")


def _lambdas(adm, lam, where) -> list:
    """The λ to try: the requested one (admissible and stable), −1 when every λ is
    admissible, else the admissible stable values in increasing abs(λ)."""
    if lam is not None:
        lv = rationalize_floats(sp.sympify(lam)) if not isinstance(lam, sp.Basic) else lam
        if not adm.contains(lv):
            raise InfeasibleDesignError(f"{where}: λ = {lv} is not admissible for a measured"
                                        f" sliding row (admissible: {adm.describe()})")
        if is_stable(lv, "continuous") is not True:
            raise InfeasibleDesignError(f"{where}: λ = {lv} is not stable (needs λ < 0)")
        return [lv]
    if adm.generic:
        return [sp.Integer(-1)]
    candidates = [v for v in adm.values if is_stable(v, "continuous") is True
                  and not v.has(sp.CRootOf)]
    candidates.sort(key=lambda v: (-float(v)))
    if not candidates:
        raise InfeasibleDesignError(f"{where}: no stable admissible λ for a measured sliding"
                                    f" row: {adm.describe()} ({adm.evidence})")
    return candidates


def _sliding_row(ar, F, H, D, L, candidates, where):
    """The first λ and member (R*, −J*) of the left null space of Q(λ) whose measured row
    Φ_1 = R* H has Φ_1 D ≠ 0: ``(λ, R*, J*, Φ_1, the members rejected)``."""
    l = H.rows  # noqa: E741
    chosen, tried = None, []
    for lv in candidates:
        basis = ar.left_null_space(sliding_pencil(F, H, L, lv))
        for v in echelon_rows([basis[i, :] for i in range(basis.rows)]):
            Rs, Js = v[:, :l], -v[:, l:]
            Phi = (Rs * H).applyfunc(sp.cancel)
            Ds = (Phi * D).applyfunc(sp.cancel)
            if Ds[0, 0] != 0:
                chosen = (lv, Rs, Js, Phi)
                break
            tried.append(f"λ = {lv}: member Φ_1 = {list(Phi)} has Φ_1 D = 0")
        if chosen:
            break
        if not basis.rows:
            tried.append(f"λ = {lv}: Q(λ) has full row rank")
    if chosen is None:
        raise InfeasibleDesignError(
            f"{where}: no measured row Φ_1 = R* H with Φ_1 D ≠ 0 and Φ_1 L = 0: "
            + "; ".join(tried), tuple(tried))
    return (*chosen, tried)


def _row_conditions(lv, Phi, Rs, mats, fsym, dec, cert) -> list:
    """λ stable, the measured row, its fault sensitivity, the decoupling, the certificate."""
    return [
        Condition(f"λ = {lv} stable", True, "λ < 0 (continuous time)", "METHOD §2b"),
        Condition("measured row Φ_1 = R* H", True,
                  f"Φ_1 = {list(Phi)} = R* H with R* = {list(Rs)}: y* = R* y", "seed 002 §5"),
        Condition(f"fault sensitivity Φ_1 D ≠ 0 ({fsym})", True,
                  f"D* = Φ_1 D = {mats['D_star'][0, 0]}", "seed 002 §5"),
        Condition("decoupling Φ_1 L = 0", True,
                  f"from {', '.join(s.name for s in dec)}" if dec else "nothing to decouple",
                  "METHOD §2"),
        Condition("certificate", cert.passed, cert.summary(), "METHOD §2"),
    ]


def _gain_conditions(gb, k1v, eps, tau, injection) -> tuple:
    """The gain bound's terms and verdict, and the injection's step-size note."""
    gconds = gb.conditions(k1v, eps if injection == "regularised" else None)
    if injection == "regularised":
        gconds.append(Condition("RK4 step for the regularised injection", True,
                                f"slope k1/ε = {k1v / eps:.4g} at e = 0: fixed-step RK4 needs"
                                f" dt < {RK4_STABILITY * eps / k1v:.3g}",
                                "RK4 stability interval", required=False))
    else:
        gconds.append(Condition("discontinuous injection", True,
                                f"sign(e) chatters with amplitude ≈ k1·dt = {k1v:.3g}·dt under a"
                                f" fixed step; v_eq is its low-pass average (τ = {tau:g}): lag"
                                " ≈ τ·|ḋ|, ripple ≈ dt/τ", "", required=False))
    return tuple(gconds)


def reaching_time(t, r, threshold: float):
    """First time after which abs(r) ≤ threshold at every later sample (None if never)."""
    t, r = np.asarray(t, dtype=float), np.abs(np.asarray(r, dtype=float))
    bad = np.nonzero(~(r <= threshold))[0]
    if bad.size == 0:
        return float(t[0])
    if bad[-1] == t.size - 1:
        return None
    return float(t[bad[-1] + 1])

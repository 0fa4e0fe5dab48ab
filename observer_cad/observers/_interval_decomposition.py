"""The γ-shift (mixed-monotone) decomposition of an interval observer's rows (METHOD §3;
the method is described in :mod:`observer_cad.observers`' interval observer).

A row whose right-hand side f_i is monotone neither jointly nor term by term in an
argument v (sin x*, exp(−|x1 − x2|)) is bounded through f_i + γ v (γ = −a, nondecreasing)
or f_i − γ v (γ = b, nonincreasing), ∂f_i/∂v ∈ [a, b] proven; the width w = x̄* − x̲* of
the interval then obeys the comparison system w' ≤ M w + c (discrete: w(t+1) ≤ M w(t) + c),
and the observer is built only when M is provably stable (α(M) < 0, resp. ρ(M) < 1; exact
M-matrix test).

``red`` below is the interval observer's reduced model (its symbols, F*, the nonlinear
terms, the noise box and ``f_row``/``d_range``).
"""
from __future__ import annotations

import dataclasses

import sympy as sp

from ..analysis import format_number, range_sign
from ..errors import InfeasibleDesignError
from ..numerics import comparison_stability
from ..synthesis import Condition

__all__ = ["decomposed_row", "decomposition_conditions", "interval_text"]


def interval_text(lo, hi):
    """``[lo, hi]`` with the numbers formatted as the reports print them."""
    return f"[{format_number(lo)}, {format_number(hi)}]"


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
        return (f"row {self.row + 1}, {self.var}: ∂f/∂{self.var} ∈ {interval_text(self.lo, self.hi)},"
                f" γ = {format_number(self.gamma)} ({g} monotone; Lipschitz bound"
                f" {format_number(sp.Max(abs(self.lo), abs(self.hi)))})")


def decomposed_row(red, i):
    """Row i by the γ-shift (METHOD §3): for every argument v whose ∂f_i/∂v ∈ [a, b]
    changes sign, f_i + γ v with γ = −a is nondecreasing in v (or f_i − γ v with γ = b
    nonincreasing; the smaller γ is taken), so with v ∈ [v̲, v̄]

        f_i ≥ (f_i + γ v)(v̲) − γ v̄ = f_i(v̲) − γ (v̄ − v̲),   f_i ≤ f_i(v̄) + γ (v̄ − v̲)

    and the −γ v part joins the linear part. The other arguments take the end their
    sign gives, as in the joint embedding. Returns (lower, upper, shifts)."""
    time, xs, yt, ys, xl, xu = red.time, red.xs, red.yt, red.ys, red.xl, red.xu
    off_lo, off_hi = red.off_lo, red.off_hi
    out_shifts = []
    lo_x, hi_x, lo_y, hi_y = [], [], [], []
    pen = sp.Integer(0)
    for v, lo_v, hi_v, width, lo_out, hi_out in (
            [(xs[j], xl[j], xu[j], xu[j] - xl[j], lo_x, hi_x) for j in range(len(xs))]
            + [(yt[m], ys[m] + off_lo[m], ys[m] + off_hi[m], off_hi[m] - off_lo[m], lo_y, hi_y)
               for m in range(len(yt))]):
        a, b, kinds = red.d_range(i, v)
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
                f" {interval_text(a, b)} is known from samples only: no proven γ for the γ-shift")
        if a == -sp.oo and b == sp.oo:
            raise InfeasibleDesignError(
                f"interval observer: row {i + 1} is not monotone in {v} and not Lipschitz in it"
                f" (∂f{i + 1}/∂{v} ∈ {interval_text(a, b)}): no finite γ for the γ-shift")
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
    return red.f_row(i, lo_x, lo_y) - pen, red.f_row(i, hi_x, hi_y) + pen, out_shifts


def _width_matrix(red, how_rows, shifts):
    """M of the comparison system for the width w = x̄* − x̲* ≥ 0: w' ≤ M w + c
    (continuous, M Metzler) or w(t+1) ≤ M w(t) + c (discrete, M ≥ 0). By the mean value
    theorem along the corners of each row, with [a, b] the proven range of ∂f_i/∂x*_j:
    M_ii = b in continuous time (the comparison principle keeps x*_i on its face),
    b for a nondecreasing argument, −a for a nonincreasing one, b − a + γ for a
    γ-shifted one, and for a row bounded term by term the sum over its pieces."""
    k, time, xs, Fs, terms, d_range = red.k, red.time, red.xs, red.Fs, red.terms, red.d_range
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


def decomposition_conditions(red, how_rows, shifts, dom, sampled_only):
    """The two required conditions of a decomposed observer (the γ used, with the
    derivative bounds and the domain they hold on; the comparison system's stability),
    or a one-line refusal when the comparison system is not provably stable."""
    k, time, args_info = red.k, red.time, red.args_info
    M = _width_matrix(red, how_rows, shifts)
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
        f"Ψ*_{j}: {arg} ∈ {interval_text(lo, hi)}" for (j, arg, (lo, hi), _) in args_info)) \
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

"""Conditioning of a design: how large Φ is against the measured rows, and how strongly
measurement noise on y reaches the design's output.

An exact design can be numerically useless: with k4 = 1e−12 the electric drive's ρ
estimator has Φ entries of 3.6e9 and amplifies the noise on y by ~1e12, yet every
synthesis condition holds. :func:`conditioning_condition` reports two numbers, at the
model's parameter defaults (symbolic designs) or as designed (numeric ones), with
‖A‖₁ the sum of the absolute values of A's entries:

- **scale of Φ**: max abs(Φ_ij) / max abs(H_ij). In both forms the rows of Φ are combinations
  of the measured rows H Fⁱ (the canonical form has Φ_1 = R* H with R*'s leading entry
  1), so a large ratio means rows that cancel: the reduced model lives on tiny
  differences of large numbers.
- **noise gain**: a bound on the output change caused by a unit error on every output
  y_i within one step of the observer, for the output the design serves:

  - an estimate z = H_z x* + Q y (virtual sensors, interval observers):
    ‖Q‖₁ + ‖H_z‖₁ (‖J*‖₁ + ‖K‖₁ ‖R*‖₁);
  - a residual r = R* y − H* x* (diagnostic observers):
    ‖R*‖₁ + ‖H*‖₁ (‖J*‖₁ + ‖K‖₁ ‖R*‖₁);
  - an unknown-input estimate d̂ = (x*(t+1) − F* x* − J* y − G* u)_i / D*_i (unknown-input
    and sliding-mode estimators), x* recovered from y through R* and J*:
    (‖R*‖₁ + ‖J*‖₁)(1 + ‖F*‖₁) / min_i abs(D*_i) over the nonzero D*_i.

  (K and R* count as 0 where the design has none.)

The condition (built by :class:`~observer_cad.synthesis.Design` for every design) holds when both are at most :data:`CONDITIONING_LEVEL` (1e6); otherwise it
is reported as not holding, with ``required=False``: the design is exact, but its
numbers should not be trusted to more than about log10(16 digits / ratio) digits, and
noise is amplified accordingly.
"""
from __future__ import annotations

import math

import sympy as sp

__all__ = ["CONDITIONING_LEVEL", "CONDITIONING_NAME", "CONDITIONING_REFERENCE",
           "conditioning_numbers", "conditioning_verdict"]

#: Above this, the scale of Φ or the noise gain is reported as ill-conditioned.
CONDITIONING_LEVEL = 1e6
#: The name of the condition (one per design).
CONDITIONING_NAME = "conditioning: scale of Φ and noise gain"
CONDITIONING_REFERENCE = "README: Conditioning"


def _values(M, subs):
    """abs(entries) of M as floats at the parameter values, or None if a symbol remains."""
    if M is None:
        return []
    M = sp.ImmutableMatrix(M)
    if M.rows == 0 or M.cols == 0:
        return []
    rep = getattr(M, "_rep", None)
    dom = getattr(rep, "domain", None)
    if dom is not None and (dom.is_ZZ or dom.is_QQ or dom.is_RR):  # numeric: no sympy per entry
        return [_abs_float(v) for v in rep.to_list_flat()]
    if M.free_symbols:
        M = M.xreplace(subs)
        if M.free_symbols:
            return None
    out = []
    for e in M:
        try:
            out.append(abs(complex(e)))
        except (TypeError, ValueError):
            return None
    return out


def _abs_float(v) -> float:
    """abs(v) as a float; ∞ for an exact number beyond the floating-point range (reported as
    ill-conditioned, not an OverflowError)."""
    try:
        return abs(float(v))
    except OverflowError:
        return math.inf


def _norm1(vals) -> float:
    return float(sum(vals)) if vals else 0.0


def conditioning_numbers(kind: str, matrices, H, parameters=None):
    """``(scale of Φ, noise gain, what the gain maps to)`` for a design's matrices, or
    ``None`` when a parameter without a value remains. ``kind``: the observer kind;
    ``H``: the plant's output matrix; ``parameters``: symbol → value."""
    subs = {k: v for k, v in (parameters or {}).items() if v is not None}
    m = matrices
    get = {name: _values(M, subs) for name, M in
           (("Phi", m.Phi), ("H", H), ("F", m.F_star), ("J", m.J_star), ("R", m.R_star),
            ("Hs", m.H_star), ("D", m.D_star), ("Hz", m.Hz), ("Q", m.Q), ("K", m.K))}
    if any(v is None for v in get.values()):
        return None
    h = max(get["H"], default=0.0)
    phi = max(get["Phi"], default=0.0)
    scale = phi / h if h > 0 else (math.inf if phi > 0 else 0.0)
    J, R, K = _norm1(get["J"]), _norm1(get["R"]), _norm1(get["K"])
    through_state = J + K * R
    if m.Hz is not None and m.Q is not None:
        gain, what = _norm1(get["Q"]) + _norm1(get["Hz"]) * through_state, "z"
    elif kind in ("unknown-input", "sliding-mode") and get["D"] and any(get["D"]):
        dmin = min(v for v in get["D"] if v > 0)
        gain = (R + J) * (1 + _norm1(get["F"])) / dmin
        what = "the unknown-input estimate"
    else:
        gain, what = R + _norm1(get["Hs"]) * through_state, "the residual r"
    return scale, gain, what


def conditioning_verdict(nums, *, at_defaults: bool = False):
    """``(holds, detail)`` for :func:`conditioning_numbers`' result against
    :data:`CONDITIONING_LEVEL` (``nums`` None: not evaluated, holds)."""
    if nums is None:
        return True, "not evaluated: a parameter has no default value"
    scale, gain, what = nums
    level = CONDITIONING_LEVEL
    ok = scale <= level and gain <= level
    at = " at the parameter defaults" if at_defaults else ""
    detail = (f"max|Φ|/max|H| = {scale:.3g}, noise gain y → {what} ≤ {gain:.3g}{at}"
              f" (level {level:.0e})")
    if not ok:
        worst = [t for t, v in (("Φ", scale), ("noise gain", gain)) if v > level]
        detail += (f"; ill-conditioned ({' and '.join(worst)} above the level): the design"
                   " is exact, but rounding and measurement noise are amplified up to"
                   f" ~{max(scale, gain):.1e}-fold")
    return ok, detail

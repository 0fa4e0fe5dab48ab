"""Does a set of Jordan rows do the task? (METHOD §2b: rank [Φ; H] < rank Φ + rank H and
every fault seen, for a residual; z = M x reachable; the argument substitution of §2c.)

References: seed 002 eqs. (2.7), (3.2), (6.3), Remark 1; METHOD §2b, §2c.
"""
from __future__ import annotations

import sympy as sp

from ...numerics import left_null_echelon
from ..certificates import residual_response
from ..core import observer_symbols, output_symbols, substitute_arguments
from ._admissible import rank_of

__all__ = ["residual_pair", "rows_satisfy_task"]


def residual_pair(Phi, H, pivots: set | None = None):
    """(R*, H*) with R* H = H* Φ, H* ≠ 0: the first such member (reduced echelon), or None;
    the rank decision's pivot conditions are added to ``pivots`` when given."""
    l, k = H.rows, Phi.rows
    nb, rk = left_null_echelon(sp.Matrix.vstack(H, Phi))
    if pivots is not None:
        pivots |= rk.conditions
    nb = [v for v in nb if v[:, l:] != sp.zeros(1, k)]
    if not nb:
        return None
    return nb[0][:, :l], -nb[0][:, l:]


def _task_holds(observer, Phi, H, D, M, st, names=()):
    """(True, "") when the rows Φ do the task, else (False, why not)."""
    PH = sp.Matrix.vstack(Phi, H)
    rPH = rank_of(PH)
    if observer == "diagnostic":
        for c in range(D.cols):
            if (Phi * D[:, c]).applyfunc(sp.cancel) == sp.zeros(Phi.rows, 1):
                nm = names[c] if c < len(names) else f"fault column {c + 1}"
                return False, f"{nm} is not seen (Φ D_{nm} = 0)"
        if not rPH < rank_of(Phi) + rank_of(H):
            return False, f"rank [Φ; H] = {rPH} is not < rank Φ + rank H (no residual)"
    if M is not None:
        r = rank_of(sp.Matrix.vstack(PH, M))
        if r != rPH:
            return False, f"rank [Φ; H] = {rPH} < rank [Φ; H; M] = {r} (z not reachable)"
    if st.terms:
        ok, why, _, _ = substitute_arguments(st, Phi, observer_symbols(Phi.rows),
                                             output_symbols(H.rows))
        if not ok:
            return False, why
    return True, ""


def rows_satisfy_task(rows, size, observer, H, D, M, st, tried, names=()):
    """True when the rows are independent and satisfy the task; records why not."""
    Phi = sp.Matrix.vstack(*[r[1] for r in rows])
    if rank_of(Phi) < size:
        return False
    ok, why = _task_holds(observer, Phi, H, D, M, st, names)
    if ok and observer == "diagnostic":  # the residual itself must respond to every target
        Rs, Hs = residual_pair(Phi, H)
        Fs = sp.diag(*[r[0] for r in rows])
        for c in range(D.cols):
            if residual_response(Phi, Fs, Hs, D[:, c]) == sp.zeros(Hs.rows * Fs.rows, 1):
                nm = names[c] if c < len(names) else f"column {c + 1}"
                ok, why = False, (f"{nm} enters only rows the residual does not read"
                                  " (H* (sI − F*)⁻¹ Φ D = 0)")
                break
    if not ok and len(tried) < 12:
        tried.append(f"k={size}, λ = ({', '.join(str(r[0]) for r in rows)}): {why}")
    return ok

"""The steady-state gain of a residual to a fault: weak against strong detection.

A residual r = R* (y − Gy u) − H* x* with the error e = Φ x − x* (METHOD §1 with output
feedthrough) obeys

    e' = F_cl e + (Φ D_j − (J* + K R*) Dy_j) d_j,     r = H* e + R* Dy_j d_j,

F_cl = F* − K H* once stabilised by output injection x*' = … + K r (F* and no K R* term
when the design has no K: the injected residual carries the fault's output part too).
Its gain to a constant fault is

    g_j = R* Dy_j + H* (λ I − F_cl)⁻¹ (Φ D_j − (J* + K R*) Dy_j),   λ = 0 (continuous),
    1 (discrete),

one entry per residual row. A fault the residual responds to (its signature says
"sensitive") with g_j = 0 in every row is seen only as a transient: a constant fault
leaves no lasting trace in r (Varga 2017, Ch. 3, strong fault detectability at
frequency 0). When λ is an eigenvalue of F_cl (a residual on the stability boundary)
there is no steady state and no gain is reported.

Exact designs decide g_j = 0 exactly (an expression in parameters counts as zero only
when it cancels identically); float designs relative to the size of the terms, with
:data:`~observer_cad.synthesis.certificates.SIGNATURE_RTOL`.
"""
from __future__ import annotations

import sympy as sp

__all__ = ["steady_state_gain", "frequency_gains"]


def _is_float(M) -> bool:
    return any(isinstance(e, sp.Float) or (isinstance(e, sp.Expr) and e.atoms(sp.Float))
               for e in M)


def steady_state_gain(matrices, structure, column, dy=None, *, rtol: float = 1e-8):
    """The residual rows' steady-state gains to an input entering through ``column``
    (n × 1) and, in the outputs, ``dy`` (l × 1, default zero): a tuple of sympy numbers
    or expressions with exact zeros (float designs: entries below ``rtol`` times the
    size of their terms are set to 0), or None (no residual, or no steady state)."""
    R, Hs = getattr(matrices, "R_star", None), getattr(matrices, "H_star", None)
    if R is None or Hs is None:
        return None
    Phi, Fs, J = (sp.Matrix(M) for M in (matrices.Phi, matrices.F_star, matrices.J_star))
    R, Hs = sp.Matrix(R), sp.Matrix(Hs)
    K = getattr(matrices, "K", None)
    Fcl = Fs - sp.Matrix(K) * Hs if K is not None else Fs
    lam = 0 if structure.model.time == "continuous" else 1
    dy = sp.zeros(R.cols, 1) if dy is None else sp.Matrix(dy)
    inject = J + sp.Matrix(K) * R if K is not None else J  # K r carries R* Dy d as well
    b = Phi * sp.Matrix(column) - inject * dy
    A = lam * sp.eye(Fcl.rows) - Fcl
    floats = any(_is_float(M) for M in (Phi, Fs, Hs, R, A, inject))
    try:
        if floats:
            import numpy as np
            An = np.array(A.evalf(), dtype=float)
            if np.linalg.cond(An) > 1 / rtol:
                return None
            x = sp.Matrix(np.linalg.solve(An, np.array(b.evalf(), dtype=float)))
        else:
            if A.rows and sp.cancel(A.det()) == 0:
                return None
            x = A.LUsolve(b) if A.rows else sp.zeros(0, 1)
    except (ValueError, ZeroDivisionError, TypeError):
        return None
    direct, through = R * dy, Hs * x
    out = []
    for i in range(Hs.rows):
        g = sp.cancel(direct[i] + through[i])
        if floats and g.is_number:
            scale = max(abs(float(direct[i])), float(sum(abs(float(Hs[i, j] * x[j]))
                                                          for j in range(x.rows))))
            g = sp.Integer(0) if abs(float(g)) <= rtol * max(scale, 1e-300) else g
        out.append(g)
    return tuple(out)


def frequency_gains(design, frequencies, *, rtol: float = 1e-8) -> dict:
    """The magnitudes of the residual rows' gains to each declared fault (and target) at
    λ = jω (continuous time) or e^{jω} (discrete time), for each ω of ``frequencies``
    (non-negative numbers, rad per time unit or per sample): ``{fault: ((ω, (|g_1|, …)),
    …)}`` — the formula of the module docstring at λ, in floating point (a magnitude
    below ``rtol`` times the size of its terms is 0), ``None`` for an ω where λ is an
    eigenvalue of F_cl. Empty for a design without a residual."""
    import numpy as np
    m = design.matrices
    st = design.structure
    R, Hs = getattr(m, "R_star", None), getattr(m, "H_star", None)
    if R is None or Hs is None or st is None:
        return {}

    def num(M):
        M = sp.Matrix(M)
        if M.free_symbols:
            from ...errors import UsageError
            raise UsageError("gains at a frequency need numeric matrices: drop --symbolic")
        return np.array(M.evalf(), dtype=complex).reshape(M.shape)
    Phi, Fs, J, R, Hs = (num(M) for M in (m.Phi, m.F_star, m.J_star, R, Hs))
    K = getattr(m, "K", None)
    K = num(K) if K is not None else None
    Fcl = Fs - K @ Hs if K is not None else Fs
    inject = J + K @ R if K is not None else J
    model = st.model
    names = [f.name for f in model.faults]
    names += [n for n in design.task.targets if n not in names]
    out = {}
    for n in names:
        col = num(st.unknown_input_columns([n]))
        Dy = st.output_columns([n])
        dy = num(Dy) if Dy.rows else np.zeros((R.shape[1], 1), dtype=complex)
        b = Phi @ col - inject @ dy
        rows = []
        for w in frequencies:
            lam = 1j * float(w) if model.time == "continuous" else np.exp(1j * float(w))
            A = lam * np.eye(Fcl.shape[0]) - Fcl
            if A.size and np.linalg.cond(A) > 1 / rtol:
                rows.append((w, None))
                continue
            x = np.linalg.solve(A, b) if A.size else np.zeros((0, 1))
            g = R @ dy + Hs @ x
            scale = np.abs(R @ dy).ravel() + (np.abs(Hs) @ np.abs(x)).ravel()
            mag = tuple(0.0 if abs(v) <= rtol * max(float(sc), 1e-300) else float(abs(v))
                        for v, sc in zip(g.ravel(), scale))
            rows.append((w, mag))
        out[n] = tuple(rows)
    return out
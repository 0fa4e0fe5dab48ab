"""Jordan-form synthesis in floating point (METHOD §2b), for large numeric linear models.

The float counterpart of :mod:`observer_cad.synthesis`. The admissible λ are those where the
pencil

    P(λ) = A − λ B,    A = [L0 F; H],  B = [L0; 0]    (r × n)

loses row rank. They are computed, not guessed:

* r > n: every λ (a left null vector exists structurally): generic solvability;
* σ_r(P(λ)) negligible at several random λ: the pencil is singular (rank-deficient for
  every λ): generic solvability;
* r = n: the finite generalised eigenvalues of (A, B) (QZ, ``scipy.linalg.eig``);
* r < n: P(λ) loses row rank iff P(λ)ᵀ loses column rank; every such λ is an eigenvalue
  of the square pencil (A − λB) Z for any n × r matrix Z, so the eigenvalues common to two
  random orthonormal Z are the candidates.

Every candidate (real up to a tolerance, finite: |β| of the normalised homogeneous pair
not negligible) is refined by the two-sided Rayleigh step λ ← λ + σ/(uᵀ B v) (u, v the
singular vectors of σ_min(P(λ))) and kept only when σ_min(P(λ)) / σ_1(P(λ)) is below the
tolerance; the evidence gives that ratio and the gap to the next singular value.

The rows then come from the numerical left null space of P(λ) for each chosen λ, the task
conditions (z = M x reachable; a residual seeing every fault) are decided by least
squares / SVD with stated tolerances, and the design is certified on the original
(exact) plant matrices with :func:`~observer_cad.synthesis.certify_design` in float
mode, with a tolerance scaled to the sizes of the products it compares.
"""
from __future__ import annotations

import itertools
from typing import Sequence

import numpy as np
import sympy as sp

from ...progress import report
from ...numerics import SingleThreadBLAS, np_exact, to_sympy_float
from ..certificates import certify_design
from ..core import Condition, Design
from ...errors import ExpressionError, InfeasibleDesignError, UsageError
from ..core import jordan_equations, observer_symbols, output_symbols
from ..core import task_for, task_parts
from ...model import PlantModel, Structure, Task
from ...model import extract_structure, parse_expression
from ...numerics import default_rtol, float_left_null_space, float_rank

__all__ = ["admissible_lambdas_float", "design_jordan_float", "DEFAULT_RTOL"]

#: default relative tolerance on σ_min(P(λ)) / σ_1(P(λ)) for "P(λ) loses row rank"
DEFAULT_RTOL = 1e-9
#: candidates with |β| below this (normalised homogeneous eigenvalue (α, β)) are infinite
_INF_BETA = 1e-8
#: cap on the λ-sets of one size examined by the row searches (in lexicographic order)
_MAX_SETS = 300
#: cap on the λ-sets examined in all
_MAX_TOTAL = 3000
#: relative cut (rows of Φ normalised) for rank Φ = k
_PHI_RTOL = 1e-10
#: certificate: absolute residual norms ≤ this × the largest norm of the compared products
_CERT_RTOL = 1e-10
#: length of the default λ list when every λ is admissible (see :func:`_defaults`)
_N_DEFAULTS = 16
#: continuous-time defaults (see :func:`_defaults`): log-spread over [−8, −1/8], coarsest first
_CONTINUOUS_DEFAULTS = (-1.0, -2.0, -0.5, -3.0, -1.5, -0.25, -4.0, -0.75, -6.0, -1.25, -0.125,
                        -8.0, -2.5, -0.375, -5.0, -1.75)
#: generic case: the sets of size k are drawn from the first max(k + _POOL_SLACK,
#: _POOL_MIN) default λ (see :func:`_pools`)
_POOL_SLACK = 2
_POOL_MIN = 8
#: generic case: a size is left after this many λ-sets failed for the generic reason
_GENERIC_FAILS = 2


# ---------------------------------------------------------------- admissible λ
def _pencil_np(A, B, lam):
    return A - lam * B


def _row_sv(A, B, lam):
    """Singular values of P(λ) (descending, min(r, n) of them) and the singular vectors
    (u, v) belonging to σ_min (the smallest of the min(r, n) values)."""
    P = _pencil_np(A, B, lam)
    U, s, Vt = np.linalg.svd(P, full_matrices=False)
    return s, U[:, -1], Vt[-1, :]


def _rel_sigma(s):
    return float(s[-1] / s[0]) if s.size and s[0] > 0 else 0.0


def _refine(A, B, lam, steps: int = 4):
    """Two-sided Rayleigh steps λ ← λ + σ/(uᵀ B v); keeps the best λ seen."""
    s, u, v = _row_sv(A, B, lam)
    best = (_rel_sigma(s), lam, s)
    for _ in range(steps):
        d = float(u @ B @ v)
        if d == 0.0 or not np.isfinite(d):
            break
        # uᵀ (A − λ B) = σ vᵀ  ⇒  uᵀ(A − (λ + σ/d) B) v = 0 to first order
        lam2 = lam + float(s[-1]) / d
        s2, u2, v2 = _row_sv(A, B, lam2)
        if _rel_sigma(s2) < best[0]:
            best = (_rel_sigma(s2), lam2, s2)
            lam, s, u, v = lam2, s2, u2, v2
        else:
            # the sign of σ is arbitrary: try the other direction once
            lam3 = lam - float(s[-1]) / d
            s3, u3, v3 = _row_sv(A, B, lam3)
            if _rel_sigma(s3) < best[0]:
                best = (_rel_sigma(s3), lam3, s3)
                lam, s, u, v = lam3, s3, u3, v3
            else:
                break
    return best[1], best[2]


def _finite_real_eigs(a, b, imag_tol):
    """Finite, (nearly) real generalised eigenvalues of the square pencil (a, b).

    Returns (real values, number of complex ones, number of infinite ones)."""
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    a = a / na if na else a
    b = b / nb if nb else b
    import scipy.linalg  # here, not at module level: 0.3-0.5 s of imports (issue 14 item 5)
    w = scipy.linalg.eig(a, b, right=False, homogeneous_eigvals=True)
    alpha, beta = w[0], w[1]
    scale = np.sqrt(np.abs(alpha) ** 2 + np.abs(beta) ** 2)
    scale[scale == 0] = 1.0
    alpha, beta = alpha / scale, beta / scale
    real, ncomplex, ninf = [], 0, 0
    for al, be in zip(alpha, beta):
        if abs(be) <= _INF_BETA:
            ninf += 1
            continue
        lam = complex(al / be) * (na / nb if na and nb else 1.0)  # undo the normalisation
        if abs(lam.imag) <= imag_tol * (1.0 + abs(lam.real)):
            real.append(lam.real)
        else:
            ncomplex += 1
    return real, ncomplex, ninf


def _cluster(vals, tol):
    vals = sorted(vals)
    out = []
    for v in vals:
        if out and abs(v - out[-1][-1]) <= tol * (1.0 + abs(v)):
            out[-1].append(v)
        else:
            out.append([v])
    return [float(np.mean(c)) for c in out]


def admissible_lambdas_float(F, H, L0, *, rtol: float | None = None):
    """``(generic, values, evidence)``: the real λ where [L0(F − λI); H] loses row rank.

    Parameters
    ----------
    F, H, L0 : array-like (or numeric sympy matrices)
        n × n, l × n and m0 × n.
    rtol : float, optional
        P(λ) loses row rank when σ_min(P(λ)) ≤ rtol · σ_1(P(λ)) (default
        :data:`DEFAULT_RTOL`).

    Returns
    -------
    generic : bool
        Every λ is admissible (r > n, or the pencil is singular).
    values : list of float
        The admissible real λ, ascending (empty when generic).
    evidence : str
        How it was decided: dimensions, counts of complex / infinite / rejected
        candidates, and for every value σ_min/σ_1 and the gap σ_(min−1)/σ_min.
    """
    F, H, L0 = (np.atleast_2d(np.asarray(np_exact(sp.Matrix(M)) if isinstance(M, sp.MatrixBase)
                                         else M, dtype=float)) for M in (F, H, L0))
    n = F.shape[0]
    H = H.reshape(-1, n) if H.size else np.zeros((0, n))
    L0 = L0.reshape(-1, n) if L0.size else np.zeros((0, n))
    A = np.vstack([L0 @ F, H])
    B = np.vstack([L0, np.zeros((H.shape[0], n))])
    r = A.shape[0]
    tol = DEFAULT_RTOL if rtol is None else float(rtol)
    if r > n:
        return True, [], (f"[L0(F − λI); H] has {r} rows > {n} columns: a left null vector"
                          " exists for every λ (generic solvability)")
    if r == 0:
        return False, [], "[L0(F − λI); H] has no rows: no admissible λ"
    with SingleThreadBLAS():
        # singular pencil: rank deficient at every λ (checked at random λ)
        na, nb = np.linalg.norm(A, 2), np.linalg.norm(B, 2)
        scale = na / nb if nb > 0 else 1.0
        rng = np.random.default_rng(20240611)
        probes = list(scale * rng.standard_normal(3))
        rels = [_rel_sigma(_row_sv(A, B, lam)[0]) for lam in probes]
        if max(rels) <= tol:
            return True, [], (f"σ_min/σ_1 of [L0(F − λI); H] ({r}×{n}) is at most"
                              f" {max(rels):.1e} ≤ tol {tol:.0e} at {len(probes)} random λ:"
                              " singular pencil, every λ is admissible (generic solvability)")
        imag_tol = 1e-6
        if r == n:
            cands, ncx, ninf = _finite_real_eigs(A, B, imag_tol)
            how = f"finite real generalised eigenvalues of the square pencil ({r}×{n}, QZ)"
            nraw = len(cands)
        else:
            sets = []
            ncx = ninf = 0
            for seed in (1, 2):
                g = np.random.default_rng(seed).standard_normal((n, r))
                Z, _ = np.linalg.qr(g)
                c, nc, ni = _finite_real_eigs(A @ Z, B @ Z, imag_tol)
                sets.append(c)
                ncx, ninf = max(ncx, nc), max(ninf, ni)
            match = 1e-4
            cands = [v for v in sets[0]
                     if any(abs(v - w) <= match * (1.0 + abs(v)) for w in sets[1])]
            nraw = len(cands)
            how = (f"wide pencil ({r}×{n}): real eigenvalues common to (A − λB) Z for two random"
                   f" orthonormal Z ({n}×{r}) ({len(sets[0])} and {len(sets[1])} real"
                   f" candidates, {nraw} common)")
        cands = _cluster(cands, 1e-6)
        values, ev, rejected = [], [], []
        for c in cands:
            lam, s = _refine(A, B, c)
            rel = _rel_sigma(s)
            gap = float(s[-2] / s[-1]) if s.size > 1 and s[-1] > 0 else float("inf")
            txt = (f"λ = {lam:.12g}: σ_min/σ_1 = {rel:.2e}, gap σ_{s.size - 1}/σ_{s.size} ="
                   f" {'inf' if gap == float('inf') else f'{gap:.2e}'}")
            if rel <= tol:
                values.append(lam)
                ev.append(txt)
            else:
                rejected.append(txt)
        order = np.argsort(values)
        values = [float(values[i]) for i in order]
        ev = [ev[i] for i in order]
        values2, ev2 = [], []
        for v, e in zip(values, ev):  # refinement may merge neighbours
            if values2 and abs(v - values2[-1]) <= 1e-9 * (1.0 + abs(v)):
                continue
            values2.append(v)
            ev2.append(e)
        evidence = (f"{how}; {ncx} complex and {ninf} infinite eigenvalue(s) not usable;"
                    f" tol σ_min/σ_1 ≤ {tol:.0e}; probes at random λ: σ_min/σ_1 ≥"
                    f" {min(rels):.1e} (regular pencil); admissible: "
                    + ("; ".join(ev2) if ev2 else "none real")
                    + (f"; rejected candidates: {'; '.join(rejected[:6])}" if rejected else ""))
    return False, values2, evidence


# ---------------------------------------------------------------- helpers
def _stable(lam: float, time: str) -> bool:
    return lam < 0 if time == "continuous" else abs(lam) < 1


def _defaults(time: str, count: int):
    """The λ the float path tries when every λ is admissible: a fixed, well-separated set
    of stable values, at most :data:`_N_DEFAULTS` (and at most ``count``) of them.

    Discrete time: the dyadic points of (0, 1), coarsest first: 1/2, 1/4, 3/4, 1/8, 3/8,
    5/8, 7/8, 1/16, … (15 values, spacing ≥ 1/16, nonnegative so F* ≥ 0). Continuous
    time: :data:`_CONTINUOUS_DEFAULTS`, −1, −2, −1/2, −3, −3/2, −1/4, … spread on a log
    scale over [−8, −1/8] around the unit scale.

    Rows for nearby λ are nearly parallel (Φ_λ = J H (F − λI)⁻¹ moves with λ relative to
    the spectrum of F), so crowded λ waste SVDs and give ill-conditioned or spurious row
    combinations: the exact path's discrete list 1/2, 1/4, …, 1/2ⁿ crowds at 0 (1/2⁶⁰ and
    1/2³⁰⁰ give the same P(λ) in floating point), and −1, −2, …, −n crowds in direction
    for |λ| ≫ ‖F‖. Every λ is generically as good as any other here; the list only has to
    be long enough for the rows a design needs (one λ per row), and ``lambdas=`` widens it.
    """
    if time == "continuous":
        vals = list(_CONTINUOUS_DEFAULTS)
    else:
        vals = [j / 2.0 ** e for e in range(1, 5) for j in range(1, 2 ** e, 2)]
    return vals[:max(1, min(count, _N_DEFAULTS))]


class _Families:
    """λ → (PhiB, JB), the rows of the left null space of P(λ) (see :func:`_family`),
    computed on first use: a search that stops at k rows pays the SVDs of the λ it
    looked at, not of the whole list."""

    def __init__(self, A, B, L0, m0, tol):
        self.A, self.B, self.L0, self.m0, self.tol = A, B, L0, m0, tol
        self._fam: dict = {}
        self.evidence: dict = {}

    def get(self, lam):
        """(PhiB on the states, JB), or None when P(λ) gives no nonzero row Φ."""
        if lam not in self._fam:
            report(f"designing (float, Jordan form): null space for λ = {_fmt(lam)}"
                   f" ({len(self._fam) + 1} computed)")
            PhiB_S, JB, fr = _family(self.A, self.B, lam, self.m0, self.tol)
            self.evidence[lam] = fr.evidence()
            self._fam[lam] = None if PhiB_S is None else (PhiB_S @ self.L0, JB)
        return self._fam[lam]

    def __getitem__(self, lam):
        return self._fam[lam]

    def __contains__(self, lam) -> bool:
        return self._fam.get(lam) is not None

    def __iter__(self):
        return (lam for lam, f in self._fam.items() if f is not None)

    def __bool__(self) -> bool:
        return any(f is not None for f in self._fam.values())

    def reached(self, lam_list) -> list:
        """The λ of the list whose null space was computed (in list order)."""
        return [lam for lam in lam_list if lam in self._fam]

    def usable(self, lam_list, count=None) -> list:
        """The first ``count`` λ of the list (all when None) with a nonzero family."""
        out = []
        for lam in lam_list:
            if count is not None and len(out) >= count:
                break
            if self.get(lam) is not None:
                out.append(lam)
        return out


def _pools(fam: _Families, lam_list, narrow: bool):
    """size → the λ the sets of that size are drawn from.

    ``narrow`` (every λ admissible, the default list): the first max(size + 2, 8)
    usable λ. The early exit of the generic case: a λ-set's success depends on its
    values only on a lower-dimensional set, so when the first sets of a size fail, the
    rest of the list (equally generic) would fail the same way; the two spare λ guard
    against a default that happens to be special for this plant (an eigenvalue of F,
    say). Otherwise (admissible values computed, or λ given) every usable λ.

    With ``narrow``, the searches also leave a size after :data:`_GENERIC_FAILS` sets
    failed for the generic reason (no combination of their rows lies in rowspace(H); z
    not reachable): that is a rank condition on [Φ_λ1; …; Φ_λk; H], which holds at
    generic λ exactly when it holds at all but a lower-dimensional set of λ-tuples, so
    the other default sets of that size fail the same way (a design that needs a
    special λ is found by the admissible-λ computation or ``lambdas=``, not by luck)."""
    if not narrow:
        every = fam.usable(lam_list)
        pools = lambda size: every  # noqa: E731
    else:
        pools = lambda size: fam.usable(lam_list, max(size + _POOL_SLACK, _POOL_MIN))  # noqa: E731
    pools.narrow = narrow
    return pools


def _family(A, B, lam, m0, tol):
    """Rows Φ = c PhiB (PhiB orthonormal rows), J* = c JB, from the left null space of P(λ),
    and the FloatRank evidence. Members with Φ = 0 (S = 0) are dropped."""
    P = _pencil_np(A, B, lam)
    N, fr = float_left_null_space(P, rtol=tol)
    if N.shape[0] == 0:
        return None, None, fr
    S, V = N[:, :m0], N[:, m0:]
    U, s, Wt = np.linalg.svd(S, full_matrices=False)
    keep = s > 1e-6 * s[0] if s.size else np.zeros(0, bool)
    if not np.any(keep):
        return None, None, fr
    U, s, Wt = U[:, keep], s[keep], Wt[keep]
    C = (U / s).T  # coefficient rows on N: C S = Wt (orthonormal)
    return Wt, -(C @ V), fr  # PhiB_S (on L0's rows), JB


def _phi_fr(Phi, tol):
    nr = np.linalg.norm(Phi, axis=1)
    nr[nr == 0] = 1.0
    return float_rank(Phi / nr[:, None], rtol=tol)


def _lstsq_rel(Bm, M):
    """X with X Bm ≈ M, and the relative residual ‖X Bm − M‖ / ‖M‖."""
    X, *_ = np.linalg.lstsq(Bm.T, M.T, rcond=None)
    X = X.T
    nm = np.linalg.norm(M)
    return X, float(np.linalg.norm(X @ Bm - M) / (nm if nm > 0 else 1.0))


def _fmt(v: float) -> str:
    return f"{v:.12g}"


# ---------------------------------------------------------------- design
def design_jordan_float(model: PlantModel, *, observer: str, estimate=None,
                        faults: Sequence[str] | None = None, decouple: Sequence[str] = (),
                        lambdas: Sequence | None = None, rtol: float | None = None,
                        task: Task | None = None, structure: Structure | None = None) -> Design:
    """Jordan-form design in floating point (numeric linear models).

    Same semantics as :func:`observer_cad.synthesis.design_jordan` for ``"virtual-sensor"``,
    ``"interval"`` and ``"diagnostic"``; parameters are replaced by their defaults;
    nonlinear terms raise :class:`UsageError`. ``rtol``: relative tolerance of the rank
    decisions on P(λ) (default :data:`DEFAULT_RTOL`). ``structure``: the structure of the
    model with its parameters substituted, when the caller has it already (it is not
    extracted again). Returns a :class:`Design` with ``method="float"`` and a float
    certificate.
    """
    if observer not in ("diagnostic", "virtual-sensor", "interval"):
        raise UsageError(f"Jordan form supports diagnostic, virtual-sensor and interval, not {observer!r}")
    task = task_for(model, task, observer=observer, faults=faults, disturbances=decouple,
                    estimate=estimate)
    with SingleThreadBLAS():
        return _design(model, observer, task, lambdas, rtol, structure)


def _design(model, observer, task, lambdas, rtol, structure=None):
    work = model.substitute_parameters()
    where = model.where
    if work.parameters:
        raise UsageError("the float Jordan path needs numeric parameters (defaults for all)")
    st = structure if structure is not None else extract_structure(work)
    if st.terms or st.C.cols:
        raise UsageError(f"{where}: the float Jordan path handles linear models only (the model"
                         " has nonlinear terms); use the exact path")
    n, l = st.n, st.l  # noqa: E741
    tol = DEFAULT_RTOL if rtol is None else float(rtol)
    res_tol = max(1e-7, 100.0 * tol)

    # Step 1: the task (shared with design_jordan)
    M, fault_syms, dec, Ds, Ls = task_parts(work, st, task)
    decoupled = observer != "interval"
    # read off the structure's exact matrices directly (a mutable copy of a 300×300
    # rational matrix costs sympy ~1 s)
    F, G, H = (np_exact(sp.ImmutableMatrix(X)) for X in (st.F, st.G, st.H))
    D, L = np_exact(Ds), np_exact(Ls)
    Mn = None if M is None else np_exact(M)

    # Step 2: L0 and the admissible λ
    if decoupled and L.shape[1]:
        L0, frL = float_left_null_space(L)
        l0_ev = f"L0: left null space of L, {frL.evidence()}"
    else:
        L0, l0_ev = np.eye(n), "L0 = I" + (" (interval observer: not decoupled)" if not decoupled else "")
    if L0.shape[0] == 0:
        raise InfeasibleDesignError(f"{where}: the disturbances span the whole state space;"
                                    " no decoupled observer exists")
    m0 = L0.shape[0]
    A = np.vstack([L0 @ F, H])
    B = np.vstack([L0, np.zeros((l, n))])
    generic, values, adm_ev = admissible_lambdas_float(F, H, L0, rtol=tol)
    describe = "every λ (generic solvability)" if generic else (
        "λ ∈ {" + ", ".join(_fmt(v) for v in values) + "}" if values else "λ ∈ {} (none real)")
    conds = [Condition("admissible λ", generic or bool(values), f"{describe}; {adm_ev}; {l0_ev}",
                       "METHOD §2b; seed 002 eq. (2.5)")]
    need = "λ < 0" if work.time == "continuous" else "|λ| < 1"
    if lambdas:
        lam_list = []
        for v in lambdas:
            try:
                lam_s = parse_expression(v, where="--lambda", allow_complex=True,
                                         allow_crootof=True)
                lam = complex(lam_s)
            except ExpressionError as exc:
                raise UsageError(f"λ = {v!r} is not a number: {exc.reason}") from None
            except (TypeError, ValueError):
                raise UsageError(f"λ = {v!r} is not a number") from None
            if abs(lam.imag) > 0:
                raise UsageError(f"λ = {v} is not real: the Jordan form needs real λ")
            lam = lam.real
            if not generic:
                s = _row_sv(A, B, lam)[0]
                near = [w for w in values if abs(w - lam) <= 1e-6 * (1.0 + abs(w))]
                if _rel_sigma(s) > tol:
                    if not near:
                        raise InfeasibleDesignError(
                            f"{where}: λ = {_fmt(lam)} is not admissible: [L0(F − λI); H] has"
                            f" full row rank there (σ_min/σ_1 = {_rel_sigma(s):.2e} > tol"
                            f" {tol:.0e}; admissible: {describe})")
                    lam = near[0]  # the computed root, of which λ is a rounding
            if not _stable(lam, work.time):
                raise InfeasibleDesignError(
                    f"{where}: λ = {_fmt(lam)} is not stable in {work.time} time (needs {need})")
            lam_list.append(lam)
    elif generic:
        lam_list = _defaults(work.time, n)
        if Mn is not None and observer != "diagnostic":  # the λ a one-row design needs
            lam1 = _one_row_lambda(F, H, L if decoupled else np.zeros((n, 0)), Mn, tol)
            if lam1 is not None and _stable(lam1, work.time) and \
                    all(abs(lam1 - v) > 1e-9 * (1 + abs(v)) for v in lam_list):
                lam_list.insert(0, lam1)  # first: the narrow generic search stops early
    else:
        lam_list = [v for v in values if _stable(v, work.time)]
        if not lam_list:
            raise InfeasibleDesignError(
                f"{where}: no stable admissible λ: {describe} ({adm_ev})", (adm_ev,))

    # Step 3: the row families (computed as the search reaches each λ)
    fam = _Families(A, B, L0, m0, tol)
    pools = _pools(fam, lam_list, narrow=generic and not lambdas)
    if not pools(1):
        raise InfeasibleDesignError(
            f"{where}: no nonzero row Φ_i for λ in {_lam_set(lam_list)}")

    # Step 4: the rows
    tried = []
    budget = [0]
    try:
        if observer == "diagnostic":
            chosen = _diagnostic_rows(fam, pools, H, D, n, tol, res_tol, tried, budget)
        else:
            chosen = _directed_rows_float(fam, pools, H, Mn, n, tol, res_tol, tried, budget)
    except _Budget:
        chosen = None
    searched = fam.reached(lam_list)
    if chosen is None and observer == "diagnostic":  # name the faults no row sees
        blind = []
        for c, f in enumerate(fault_syms):
            col = D[:, c]
            if all(np.linalg.norm(fam[lam][0] @ col) <= res_tol * np.linalg.norm(fam[lam][0])
                   * max(np.linalg.norm(col), 1e-300) for lam in fam):
                blind.append(f.name)
        if blind:
            dec_txt = f" with {', '.join(task.decoupled)} decoupled" if task.decoupled else ""
            raise InfeasibleDesignError(
                f"{where}: {', '.join(blind)} {'is' if len(blind) == 1 else 'are'} undetectable"
                f"{dec_txt}: every row Φ with Φ L = 0 (λ in {{{', '.join(map(_fmt, searched))}}})"
                f" has " + ", ".join(f"Φ D_{b} ≈ 0" for b in blind) + " (float path)",
                tuple(tried))
    if chosen is None:
        bound = (f"with fewer than n = {n} rows for λ in {_lam_set(searched)}"
                 if not pools.narrow or len(lam_list) >= n - 1 else
                 f"from the default λ {_lam_set(lam_list)} (at most {len(lam_list)} distinct"
                 " λ; give more with lambdas= / --lambda)")
        raise InfeasibleDesignError(
            f"{where}: no Jordan-form {observer} {bound} (float path): " + "; ".join(tried),
            tuple(tried))
    rows, extra = chosen

    # Step 5: the matrices
    k = len(rows)
    lams = [r[0] for r in rows]
    Phi = np.vstack([r[1] for r in rows])
    J = np.vstack([r[2] for r in rows])
    mats_np = {"Phi": Phi, "F_star": np.diag(lams), "J_star": J, "G_star": Phi @ G}
    if observer == "diagnostic":
        mats_np["R_star"], mats_np["H_star"] = extra["R_star"], extra["H_star"]
        mats_np["D_star"] = Phi @ D
    if L.shape[1]:
        mats_np["L_star"] = np.zeros((k, L.shape[1])) if decoupled else Phi @ L
    if Mn is not None:
        X, zres = _lstsq_rel(np.vstack([Phi, H]), Mn)
        mats_np["Hz"], mats_np["Q"] = X[:, :k], X[:, k:]
    mats = {name: to_sympy_float(X) for name, X in mats_np.items()}
    mats["F_star"] = sp.diag(*[sp.Float(v) for v in lams])

    # Step 6: certificate on the exact plant matrices, tolerance scaled to the products
    nrm = np.linalg.norm
    sizes = [nrm(Phi) * nrm(F), nrm(np.diag(lams)) * nrm(Phi), nrm(J) * nrm(H),
             nrm(Phi) * nrm(G), nrm(Phi) * nrm(D), nrm(Phi) * nrm(L)]
    if observer == "diagnostic":
        sizes += [nrm(mats_np["H_star"]) * nrm(Phi), nrm(mats_np["R_star"]) * nrm(H)]
    if Mn is not None:
        sizes += [nrm(Mn), nrm(mats_np["Hz"]) * nrm(Phi), nrm(mats_np["Q"]) * nrm(H)]
    scale = max([1.0] + [float(s) for s in sizes])
    cert_tol = _CERT_RTOL * scale
    plant = dict(F=st.F, G=st.G, H=st.H, C=sp.zeros(n, 0), D=Ds, L=Ls)
    cert = certify_design(plant, mats, M=M, decoupled=decoupled, exact=False, tolerance=cert_tol)

    # Step 7: equations, outputs, conditions
    xs, ys = observer_symbols(k), output_symbols(l)
    equations, outputs = jordan_equations(mats, work.inputs, xs, ys, observer, M)

    for i, lam in enumerate(lams):
        conds.append(Condition(f"λ_{i + 1} = {_fmt(lam)} stable", _stable(lam, work.time),
                               f"{need} ({work.time} time); null space of P(λ): {fam.evidence[lam]}",
                               "METHOD §2b"))
    PH = np.vstack([Phi, H])
    fPH, fP, fH = float_rank(PH), _phi_fr(Phi, tol), float_rank(H)
    if observer == "diagnostic":
        conds.append(Condition(
            "residual condition rank [Φ; H] < rank Φ + rank H", fPH.rank < fP.rank + fH.rank,
            f"rank [Φ; H] = {fPH.rank} ({fPH.evidence()}), rank Φ + rank H = {fP.rank} +"
            f" {fH.rank}", "seed 002 eq. (2.7)"))
        for c, f in enumerate(fault_syms):
            col = Phi @ D[:, c]
            rel = np.abs(col) / np.maximum(nrm(Phi, axis=1) * nrm(D[:, c]), np.finfo(float).tiny)
            seen = [i + 1 for i in range(k) if rel[i] > res_tol]
            conds.append(Condition(f"fault sensitivity ({f.name})", bool(seen),
                                   f"Φ D = [{', '.join(f'{v:.3e}' for v in col)}];"
                                   f" |Φ_i D|/(|Φ_i| |D|) = [{', '.join(f'{v:.1e}' for v in rel)}]"
                                   f" > {res_tol:.0e} for row(s) {seen}", "seed 002 §2, Remark 1"))
        Hs, Fs = mats_np["H_star"], mats_np["F_star"]
        O = np.vstack([Hs @ np.linalg.matrix_power(Fs, i) for i in range(k)])
        fo = float_rank(O)
        conds.append(Condition("observability of (F*, H*)", fo.rank == k,
                               f"observability matrix: {fo.evidence()} (k = {k})", "METHOD §4",
                               required=False))
    if Mn is not None:
        fPHM = float_rank(np.vstack([PH, Mn]))
        conds.append(Condition("z = M x reachable: rank [Φ; H] = rank [Φ; H; M]",
                               zres <= res_tol,
                               f"least squares M ≈ H_z Φ + Q H: relative residual {zres:.2e} ≤"
                               f" {res_tol:.0e}; [Φ; H]: {fPH.evidence()}; [Φ; H; M]:"
                               f" {fPHM.evidence()}", "seed 002 eq. (3.2)"))
        Hz = mats_np["Hz"]
        ztol = res_tol * max(1.0, float(np.max(np.abs(Hz))))
        nonneg = bool(np.all(Hz >= -ztol))
        conds.append(Condition("H_z ≥ 0", nonneg, f"H_z = [{', '.join(f'{v:.6g}' for v in Hz.ravel())}]"
                               + ("" if nonneg else " (the interval bounds use the split H_z⁺, H_z⁻)"),
                               "METHOD §3", required=False))
    if work.time == "continuous":
        conds.append(Condition("F* Metzler", True, "F* is diagonal", "METHOD §3", required=False))
    else:
        nonneg = all(v >= 0 for v in lams)
        conds.append(Condition("F* nonnegative", nonneg,
                               f"diag(F*) = [{', '.join(map(_fmt, lams))}]"
                               + ("" if nonneg else " (interval bounds then use the ⁺/⁻ split)"),
                               "METHOD §3", required=False))
    if not decoupled:
        conds.append(Condition("decoupling", True, "not required (interval observer): L* = Φ L",
                               "METHOD §2b"))
    resid = ", ".join(f"{i.name}: {i.residual}" for i in cert.identities)
    conds.append(Condition("certificate", cert.passed,
                           f"{cert.summary()} (absolute residual norms {resid}; tolerance"
                           f" {_CERT_RTOL:.0e} × {scale:.2e}, the largest norm of the compared products)",
                           "METHOD §2"))
    choice = (f"k = {k}: rows with λ = ({', '.join(map(_fmt, lams))}) from the numerical left"
              f" null spaces of P(λ) for λ in {_lam_set(searched)}; the fewest"
              f" rows that satisfy the {observer} conditions (float path, rtol {tol:.0e},"
              f" residual tolerance {res_tol:.0e})"
              + (f" (smaller sets rejected: {'; '.join(tried[:4])})" if tried else ""))
    return Design(
        model_name=work.name, form="jordan", k=k, matrices=mats, conditions=tuple(conds),
        assumptions=(), certificate=cert, task=task, structure=st, symbolic=False,
        method="float", choice=choice, attempts=tuple(tried), time=work.time,
        lambdas=tuple(sp.Float(v) for v in lams), nonlinear=(), equations=equations,
        observer_states=tuple(xs), outputs=tuple(outputs))


def _one_row_lambda(F, H, L, M, tol):
    """The one λ (or None) at which a one-row virtual sensor / interval observer exists when
    it does not for generic λ (METHOD §2b). Φ ∝ M − Q H needs (Q, J*) E0 = m0 − λ m1 with
    E0 = [H L, H F; 0, H], m0 = (M L, M F), m1 = (0, M) (λ H absorbed into J*): λ enters
    linearly, so it is the coefficient of m1 in the least-squares solution of
    (x, λ) [E0; m1] = m0, kept when the relative residual is below ``tol``-scaled 1e-7 and
    m1 is not in rowspace E0 (then every λ or none works: the defaults decide)."""
    if M.shape[0] != 1:
        return None
    n, l, p = F.shape[0], H.shape[0], L.shape[1]  # noqa: E741
    E0 = np.block([[H @ L, H @ F], [np.zeros((l, p)), H]])
    m0 = np.hstack([M @ L, M @ F])
    m1 = np.hstack([np.zeros((1, p)), M])
    _, r1 = _lstsq_rel(E0, m1)
    if r1 <= max(1e-7, 100.0 * tol):
        return None
    X, res = _lstsq_rel(np.vstack([E0, m1]), m0)
    if res > max(1e-7, 100.0 * tol):
        return None
    return float(X[0, -1])


def _lam_set(lams) -> str:
    """{λ1, λ2, …} for messages; long lists (the n default λ of a large model) abridged."""
    shown = [_fmt(v) for v in lams[:6]]
    more = f", … ({len(lams)} values)" if len(lams) > 8 else ""
    if not more:
        shown = [_fmt(v) for v in lams]
    return "{" + ", ".join(shown) + more + "}"


class _Budget(Exception):
    pass


def _combos(lams, size, tried, budget):
    """The λ-sets of one size in order, at most :data:`_MAX_SETS` of them (noted in tried);
    raises _Budget once :data:`_MAX_TOTAL` sets were examined in all."""
    for i, combo in enumerate(itertools.combinations(lams, size)):
        if i == _MAX_SETS:
            tried.append(f"k={size}: only the first {_MAX_SETS} λ-sets (lexicographic) examined")
            return
        budget[0] += 1
        if budget[0] > _MAX_TOTAL:
            tried.append(f"search stopped after {_MAX_TOTAL} λ-sets in all (at k={size})")
            raise _Budget
        yield combo


def _directed_rows_float(fam, pools, H, M, n, tol, res_tol, tried, budget):
    """Sets of distinct λ, smallest first: M ≈ Σ c_λ PhiB_λ + Q H by least squares."""
    checked, reachable = None, True  # the pool whose reachability was decided last
    for size in range(1, n):
        lams = pools(size)
        if len(lams) < size:
            break
        if lams != checked:
            # shortcut: not reachable with every family of the pool at once -> not
            # reachable by any subset of it
            checked = lams
            allB = np.vstack([fam[lam][0] for lam in lams] + [H])
            _, res_all = _lstsq_rel(allB, M)
            reachable = res_all <= res_tol
            if not reachable:
                msg = (f"M is not in rowspace(H) + Σ_λ rowspace(N_λ L0) over {len(lams)} λ"
                       f" (relative least-squares residual {res_all:.2e} > {res_tol:.0e})")
                if tried and tried[-1].startswith("M is not in rowspace(H)"):
                    tried[-1] = msg  # the latest (widest) pool says it all
                else:
                    tried.append(msg)
        if not reachable:
            continue
        report(f"designing (float, Jordan form): k = {size}, λ-sets from {len(lams)} values")
        fails = 0
        for combo in _combos(lams, size, tried, budget):
            if pools.narrow and fails >= _GENERIC_FAILS:
                break  # generic λ: the other sets of this size fail the same way
            Bm = np.vstack([fam[lam][0] for lam in combo] + [H])
            X, res = _lstsq_rel(Bm, M)
            if res > res_tol:
                fails += 1
                if len(tried) < 12:
                    tried.append(f"k={size}, λ = ({', '.join(map(_fmt, combo))}): z not reachable"
                                 f" (relative residual {res:.2e})")
                continue
            rows, off = [], 0
            for lam in combo:
                PhiB, JB = fam[lam]
                c = X[:, off:off + PhiB.shape[0]]
                off += PhiB.shape[0]
                if M.shape[0] > 1:  # several estimates: a basis of the rows they need
                    _, s, Vt = np.linalg.svd(c, full_matrices=False)
                    c = Vt[s > res_tol * (s[0] if s.size else 0.0)] if s.size and s[0] > 0 else c[:0]
                for ci in c:
                    if np.linalg.norm(ci) > res_tol * np.linalg.norm(M):
                        rows.append((lam, ci @ PhiB, ci @ JB))
            if len({r[0] for r in rows}) != size:
                continue  # a smaller set does it
            Phi = np.vstack([r[1] for r in rows])
            if _phi_fr(Phi, _PHI_RTOL).rank < len(rows):
                continue
            return rows, {}
    return None


def _diagnostic_rows(fam, pools, H, D, n, tol, res_tol, tried, budget):
    """Sets of distinct λ, smallest first: rows Φ_i = c_i PhiB_i with Σ Φ_i ∈ rowspace(H)
    (intersection by SVD of [B; H]) and every fault column seen by some row."""
    nD = np.linalg.norm(D, axis=0)
    nD[nD == 0] = 1.0
    rng = np.random.default_rng(7)

    def seen(Phi):
        rel = np.abs(Phi @ D) / (np.maximum(np.linalg.norm(Phi, axis=1), 1e-300)[:, None] * nD)
        return np.any(rel > res_tol, axis=0) if D.shape[1] else np.zeros(0, bool)

    for size in range(1, n):
        lams = pools(size)
        if len(lams) < size:
            break
        report(f"designing (float, Jordan form): k = {size}, λ-sets from {len(lams)} values")
        fails = 0
        for combo in _combos(lams, size, tried, budget):
            if pools.narrow and fails >= _GENERIC_FAILS:
                break  # generic λ: the other sets of this size fail the same way
            dims = [fam[lam][0].shape[0] for lam in combo]
            Bm = np.vstack([fam[lam][0] for lam in combo])
            BH = np.vstack([Bm, H])
            N, fr = float_left_null_space(BH, rtol=min(tol, default_rtol(BH.shape)))
            X = N[:, :Bm.shape[0]]
            if X.shape[0] == 0 or np.linalg.norm(X) <= res_tol:
                fails += 1
                if len(tried) < 12:
                    tried.append(f"k={size}, λ = ({', '.join(map(_fmt, combo))}): no combination"
                                 f" of the rows lies in rowspace(H) ({fr.evidence()})")
                continue
            cands = list(N) + [g @ N for g in rng.standard_normal((6, N.shape[0]))]
            why = "no candidate sees every fault with rank Φ = k"
            for v in cands:
                x, h = v[:Bm.shape[0]], v[Bm.shape[0]:]
                rows, used, off = [], [], 0
                for lam, d in zip(combo, dims):
                    PhiB, JB = fam[lam]
                    c = x[off:off + d]
                    off += d
                    used.append(np.linalg.norm(c) > res_tol * np.linalg.norm(x))
                    rows.append([lam, c])
                if not any(used):
                    continue
                # a λ not used by the residual: give it the member most sensitive to the
                # faults the others miss (exact path: any row may see a fault)
                Phi = np.vstack([c @ fam[lam][0] if u else np.zeros(n)
                                 for (lam, c), u in zip(rows, used)])
                miss = ~seen(Phi[used]) if D.shape[1] else np.zeros(0, bool)
                if not all(used):
                    if not np.any(miss):
                        continue  # a smaller set does it
                    for i, u in enumerate(used):
                        if not u:
                            lam = rows[i][0]
                            T = fam[lam][0] @ D[:, miss]
                            uu, _, _ = np.linalg.svd(T, full_matrices=False)
                            rows[i][1] = uu[:, 0]
                    Phi = np.vstack([c @ fam[lam][0] for lam, c in rows])
                    miss = ~seen(Phi)
                if np.any(miss):
                    why = f"fault column(s) {[i + 1 for i in np.flatnonzero(miss)]} not seen (Φ D ≈ 0)"
                    continue
                if _phi_fr(Phi, _PHI_RTOL).rank < size:
                    why = "rank Φ < k"
                    continue
                out = [(lam, c @ fam[lam][0], c @ fam[lam][1]) for lam, c in rows]
                Hs = np.array([[1.0 if u else 0.0 for u in used]])
                # Σ_used Φ_i = x B = −h H
                return out, {"H_star": Hs, "R_star": -h[None, :]}
            if len(tried) < 12:
                tried.append(f"k={size}, λ = ({', '.join(map(_fmt, combo))}): {why}")
    return None

"""Diagnosability analysis: which faults a disturbance-decoupled residual can detect,
which pairs it can tell apart, and the achievable structure matrix.

Problem
-------
Plant (METHOD §1) ``x' = F x + G u + C Ψ + D d + L ρ``, ``y = H x``. A residual
generator of order k is a member ``v = (R*, −J*_1, …, −J*_k)`` of the left null space
of ``(W⁽ᵏ⁾ L⁽ᵏ⁾)`` (METHOD §2a), with rows

    Φ_1 = R* H,   Φ_{i+1} = Φ_i F − J*_i H  (i < k),   Φ_k F = J*_k H,   Φ_i L = 0.

Its residual responds to the fault f iff ``Φ D_f ≠ 0`` (the error system
``e' = (F* − K H*) e + D* f``, ``r = H* e`` is observable). For a set S of inputs to
decouple (the disturbances and possibly other faults) this module answers:

* **detectable**: some member, of some order k, has ``Φ D_f ≠ 0``;
* **minimal order**: the smallest such k;
* **isolable** (f_a from f_b): f_a is detectable with D_b decoupled as well;
* **structure matrix**: for every set of faults decoupled, the faults a single residual
  can stay sensitive to (a row of 0/1).

Method
------
The members of order k never need to be listed. A row φ occurs as row i of some member
of order k iff it can be *reached* from 0 in i steps and *finished* (brought to
``Φ_{k+1} = 0``) in k + 1 − i steps, every row on the way annihilating L; the recursion
is Markov (the next row depends only on the current one and a free J*_i), so reaching
and finishing chains concatenate. With

    A_1 = {R H : R H L = 0},            A_{i+1} = (A_i F + rowsp H) ∩ {φ : φ L = 0},
    B_1 = {φ : φ L = 0, φ F ∈ rowsp H}, B_{j+1} = {φ : φ L = 0, φ F ∈ B_j + rowsp H},

the span of all rows of all members of order k is ``Σ_k = Σ_i A_i ∩ B_{k+1−i}``, so
f has a detecting residual of order k iff ``Σ_k D_f ≠ 0``. The A_i and B_j grow and stop
growing at the first repeat (each is a function of the previous one), after at most n
steps; then ``Σ_k = A_∞ ∩ B_∞`` for every larger k, and f is detectable iff
``(A_∞ ∩ B_∞) D_f ≠ 0``. B_j is kept as the annihilator of the column space
``K_j = Im L + F (K_{j−1} ∩ ker H)`` (K_0 = Rⁿ), the unobservability-subspace
recursion. Every space lives in Rⁿ (n-sized eliminations, not the l(k+1)-row Krylov
matrix), and they are grown only until the question is answered; the tests check ``Σ_k D_f ≠ 0`` against the members of
``(W⁽ᵏ⁾ L⁽ᵏ⁾)`` built with :func:`krylov_blocks` / :func:`member_to_phi`, and
detectability against the normal rank of the system matrix.

A row of the structure matrix with the faults S decoupled: the faults detectable with
S and the disturbances decoupled. A residual sensitive to *all* of them at once exists
because each "Φ D_f ≠ 0" excludes a proper subspace of the members, and a vector space
over an infinite field is not a finite union of proper subspaces.

Exact arithmetic over QQ or QQ(parameters) (:mod:`observer_cad.numerics`): every pivot
divided by and every entry found nonzero is recorded as a condition ``Ne(f, 0)``; under
those conditions the computation specialises unchanged to parameter values, so both the
positive and the negative answers hold there (``assumptions``).

Nonlinear plants (METHOD §2c): a term φ_j(A_j x, u) whose argument is measured
(A_j ∈ rowsp H) is a known signal. Any other term is first decoupled (its column of C
joins L): an answer found that way does not rest on the argument substitution. If that
fails, the term is treated as known (an upper bound on what can be detected) and a
member is searched, order by order, whose Φ passes :func:`substitute_arguments`
(rank [Φ; H] = rank [Φ; H; A_j] for every nonzero column of Φ C); an answer found that
way rests on the substitution and says so. That search tries the reduced-echelon members,
their pairwise sums and one fixed generic combination: a "no" from it is not a proof.

References: METHOD §2a, §2c; seed 000 §3 (canonical form), seed 002 Remark 1 (several
faults); for the geometric reading (Σ_∞ is the annihilator of the smallest
unobservability subspace containing Im L) Massoumnia, Verghese & Willsky, IEEE TAC 34
(1989); for structure matrices Varga, *Solving Fault Diagnosis Problems*, Springer 2017,
§5.2 (achievable specifications).
"""
from __future__ import annotations

import dataclasses
import itertools
import re
from typing import Sequence

import sympy as sp

from ..errors import ModelError, UsageError
from ..model import PlantModel, Structure, parse_estimate
from ..numerics import exact_rank_value
from ..synthesis.core import prepare
from ._analysis_values import (Analysis, FaultAnalysis, PairAnalysis, StrongFault,
                               StructureRow, Suggestion)
from ._orders import GAIN_RTOL, evaluation_points, feedthrough_orders
from ._reach import DiagnosisQuestions, detecting_orders

__all__ = ["analyze", "Analysis", "FaultAnalysis", "PairAnalysis", "StructureRow",
           "StrongFault", "Suggestion", "detecting_orders", "feedthrough_orders",
           "MAX_ENUMERATED_FAULTS", "STRONG_MAX_STATES", "parse_frequencies"]

#: Up to this many faults every set of decoupled faults is enumerated for the structure
#: matrix; above it only the sets of at most two faults (``structure_complete`` False).
MAX_ENUMERATED_FAULTS = 8


def _resolve(model: PlantModel, faults, disturbances):
    where = model.where

    def lookup(name, what, pool):
        sym = model.symbol(str(name)) if not isinstance(name, sp.Symbol) else name
        if sym is None or sym not in pool:
            declared = ", ".join(s.name for s in pool) or "none"
            raise ModelError(f"{where}: unknown {what} '{name}'; declared: {declared}")
        return sym

    pool = tuple(model.faults) + tuple(model.disturbances)
    if faults is None:
        fs = list(model.faults)
    else:
        fs = [lookup(n, "fault", pool) for n in ([faults] if isinstance(faults, str) else faults)]
    if not fs:
        raise UsageError(f"{where}: no faults to analyse (the model declares none; name"
                         " one with --fault)")
    if len(set(fs)) != len(fs):
        raise UsageError("a fault is named twice")
    dist = [r for r in model.disturbances if r not in fs]
    for n in ([disturbances] if isinstance(disturbances, str) else (disturbances or ())):
        s = lookup(n, "fault or disturbance to decouple", pool)
        if s in fs:
            raise UsageError(f"'{s.name}' cannot be both analysed (--fault) and decoupled"
                             " (--disturbance)")
        if s not in dist:
            dist.append(s)
    return fs, dist


def _candidate_rows(work: PlantModel, st: Structure, candidates):
    """(label, row) for every state not measured and every candidate expression."""
    H = sp.Matrix(st.H)
    rH = exact_rank_value(H)
    out = []
    for i, x in enumerate(work.states):
        row = sp.Matrix([[1 if j == i else 0 for j in range(st.n)]])
        if exact_rank_value(sp.Matrix.vstack(H, row)) > rH:
            out.append((str(x), row))
    seen = [row for _, row in out]
    for c in candidates or ():
        M = parse_estimate(work, c, what="--candidate")
        for r in range(M.rows):
            if M[r, :] not in seen:  # a candidate that is a state already listed: once
                seen.append(M[r, :])
                out.append((str(c), M[r, :]))
    return out


def analyze(model: PlantModel, *, faults: Sequence[str] | None = None,
            disturbances: Sequence[str] | None = None,
            candidates: Sequence | None = None, symbolic: bool = False,
            method: str = "auto", rtol: float | None = None,
            structure: Structure | None = None,
            max_enumerated: int = MAX_ENUMERATED_FAULTS,
            frequencies: Sequence | None = (0,)) -> Analysis:
    """Detectability, minimal orders, isolability and the achievable structure matrix.

    Problem: for ``x' = F x + G u + C Ψ + D d + L ρ``, ``y = H x`` and the residual
    generators of METHOD §2a decoupled from ρ, which faults can be detected (Φ D_f ≠ 0),
    with which minimal order k, which pairs isolated, which sets of faults decoupled by
    one residual that stays sensitive to the rest (see the module docstring).

    Parameters
    ----------
    model : PlantModel
    faults : sequence of str, optional
        The faults to analyse (default: every declared fault). A declared disturbance
        may be named: it is then analysed, not decoupled.
    disturbances : sequence of str, optional
        Further faults or disturbances to decouple, besides the model's disturbances
        (default: none). Declared faults not named anywhere are taken as zero.
    candidates : sequence of str or sympy expressions, optional
        Candidate extra outputs (linear in the states) for the suggestions; every
        unmeasured state is always tried.
    symbolic : bool, default False
        Keep parameters as symbols (answers generic, with ``assumptions``); otherwise
        substitute their defaults as exact rationals.
    method : {"auto", "exact", "float"}, default "auto"
        Exact arithmetic, or SVD rank decisions with relative tolerance ``rtol``
        (default 1e-9; the smallest distance of a decision from its cut is reported in
        ``notes``). "auto" takes the float path for numeric models with more than
        ``FLOAT_AUTO_N`` states, as ``design`` does.
    rtol : float, optional
    structure : Structure, optional
        The extracted structure of ``model`` (symbolic only; saves re-extraction).
    max_enumerated : int, default 8
        Up to this many faults every set of decoupled faults is enumerated for the
        structure matrix; above it, only sets of at most two.
    frequencies : sequence of numbers, default (0,)
        The frequencies ω (rad per time unit; per sample in discrete time, in [0, π]) of
        the strong answers: a fault is strongly detectable when a residual's gain to it
        is nonzero at s = jω (z = e^{jω}) for every ω listed (ω = 0: a nonzero
        steady-state gain). Decimals are read as exact rationals ("0.1" is 1/10). None
        or empty: no strong answers.

    Returns
    -------
    Analysis

    Raises
    ------
    ModelError, UsageError
        An unknown fault or disturbance name, or nothing to analyse.
    """
    if rtol is not None and not 0 < rtol < 1:
        raise UsageError(f"rtol {rtol}: a relative tolerance must lie in (0, 1)")
    if method == "float" and symbolic and model.parameters:
        raise UsageError("the float path needs numeric parameters: analyse without --symbolic")
    # the given structure is the model's: the work model's only when parameters are kept
    omegas = parse_frequencies(frequencies, model.time)
    problem = prepare(model, symbolic=symbolic, method=method,
                      structure=structure if (symbolic or not model.parameters) else None)
    work, st = problem.work, problem.structure
    fs, dist = _resolve(work, faults, disturbances)
    for c in candidates or ():  # read (and refused) now, whether or not they are needed
        parse_estimate(work, c, what="--candidate")
    P = DiagnosisQuestions(work, st, fs, dist, method=problem.method, rtol=rtol)
    with P.ops.threads():
        result = _analyze(P, candidates, symbolic, max_enumerated)
        return _with_strong(P, result, omegas)


#: Strong detectability is computed up to this many states (its order-by-order spaces
#: have l (k + 1) rows); above it the analysis says it was skipped.
STRONG_MAX_STATES = 40


def parse_frequencies(frequencies, time: str) -> tuple:
    """The frequencies as exact non-negative rationals (a decimal string or number is
    read by its decimal digits, never evaluated)."""
    out = []
    for w in frequencies or ():
        text = str(w).strip()
        if isinstance(w, float):
            text = repr(w)
        if len(text) > 40 or not re.fullmatch(
                r"[+]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d{1,3})?(/\d+)?", text):
            raise UsageError(f"frequency '{w}': expected a non-negative number of at most 40"
                             f" characters (rad per"
                             f" {'time unit' if time == 'continuous' else 'sample'})")
        q = sp.Rational(text)
        if q != 0 and not (sp.Rational(1, 10**12) <= q <= 10**12):
            raise UsageError(f"frequency {w}: outside [1e-12, 1e12] (0, or a frequency in that"
                             " range: the gains are evaluated at powers of it)")
        if time != "continuous" and q > sp.Rational(355, 113):
            raise UsageError(f"frequency {w}: a discrete-time frequency lies in [0, π] (rad"
                             " per sample)")
        if q not in out:
            out.append(q)
    return tuple(out)


def _with_strong(P, result: Analysis, omegas) -> Analysis:
    """The analysis with the strong answers (or a note saying why there are none)."""
    if not omegas:
        return result
    where = ", ".join(str(w) for w in omegas)
    if P.n > STRONG_MAX_STATES:
        return dataclasses.replace(result, frequencies=omegas, notes=result.notes + (
            f"strong detectability not computed: {P.n} states > {STRONG_MAX_STATES}",))
    points = evaluation_points(omegas, P.work.time)
    strong, conds = [], set(result.assumptions)
    for r in result.fault_results:
        ok, k, c = P.ask_strong(r.fault, (), points, order=True) if r.detectable \
            else (False, None, frozenset())
        conds |= c
        strong.append(StrongFault(r.fault, ok, k))
    rows = _strong_rows(P, result.structure, points, conds)
    var = "s = jω" if P.work.time == "continuous" else "z = e^{jω}"
    notes = [f"strong detectability: a residual gain ≠ 0 at {var} for ω = {where} (ω = 0:"
             " the steady-state gain; Varga 2017, Ch. 3)"]
    if P.hidden:
        notes.append("strong answers are those with the nonlinear terms of unmeasured"
                     " arguments decoupled")
    if P.work.time != "continuous" and any(w != 0 for w in omegas):
        notes.append(f"gains at e^{{jω}}, ω ≠ 0, decided in floating point (relative"
                     f" tolerance {GAIN_RTOL:.0e})")
    kept = tuple(n for n in result.notes if "special case" not in n)
    failing = _failing_at_defaults(conds, P.work.parameters) if result.symbolic else []
    if failing:  # the strong answers' conditions join the weak ones'
        notes.append(_special_case_note(failing))
    return dataclasses.replace(
        result, frequencies=omegas, strong=tuple(strong), strong_structure=rows,
        assumptions=tuple(sorted(conds, key=str)), notes=kept + tuple(notes))


def _strong_rows(P, weak_rows, points, all_conds) -> tuple:
    """The strong structure matrix (Varga 2017 §5.2 with strong detectability): the
    weak rows whose every 1 can be kept with a nonzero gain at every frequency while the
    row's 0s stay decoupled (one residual has them all: each "gain = 0" is a proper
    subspace of the members), with the least order of such a residual. A weak row that
    loses a fault this way is not a strong row: the fault is still seen, as a transient,
    so it is not decoupled either."""
    out = []
    for row in weak_rows:
        orders = []
        for f in row.sensitive:
            ok, k, conds = P.ask_strong(f, row.requested, points, order=True)
            all_conds |= conds
            if not ok:
                break
            orders.append(k)
        else:
            out.append(dataclasses.replace(row, order=max(orders), via_substitution=False))
    return tuple(out)


def _failing_at_defaults(conditions, parameters) -> list:
    """The conditions (``Ne(f, 0)``) a symbolic answer needs that are false at the
    parameters' defaults (none when a parameter has no default: there is nothing to
    evaluate at)."""
    values = dict(parameters)
    if not values or any(v is None for v in values.values()):
        return []
    return sorted((c for c in conditions if sp.sympify(c).xreplace(values) == sp.false),
                  key=str)


def _analyze(P, candidates, symbolic, max_enumerated) -> Analysis:
    """Steps 1-4 of the module docstring's questions, the notes, and the analysis."""
    work = P.work
    names = tuple(f.name for f in P.faults)
    all_conds: set = set()
    fault_results = _detectability(P, names, all_conds)
    pairs = _isolability(P, names, all_conds)
    structure_rows, complete = _structure_rows(P, names, max_enumerated, all_conds)
    suggestions, unhelped = _suggestions(P, candidates, fault_results, pairs, all_conds)
    notes = _notes(P, len(names), complete, max_enumerated, all_conds, symbolic)
    return Analysis(
        model_name=work.name, time=work.time, faults=names,
        disturbances=tuple(s.name for s in P.dist), symbolic=bool(symbolic and work.parameters),
        fault_results=tuple(fault_results), pairs=tuple(pairs), structure=structure_rows,
        structure_complete=complete, suggestions=tuple(suggestions),
        unhelped=tuple(unhelped), assumptions=tuple(sorted(all_conds, key=str)),
        notes=tuple(notes), candidates=tuple(str(c) for c in (candidates or ())))


def _detectability(P, names, all_conds) -> list:
    """Step 1: detectability and minimal order of each fault, disturbances decoupled."""
    fault_results = []
    for f in names:
        ok, k, sub, conds = P.ask(f, (), order=True)
        all_conds |= conds
        fault_results.append(FaultAnalysis(
            f, ok, k, "" if ok else P.reason(f, (), sub), sub and ok,
            tuple(sorted(conds, key=str))))
    return fault_results


def _isolability(P, names, all_conds) -> list:
    """Step 2: isolability of each pair (a from b: a detectable with b decoupled too)."""
    pairs = []
    for a, b in itertools.combinations(names, 2):
        ab = P.ask(a, (b,), order=True)
        ba = P.ask(b, (a,), order=True)
        all_conds |= ab[3] | ba[3]
        why = []
        if not ab[0]:
            why.append(P.reason(a, (b,), ab[2]))
        if not ba[0]:
            why.append(P.reason(b, (a,), ba[2]))
        pairs.append(PairAnalysis((a, b), ab[0], ba[0], ab[1], ba[1], "; ".join(why),
                                  (ab[2] and ab[0]) or (ba[2] and ba[0]),
                                  tuple(sorted(ab[3] | ba[3], key=str))))
    return pairs


def _structure_rows(P, names, max_enumerated, all_conds):
    """Step 3: the achievable structure matrix rows, and whether every set of decoupled
    faults was enumerated. Larger sets first: f detectable with S decoupled stays
    detectable with any subset of S decoupled (more members), so a positive answer for
    S ∪ {g} settles f for S without computing."""
    m = len(names)
    complete = m <= max_enumerated
    sizes = range(m - 1, -1, -1) if complete else range(min(m - 1, 2), -1, -1)
    known: dict = {}  # (S, f) -> (detectable, via_substitution)
    rows: dict = {}
    for size in sizes:
        for S in itertools.combinations(names, size):
            sens, via = [], False
            for f in names:
                if f in S:
                    continue
                ans = next((known[(T, f)] for g in names if g != f and g not in S
                            for T in [tuple(x for x in names if x in S or x == g)]
                            if known.get((T, f), (False, True)) == (True, False)), None)
                if ans is None:
                    ok, _, sub, conds = P.ask(f, S, order=False)
                    all_conds |= conds
                    ans = (ok, sub)
                known[(S, f)] = ans
                if ans[0]:
                    sens.append(f)
                    via = via or ans[1]
            if not sens:
                continue
            key = tuple(sens)
            if key not in rows or len(S) < len(rows[key].requested):
                rows[key] = StructureRow(S, tuple(f for f in names if f not in sens), key, via)
    return tuple(sorted(rows.values(), key=lambda r: (len(r.decoupled), r.decoupled))), complete


def _suggestions(P, candidates, fault_results, pairs, all_conds):
    """Step 4: one extra measurement for each failing question; the goals none helps."""
    goals = [(r.fault, None) for r in fault_results if not r.detectable]
    for p in pairs:
        a, b = p.faults
        if not p.a_from_b and P.ask(a, (), order=False)[0]:
            goals.append((a, b))
        if not p.b_from_a and P.ask(b, (), order=False)[0]:
            goals.append((b, a))
    cands = _candidate_rows(P.work, P.st, candidates) if goals else []
    suggestions, unhelped = [], []
    for f, other in goals:
        dec = () if other is None else (other,)
        found = False
        for label, row in cands:
            ok, k, _, conds = P.ask(f, dec, order=True, extra=row)
            if ok:
                all_conds |= conds
                suggestions.append(Suggestion(f, other, label, k))
                found = True
        if not found:
            goal = f"detect {f}" if other is None else f"isolate {f} from {other}"
            unhelped.append(goal + (": no single extra measurement among the unmeasured"
                                    " states" + (" and the candidates" if candidates else "")
                                    + " helps" if cands else ": every state is measured"))
    return suggestions, unhelped


def _notes(P, m, complete, max_enumerated, all_conds, symbolic) -> list:
    """What the answers rest on: nonlinear terms, limits, defaults, the float evidence."""
    work, st = P.work, P.st
    notes = []
    if P.hidden:
        args = ", ".join(str((sp.Matrix(st.terms[j].row) * sp.Matrix(work.states))[0, 0])
                         for j in P.hidden)
        notes.append(f"nonlinear terms with unmeasured arguments ({args}): answers are first"
                     " sought with those terms decoupled (Φ C = 0); an answer marked 'via"
                     " argument substitution' rests on rank [Φ; H] = rank [Φ; H; A_j]"
                     " (METHOD §2c) for the member found")
    if not complete:
        notes.append(f"{m} faults > {max_enumerated}: structure-matrix rows enumerated for"
                     " at most two decoupled faults only")
    notes.append("a residual of order k = n is a full-order one; the reduced-order designs"
                 " (design --form canonical) search k < n")
    failing = _failing_at_defaults(all_conds, work.parameters) if symbolic else []
    if failing:
        notes.append(_special_case_note(failing))
    if not P.ops.exact:
        notes.append(f"float path: rank decisions by SVD, cut at {P.ops.cut:.0e}·max(σ_1, 1); the"
                     f" closest decision was {P.ops.margin:.1e} times away from its cut"
                     " (exact: method='exact')")
    return notes


def _special_case_note(failing) -> str:
    return (f"at the parameter defaults {', '.join(str(c) for c in failing)}"
            f" fail{'s' if len(failing) == 1 else ''}: the defaults are a special"
            " case this generic answer does not cover (analyse without --symbolic"
            " for the answer there)")

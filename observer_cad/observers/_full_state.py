"""Intervals for every state (seed 002 §4): with H = (H0 0) up to a permutation of the
states, the measured states come from y through H0⁻¹ (⁺/⁻ split of H0⁻¹ over the noise
box — the split removes the assumption H0⁻¹ ≥ 0, which is reported), the others from an
interval observer for z = (the unmeasured states).
"""
from __future__ import annotations

import sympy as sp

from ..synthesis import Condition
from ..errors import InfeasibleDesignError, UsageError
from ..model import PlantModel, extract_structure
from ..numerics import box_max, box_min
from ._observer import Observer, output_symbols
from ._interval import bounds_box, interval_observer_nonlinear

__all__ = ["full_state_intervals"]


def full_state_intervals(model: PlantModel, *, lambdas=None, margin=None, domain=None) -> Observer:
    """Intervals for every state (seed 002 §4): measured states from y, the others from
    an interval observer. Outputs ``x1_lower``, ``x1_upper``, … in state order.

    Needs H = (H0 0) up to a permutation of the states with H0 invertible (the
    measured states are the columns where H is nonzero). The paper assumes H0⁻¹ ≥ 0;
    here H0⁻¹ is split into ⁺/⁻ over the noise box, so the assumption is only reported.
    """
    work = model.substitute_parameters() if model.parameters else model
    st = extract_structure(work)
    designer = _designer(st)
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
    measured, W, through = _measured_outputs(work, st, ys, W)
    if W.cols:
        if through:  # a missing bound named by its role
            bounds_box(work, through, "the fault or disturbance in the outputs")
        wlo, whi = bounds_box(work, list(work.noise) + through, "noise")
        off_lo, off_hi = -box_max(W, wlo, whi), -box_min(W, wlo, whi)
    else:
        off_lo = off_hi = sp.zeros(l, 1)
    ylo = sp.Matrix(measured) + off_lo
    yhi = sp.Matrix(measured) + off_hi
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
            designs = [designer(work, observer="interval", estimate=est, lambdas=lambdas)]
            groups = [rest]
        except InfeasibleDesignError:
            designs = [designer(work, observer="interval", estimate=str(work.states[j]),
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
        " from an interval observer (seed 002 §4)"
        + ("; reads y − Gy u, the faults and disturbances of the outputs bounded like the noise"
           if st.has_feedthrough else ""))


def _designer(st):
    """design_jordan, or with output feedthrough the entry point that lifts the design
    (observer_cad.synthesis.design: y − Gy u, METHOD §2)."""
    from ..synthesis import design, design_jordan
    return design if st.has_feedthrough else design_jordan


def _measured_outputs(work, st, ys, W) -> tuple:
    """(y − Gy u per output, [W E], the faults and disturbances of E): with output
    feedthrough the measured states read y − Gy u and every fault or disturbance in
    the outputs is bounded like the noise (observers/_interval_feedthrough.py)."""
    if not st.has_feedthrough:
        return list(ys), W, []
    measured = list(ys)
    if work.inputs:
        Gu = sp.Matrix(st.Gy) * sp.Matrix(work.inputs)
        measured = [y - Gu[k] for k, y in enumerate(ys)]
    through = [s for s in list(work.faults) + list(work.disturbances)
               if not st.output_columns([s]).is_zero_matrix]
    if through:
        W = sp.Matrix.hstack(W, sp.Matrix(st.output_columns(through)))
    return measured, W, through

"""Models from where engineers already have them: a python-control ``StateSpace``, a scipy
``lti`` / ``dlti``, or the matrices ``(A, B, C, D)``.

    model = PlantModel.from_statespace(sys, inputs=[0], faults=[1, 2], disturbances=[3],
                                       noise=[4], name="drive")

Each group lists the indices of the system's input columns (columns of B and D) that
play that role; every column is in exactly one group (``inputs`` defaults to the columns
no other group names). The model is

    x' = A x + B u_all,     y = C x + D u_all

with u_all split into inputs u, faults d, disturbances ρ and noise w: a noise column of B
is process noise, a noise column of D measurement noise; a fault column of D is a sensor
fault. Numbers become exact rationals by one rule: a Python or numpy float becomes the
rational of its shortest decimal representation (``repr``: 0.1 is 1/10, not the binary
double 3602879701896397/36028797018963968); integers, fractions and sympy rationals stay
as they are; NaN and infinities are refused, naming the matrix and the entry.

Names: states ``x1 … xn``, inputs ``u1 …``, faults ``f1 …``, disturbances ``rho1 …``,
noise ``w1 …`` — or the system's own labels (python-control's state and input labels)
when they are valid names that the tool does not reserve; ``names=`` overrides either.
Time: continuous for ``dt`` 0 or None, discrete otherwise (time in steps; the sample time
itself is not part of the model).
"""
from __future__ import annotations

import keyword
import math
import numbers
import re
from fractions import Fraction
from typing import Mapping, Sequence

import sympy as sp

from ..errors import DimensionError, ModelError

__all__ = ["statespace_model_arguments", "statespace_matrices"]

_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
_RESERVED = re.compile(r"t|y[0-9]+|xs[0-9]+")


def _exact(value, where: str) -> sp.Rational:
    """A matrix entry as an exact rational (the module docstring's rule)."""
    if isinstance(value, sp.Basic):
        if value.is_Rational:
            return value
        if value.is_Float:
            value = float(value)
        else:
            raise ModelError(f"{where}: {value} is not a real number")
    if isinstance(value, bool):
        raise ModelError(f"{where}: {value!r} is not a number")
    if isinstance(value, numbers.Integral):
        return sp.Integer(int(value))
    if isinstance(value, Fraction):
        return sp.Rational(value.numerator, value.denominator)
    if isinstance(value, numbers.Complex) and not isinstance(value, numbers.Real):
        if complex(value).imag != 0:
            raise ModelError(f"{where}: {value!r} is not real")
        value = complex(value).real
    if isinstance(value, numbers.Real):
        v = float(value)
        if not math.isfinite(v):
            raise ModelError(f"{where}: {value!r} is not a finite number")
        return sp.Rational(repr(v))
    raise ModelError(f"{where}: {value!r} is not a number")


def _matrix(M, rows: int | None, cols: int | None, name: str, where: str) -> sp.Matrix:
    """A 2-D array-like as an exact sympy Matrix of the given shape (None: any)."""
    try:
        data = [list(r) for r in M] if not hasattr(M, "tolist") else M.tolist()
    except TypeError:
        raise ModelError(f"{where}: {name} is not a matrix") from None
    if data and not isinstance(data[0], list):  # a 1-D array: one column
        data = [[v] for v in data]
    r = len(data)
    c = len(data[0]) if r else (cols or 0)
    if any(len(row) != c for row in data):
        raise DimensionError(f"{where}: the rows of {name} have different lengths")
    if (rows is not None and r != rows) or (cols is not None and c != cols):
        raise DimensionError(f"{where}: {name} is {r}×{c}, expected "
                             f"{rows if rows is not None else r}×{cols if cols is not None else c}")
    return sp.Matrix(r, c, [_exact(v, f"{where}: {name}[{i + 1},{j + 1}]")
                            for i, row in enumerate(data) for j, v in enumerate(row)])


def statespace_matrices(sys, *, where: str = "from_statespace"):
    """``(A, B, C, D, time, labels)`` of a python-control ``StateSpace``, a scipy ``lti``
    or ``dlti`` (converted to state space), or a tuple ``(A, B, C, D)``; A … D exact
    rational sympy matrices, ``time`` "continuous" or "discrete" (None for a tuple),
    ``labels`` the system's state and input names where it has them."""
    labels: dict = {}
    time = None
    if isinstance(sys, (tuple, list)):
        if len(sys) != 4:
            raise ModelError(f"{where}: a tuple must be (A, B, C, D), got {len(sys)} items")
        A, B, C, D = sys
    else:
        if hasattr(sys, "to_ss") and not hasattr(sys, "A"):
            sys = sys.to_ss()
        elif type(sys).__module__.startswith("scipy.signal") and hasattr(sys, "to_ss"):
            sys = sys.to_ss()
        if not all(hasattr(sys, k) for k in ("A", "B", "C", "D")):
            raise ModelError(f"{where}: expected a python-control StateSpace, a scipy lti or"
                             f" (A, B, C, D), got {type(sys).__name__}")
        A, B, C, D = sys.A, sys.B, sys.C, sys.D
        dt = getattr(sys, "dt", None)
        time = "continuous" if dt in (None, 0) or dt is False else "discrete"
        for key, attr in (("states", "state_labels"), ("inputs", "input_labels")):
            found = getattr(sys, attr, None)
            if found:
                labels[key] = [str(s) for s in found]
    A = _matrix(A, None, None, "A", where)
    n = A.rows
    if A.cols != n:
        raise DimensionError(f"{where}: A must be square, got {A.rows}×{A.cols}")
    B = _matrix(B, n, None, "B", where)
    C = _matrix(C, None, n, "C", where)
    D = _matrix(D, C.rows, B.cols, "D", where)
    return A, B, C, D, time, labels


def _usable(name: str) -> bool:
    return bool(_NAME.fullmatch(name)) and not keyword.iskeyword(name) \
        and not _RESERVED.fullmatch(name)


def _groups(m: int, inputs, faults, disturbances, noise, where: str) -> dict:
    """role -> column indices, every column in exactly one role."""
    roles = {"faults": faults, "disturbances": disturbances, "noise": noise}
    out, seen = {}, {}
    for role, cols in list(roles.items()) + [("inputs", inputs)]:
        if cols is None:
            continue
        if isinstance(cols, (int, numbers.Integral)) and not isinstance(cols, bool):
            cols = [cols]
        picked = []
        for c in cols:
            if isinstance(c, bool) or not isinstance(c, numbers.Integral):
                raise ModelError(f"{where}: {role} lists {c!r}, not a column index")
            c = int(c)
            if not 0 <= c < m:
                raise ModelError(f"{where}: {role} lists column {c}; the system has {m}"
                                 f" input columns (0 … {m - 1})")
            if c in seen:
                raise ModelError(f"{where}: column {c} is in {seen[c]} and in {role}")
            seen[c] = role
            picked.append(c)
        out[role] = picked
    if inputs is None:
        out["inputs"] = [c for c in range(m) if c not in seen]
        seen.update({c: "inputs" for c in out["inputs"]})
    missing = [c for c in range(m) if c not in seen]
    if missing:
        raise ModelError(f"{where}: input column(s) {', '.join(map(str, missing))} are in no"
                         " group (inputs, faults, disturbances, noise)")
    return out


def statespace_model_arguments(sys, *, inputs: Sequence[int] | None = None, faults: Sequence[int] = (),
                    disturbances: Sequence[int] = (), noise: Sequence[int] = (),
                    name: str = "statespace", time: str | None = None,
                    names: Mapping[str, Sequence[str]] | None = None, **model_options) -> dict:
    """The arguments of :class:`~observer_cad.model.PlantModel` for a state-space system
    (see the module docstring); ``PlantModel.from_statespace(sys, ...)`` builds the model.

    Parameters
    ----------
    sys : control.StateSpace, scipy.signal.lti or dlti, or tuple (A, B, C, D)
    inputs, faults, disturbances, noise : sequences of int
        The input columns (of B and D) in each role; ``inputs`` defaults to the columns no
        other group lists.
    name : str
        The model's name.
    time : {"continuous", "discrete"}, optional
        Needed for a tuple; for a system it must agree with the system's ``dt``.
    names : mapping, optional
        ``{"states": [...], "inputs": [...], "faults": [...], ...}``: the symbols' names.
    **model_options
        Passed to :class:`PlantModel` (``bounds``, ``units``, ``parameters`` …).

    Returns
    -------
    dict
        The model's keyword arguments: its dynamics and outputs written from the matrices,
        exact rationals throughout.

    Raises
    ------
    ModelError, DimensionError
        Shapes that do not fit, an entry that is not a finite real number, a column in two
        groups or in none, a name that is not usable.
    """
    where = f"from_statespace ({name})"
    A, B, C, D, sys_time, labels = statespace_matrices(sys, where=where)
    if time is None:
        if sys_time is None:
            raise ModelError(f"{where}: say time='continuous' or 'discrete' for (A, B, C, D)")
        time = sys_time
    elif sys_time is not None and time != sys_time:
        raise ModelError(f"{where}: time={time!r}, but the system is {sys_time}")
    groups = _groups(B.cols, inputs, faults, disturbances, noise, where)
    default = {"inputs": "u", "faults": "f", "disturbances": "rho", "noise": "w"}
    names = dict(names or {})
    n = A.rows
    state_names = list(names.get("states") or [])
    if not state_names:
        found = labels.get("states", [])
        state_names = found if len(found) == n and all(map(_usable, found)) \
            else [f"x{i + 1}" for i in range(n)]
    if len(state_names) != n:
        raise DimensionError(f"{where}: {len(state_names)} state names for {n} states")
    syms = {"states": tuple(sp.Symbol(s) for s in state_names)}
    sys_inputs = labels.get("inputs", [])
    for role, cols in groups.items():
        given = list(names.get(role) or [])
        if not given:
            own = [sys_inputs[c] for c in cols] if len(sys_inputs) == B.cols else []
            given = own if own and all(map(_usable, own)) else \
                [f"{default[role]}{i + 1}" for i in range(len(cols))]
        if len(given) != len(cols):
            raise DimensionError(f"{where}: {len(given)} {role} names for {len(cols)} columns")
        syms[role] = tuple(sp.Symbol(s) for s in given)
    column = {}  # input column -> its symbol
    for role, cols in groups.items():
        column.update(zip(cols, syms[role]))
    ucol = sp.Matrix([column[c] for c in range(B.cols)]) if B.cols else sp.zeros(0, 1)
    x = sp.Matrix(syms["states"])
    dyn = A * x + (B * ucol if B.cols else sp.zeros(n, 1))
    out = C * x + (D * ucol if B.cols else sp.zeros(C.rows, 1))
    return dict(name=name, time=time, states=list(syms["states"]),
                      inputs=list(syms["inputs"]), faults=list(syms["faults"]),
                      disturbances=list(syms["disturbances"]), noise=list(syms["noise"]),
                      outputs=list(out), dynamics=list(dyn), **model_options)

"""Reference simulator: plant and observer together, in plain numpy (the oracle the
compiled path is checked against).

Scenarios are data (JSON)::

    {"steps": 200,                      # discrete time; or "t_end": 20, "dt": 0.01
     "seed": 1,
     "initial": {"x1": 0, "x2": 0},     # plant initial state (missing: 0)
     "observer_initial": {"xl1": -1},   # optional, overrides the observer's defaults
     "signals": {"u": "0.2*sin(t/10)",  # sympy expression in t (Piecewise allowed)
                 "rho": {"uniform": [-0.05, 0.05]},   # seeded random samples
                 "d": {"piecewise": [["0.3*sin(t/2)", "t <= 20"],
                                     [{"uniform": [-0.5, 0.5]}, true]]}}}

Every input, fault, disturbance and noise not given is zero. Signals are held constant
over a step. Continuous time: plant and observer are integrated as one system by
fixed-step RK4 (the outputs y = H x + W w are evaluated inside the stages, so the
observer sees the plant exactly as the equations say). Discrete time: both step at once.

:func:`simulate` runs one scenario; with ``runs=R`` it runs R seeded realisations of
the random signals at once (vectorised over runs) for Monte-Carlo checks.
"""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Mapping

import numpy as np
import sympy as sp

from ..errors import UsageError
from ..model import PlantModel
from ..observers import Observer, output_symbols

__all__ = ["signal_arrays", "align_delay", "Scenario", "load_scenario", "scenario_from_dict", "simulate", "SimulationResult", "column_units", "T"]

T = sp.Symbol("t")


@dataclasses.dataclass(frozen=True)
class Scenario:
    signals: Mapping
    initial: Mapping
    observer_initial: Mapping | None = None
    steps: int | None = None
    t_end: float | None = None
    dt: float | None = None
    seed: int = 0
    source: str | None = None

    def grid(self, time: str) -> np.ndarray:
        where = self.source or "scenario"
        if time == "discrete":
            if self.steps is None:
                raise UsageError(f"{where}: a discrete-time scenario needs 'steps'")
            return np.arange(int(self.steps), dtype=float)
        if self.t_end is None or self.dt is None:
            raise UsageError(f"{where}: a continuous-time scenario needs 't_end' and 'dt'")
        n = int(round(self.t_end / self.dt))
        return np.arange(n + 1) * float(self.dt)


def load_scenario(path) -> Scenario:
    """Read a scenario JSON file; errors name the file and the key."""
    p = Path(path)
    if not p.is_file():
        raise UsageError(f"{path}: no such scenario file")
    try:
        data = json.loads(p.read_text())
    except json.JSONDecodeError as exc:
        raise UsageError(f"{path}: not valid JSON: {exc}") from None
    return scenario_from_dict(data, source=str(path))


def scenario_from_dict(data: dict, source: str | None = None) -> Scenario:
    where = source or "scenario"
    if not isinstance(data, dict):
        raise UsageError(f"{where}: a scenario is a JSON object")
    known = {"steps", "t_end", "dt", "seed", "initial", "observer_initial", "signals", "description"}
    for key in data:
        if key not in known:
            raise UsageError(f"{where}: unknown key '{key}' (known: {', '.join(sorted(known))})")
    return Scenario(signals=dict(data.get("signals", {})), initial=dict(data.get("initial", {})),
                    observer_initial=data.get("observer_initial"), steps=data.get("steps"),
                    t_end=data.get("t_end"), dt=data.get("dt"), seed=int(data.get("seed", 0)),
                    source=source)


@dataclasses.dataclass(frozen=True)
class SimulationResult:
    """Columns by name: ``t``, the plant states, ``y1…``, every input, fault,
    disturbance and noise, and the observer's outputs. Arrays have shape (N,) for one
    run, (R, N) for ``runs=R``.

    ``order`` is the CSV's column order (noise is a column but not in the CSV);
    ``units`` maps a column to its unit (columns without one are absent, see
    :func:`column_units`); ``model`` and ``time`` name the simulated plant and its time
    domain.
    """

    columns: dict
    order: tuple
    units: Mapping = dataclasses.field(default_factory=dict)
    model: str | None = None
    time: str | None = None

    def __getitem__(self, name):
        return self.columns[name]

    @property
    def runs(self) -> int | None:
        """R for a Monte-Carlo result, None for a single run."""
        t = np.asarray(self.columns["t"])
        return None if t.ndim == 1 else t.shape[0]

    def to_pandas(self):
        """The columns in ``order`` as a ``pandas.DataFrame`` indexed by ``t`` (one run), or
        with a ``(run, t)`` MultiIndex (``runs=R``); ``df.attrs["units"]`` holds the units.

        pandas is optional: without it this raises :class:`ImportError` saying
        ``pip install pandas``.
        """
        try:
            import pandas as pd
        except ImportError:
            raise ImportError("SimulationResult.to_pandas() needs pandas:"
                              " pip install pandas (or pip install 'observer_cad[export]')") from None
        names = [c for c in self.order if c != "t"]
        t = np.asarray(self.columns["t"], dtype=float)
        if t.ndim == 1:
            df = pd.DataFrame({c: np.asarray(self.columns[c], dtype=float) for c in names},
                              index=pd.Index(t, name="t"))
        else:
            R, N = t.shape
            index = pd.MultiIndex.from_arrays([np.repeat(np.arange(R), N), t.reshape(-1)],
                                              names=["run", "t"])
            df = pd.DataFrame({c: np.asarray(self.columns[c], dtype=float).reshape(-1)
                               for c in names}, index=index)
        df.attrs["units"] = {c: u for c, u in self.units.items() if c in self.order}
        if self.model is not None:
            df.attrs["model"] = self.model
        return df

    def _summary(self) -> str:
        t = np.asarray(self.columns["t"], dtype=float)
        n = t.shape[-1]
        unit = "s" if self.time == "continuous" else ("steps" if self.time == "discrete" else "")
        span = f"t = {t.flat[0]:g} … {t.flat[-1]:g}{' ' + unit if unit else ''}" if n else "no samples"
        runs = "" if t.ndim == 1 else f", {t.shape[0]} runs"
        what = f"{self.model!r}, " if self.model else ""
        time = f"{self.time} time, " if self.time else ""
        return f"{what}{time}{n} samples{runs}, {span}, {len(self.order) - 1} signals"

    def __repr__(self) -> str:
        return f"<SimulationResult {self._summary()}>"

    def _label(self, c: str) -> str:
        return f"{c} [{self.units[c]}]" if c in self.units else c

    def _repr_markdown_(self) -> str:
        cols = ", ".join(f"`{self._label(c)}`" for c in self.order if c != "t")
        return f"**SimulationResult** — {self._summary()}\n\ncolumns: {cols}"

    def _repr_latex_(self) -> str:
        t = np.asarray(self.columns["t"], dtype=float)
        cols = ", ".join(r"\mathrm{" + self._label(c).replace("_", r"\_") + "}"
                         for c in self.order if c != "t")
        return (rf"$\text{{SimulationResult: {t.shape[-1]} samples, }}"
                rf"t \in [{t.flat[0]:g}, {t.flat[-1]:g}];\ {cols}$")


def column_units(model: PlantModel, observer: Observer | None, names) -> dict:
    """The unit of every column in ``names`` that has one.

    Plant columns take the model's units (``y_i`` the unit its states share,
    :meth:`PlantModel.output_unit`). Observer outputs inherit their signal's:
    ``x1_hat``, ``x1_lower``, ``x1_upper`` the unit of ``x1``; ``d_hat`` that of ``d``;
    a residual ``r`` (``r1``, …) the unit of the outputs it compares when they share
    one, else none; an estimate of an expression (``z_hat``) has none.
    """
    ys = list(output_symbols(len(model.outputs)))
    out_expr = dict(observer.outputs) if observer is not None else {}
    units = {}
    for name in names:
        u = model.unit_of(name)
        if u is None:
            for suffix in ("_hat", "_lower", "_upper"):
                if name.endswith(suffix) and model.symbol(name[:-len(suffix)]) is not None:
                    u = model.unit_of(name[:-len(suffix)])
                    break
            else:
                if name in out_expr and (name == "r" or (name[:1] == "r" and name[1:].isdigit())):
                    used = sp.sympify(out_expr[name]).free_symbols & set(ys)
                    found = {model.output_unit(ys.index(y)) for y in used}
                    if len(found) == 1:
                        u = found.pop()
        if u is not None:
            units[name] = u
    return units


def signal_arrays(model: PlantModel, sc: Scenario, t: np.ndarray, runs: int):
    where = sc.source or "scenario"
    names = {s.name: s for s in model.inputs + model.faults + model.disturbances + model.noise}
    for key in sc.signals:
        if key not in names:
            raise UsageError(f"{where}: signal '{key}' is not an input, fault, disturbance or"
                             f" noise of {model.name} (known: {', '.join(names) or 'none'})")
    rng = np.random.default_rng(sc.seed)
    out = {}

    def expr_of(spec, what):
        try:
            e = sp.sympify(spec, locals={"t": T}) if isinstance(spec, str) else sp.sympify(spec)
        except (sp.SympifyError, SyntaxError, TypeError) as exc:
            raise UsageError(f"{where}: {what}: cannot parse {spec!r}: {exc}") from None
        if isinstance(e, bool):
            e = sp.true if e else sp.false
        extra = e.free_symbols - {T}
        if extra:
            raise UsageError(f"{where}: {what} uses '{sorted(extra, key=str)[0]}'; only t is allowed")
        return e

    def values(spec, name):
        if isinstance(spec, dict) and set(spec) == {"uniform"}:
            if not isinstance(spec["uniform"], (list, tuple)) or len(spec["uniform"]) != 2:
                raise UsageError(f"{where}: signal '{name}': use {{\"uniform\": [low, high]}}")
            lo, hi = (float(v) for v in spec["uniform"])
            return rng.uniform(lo, hi, size=(runs, t.size))
        if isinstance(spec, dict) and set(spec) == {"piecewise"}:
            # [[value spec, condition in t], ...]: the first true condition wins
            res = np.full((runs, t.size), np.nan)
            taken = np.zeros(t.size, dtype=bool)
            for seg in spec["piecewise"]:
                if not isinstance(seg, (list, tuple)) or len(seg) != 2:
                    raise UsageError(f"{where}: signal '{name}': piecewise segments are"
                                     " [value, condition] pairs")
                vals = values(seg[0], name)
                cond = expr_of(seg[1], f"signal '{name}' condition")
                c = np.broadcast_to(np.asarray(sp.lambdify(T, cond, "numpy")(t), dtype=bool), t.shape)
                use = c & ~taken
                res[:, use] = vals[:, use]
                taken |= c
            return np.where(np.isnan(res), 0.0, res)
        if isinstance(spec, dict):
            raise UsageError(f"{where}: signal '{name}': use an expression in t,"
                             " {\"uniform\": [low, high]} or {\"piecewise\": [[value, condition], ...]}")
        e = expr_of(spec, f"signal '{name}'")
        v = np.broadcast_to(np.asarray(sp.lambdify(T, e, "numpy")(t), dtype=float), t.shape)
        return np.broadcast_to(v, (runs, t.size)).copy()

    for name in sorted(names):
        out[name] = values(sc.signals.get(name, 0), name)
    return out


def align_delay(v: np.ndarray, delay: int) -> np.ndarray:
    """Shift an output produced ``delay`` steps late so that column t holds the estimate of
    time t (NaN where it is not available yet). ``v`` has shape (runs, N)."""
    if not delay:
        return v
    shifted = np.full_like(v, np.nan)
    shifted[:, :-delay] = v[:, delay:]
    return shifted


def _vector_fn(args, exprs):
    """Numpy function of arrays (one per arg) returning a list of arrays (broadcast)."""
    # cse: long expressions (e.g. DREM's determinants) share their subexpressions
    f = sp.lambdify(args, list(exprs), "numpy", cse=True)

    def call(*vals):
        res = f(*vals)
        shape = None
        out = []
        for r in res:
            if np.ndim(r) == 0:  # a constant expression: broadcast to the runs
                if shape is None:
                    shape = np.broadcast_shapes(*(np.shape(v) for v in vals)) if vals else ()
                r = np.full(shape, float(r))
            out.append(r)
        return out
    return call


def simulate(model: PlantModel, observer: Observer | None, scenario: Scenario, *,
             runs: int | None = None) -> SimulationResult:
    """Simulate the plant (parameters at their defaults) with the observer attached."""
    m = model.substitute_parameters() if model.parameters else model
    t = scenario.grid(m.time)
    if observer is not None and observer.time != m.time:
        raise UsageError(f"observer is {observer.time}-time but the model is {m.time}-time")
    R = 1 if runs is None else int(runs)
    N = t.size
    sig = signal_arrays(m, scenario, t, R)
    xs = list(m.states)
    ins = list(m.inputs) + list(m.faults) + list(m.disturbances) + list(m.noise)
    ys = list(output_symbols(len(m.outputs)))
    y_expr = list(m.outputs)
    obs_states = list(observer.states) if observer else []
    par = dict(observer.parameters) if observer else {}
    # the observer sees y = h(x, w) and u
    obs_upd = [sp.sympify(e).xreplace(par) for e in (observer.update if observer else ())]
    obs_out = [sp.sympify(e).xreplace(par) for _, e in (observer.outputs if observer else ())]
    ysub = dict(zip(ys, y_expr))
    joint_args = xs + obs_states + ins
    f_joint = _vector_fn(joint_args, list(m.dynamics) + [e.xreplace(ysub) for e in obs_upd])
    f_y = _vector_fn(xs + ins, y_expr)
    f_out = _vector_fn(obs_states + ys + ins, obs_out) if obs_out else None

    where = scenario.source or "scenario"
    init_names = {s.name: s for s in xs}
    for key in scenario.initial:
        if key not in init_names:
            raise UsageError(f"{where}: initial state '{key}' is not a state of {m.name}")
    x0 = {s: float(scenario.initial.get(s.name, 0.0)) for s in xs}
    X = np.zeros((len(joint_args) - len(ins), R, N))
    for i, s in enumerate(xs):
        X[i, :, 0] = x0[s]
    if observer is not None:
        oinit = dict(scenario.observer_initial or {})
        names = {str(s): s for s in obs_states}
        for key in oinit:
            if key not in names:
                raise UsageError(f"{where}: observer_initial '{key}' is not an observer state"
                                 f" (states: {', '.join(names)})")
        for j, s in enumerate(obs_states):
            if str(s) in oinit:
                v = float(oinit[str(s)])
            else:
                v = float(sp.sympify(observer.initial.get(s, 0)).xreplace(x0))
            X[len(xs) + j, :, 0] = v
    U = np.stack([sig[s.name] for s in ins]) if ins else np.zeros((0, R, N))
    nx = X.shape[0]
    with np.errstate(invalid="ignore"):
        for i in range(N - 1):
            u = [U[j, :, i] for j in range(len(ins))]
            cur = [X[j, :, i] for j in range(nx)]
            if m.time == "discrete":
                nxt = f_joint(*cur, *u)
            else:
                h = t[i + 1] - t[i]
                k1 = f_joint(*cur, *u)
                k2 = f_joint(*[c + h / 2 * k for c, k in zip(cur, k1)], *u)
                k3 = f_joint(*[c + h / 2 * k for c, k in zip(cur, k2)], *u)
                k4 = f_joint(*[c + h * k for c, k in zip(cur, k3)], *u)
                nxt = [c + h / 6 * (a + 2 * b + 2 * cc + d)
                       for c, a, b, cc, d in zip(cur, k1, k2, k3, k4)]
            for j in range(nx):
                X[j, :, i + 1] = nxt[j]
    cols = {"t": np.broadcast_to(t, (R, N)).copy()}
    for j, s in enumerate(xs):
        cols[s.name] = X[j]
    allu = [U[j] for j in range(len(ins))]
    yv = f_y(*[X[j] for j in range(len(xs))], *allu)
    for name, v in zip(ys, yv):
        cols[str(name)] = np.asarray(v)
    for j, s in enumerate(ins):
        cols[s.name] = U[j]
    # CSV order: t, states, outputs, inputs, faults, disturbances (noise kept as a column
    # of the result but not in the CSV order), then the observer's outputs
    order = ["t"] + [s.name for s in xs] + [str(y) for y in ys] + \
        [s.name for s in ins if s not in m.noise]
    if f_out is not None:
        ov = f_out(*[X[len(xs) + j] for j in range(len(obs_states))], *yv, *allu)
        for (name, _), v in zip(observer.outputs, ov):
            cols[name] = align_delay(np.array(v, dtype=float), int(observer.delays.get(name, 0)))
            order.append(name)
    if runs is None:
        cols = {k: v[0] for k, v in cols.items()}
    return SimulationResult(cols, tuple(order), units=column_units(model, observer, cols),
                            model=model.name, time=model.time)

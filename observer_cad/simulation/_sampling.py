"""What varies from run to run: signal programs and per-run draws.

A scenario's signals become a :class:`SignalProgram`: on the time grid, each signal j is

    v_j(t_i) = base[i, j] + su[i, j] · U_j(i) + sn[i, j] · Z_j(i)

with U uniform on [0, 1) and Z standard normal, drawn from the counter-based generator
(:mod:`._random`) keyed by (seed, run, stream 2j / 2j + 1). A number or an expression in t
is ``base`` alone; ``{"uniform": [lo, hi]}`` is base = lo, su = hi − lo;
``{"normal": [mean, std]}`` is base = mean, sn = std; a piecewise signal takes each
segment's coefficients where its condition is the first true one. The deterministic part
is evaluated once (vectorised, cached per scenario); the random part costs a hash per
sample, in numpy here and in C in the compiled loop (same bits).

Per-run quantities — the true plant parameters, the observer's free parameters, the plant
and observer initial states — are drawn by :func:`draw_runs`: ``"sampling": "random"``
(default; stream ``PARAMETER_STREAMS + 2q`` of quantity q), ``"sobol"`` (scrambled Sobol
points, point k for sample k) or ``"lhs"`` (a Latin hypercube over all the samples: the
only method whose draws depend on the number of samples). Quantities are numbered in a
fixed order: plant parameters by name, plant initial states, observer initial states
(model / observer order), observer parameters by name.

Fault cases (``"cases"``) replace signals; sample k of every case uses the same random
numbers (common random numbers), so cases differ only by their faults.
"""
from __future__ import annotations

import dataclasses
import functools
import math
import warnings
from typing import Mapping

import numpy as np
import sympy as sp

from ..errors import UsageError
from ..model import PlantModel, parse_expression
from ..numerics import algebraic_to_float
from ._random import PARAMETER_STREAMS, normal_samples, stream_keys, uniform_samples

__all__ = ["Distribution", "SignalProgram", "signal_program", "RunDraws", "draw_runs",
           "parameter_layout", "ParameterLayout", "SAMPLING_METHODS", "NOMINAL_CASE",
           "check_distribution", "DrawPlan", "draw_plan", "DECLARED"]

#: how per-run quantities are drawn
SAMPLING_METHODS = ("random", "sobol", "lhs")
#: the case name of a scenario without ``"cases"``
NOMINAL_CASE = "nominal"
#: a parameter or signal drawn uniformly over the model's declared box
#: (``uncertainty`` for a parameter, ``bounds`` for a disturbance or noise)
DECLARED = "declared"
_T = sp.Symbol("t")


@dataclasses.dataclass(frozen=True)
class Distribution:
    """A per-run quantity: ``fixed`` (value ``a``), ``uniform`` on [a, b] or ``normal``
    with mean a and standard deviation b."""

    kind: str
    a: float
    b: float = 0.0

    @property
    def random(self) -> bool:
        return self.kind != "fixed" and not (self.kind == "uniform" and self.a == self.b) \
            and not (self.kind == "normal" and self.b == 0)

    def transform(self, u: np.ndarray) -> np.ndarray:
        """Values from uniform samples u ∈ [0, 1) (inverse transform)."""
        if self.kind == "fixed":
            return np.full(np.shape(u), self.a)
        if self.kind == "uniform":
            return self.a + (self.b - self.a) * u
        from scipy.special import ndtri
        return self.a + self.b * ndtri(np.clip(u, 2.0 ** -60, 1 - 2.0 ** -53))

    @staticmethod
    def of(spec) -> "Distribution":
        """From a validated scenario value (a number, {"uniform": …} or {"normal": …})."""
        if isinstance(spec, dict):
            (kind, (a, b)), = spec.items()
            return Distribution(kind, float(a), float(b))
        return Distribution("fixed", float(spec))


# ---------------------------------------------------------------------------- signals
@dataclasses.dataclass(frozen=True, eq=False)
class SignalProgram:
    """The signals of one case on the time grid (see the module docstring).

    ``names`` the signals in the model's order (inputs, faults, disturbances, noise);
    ``base``, ``su``, ``sn`` arrays (N, nv), C-contiguous, read-only; ``random[j]``: signal
    j has a random part; ``normal[j]``: … a normal part."""

    names: tuple
    base: np.ndarray
    su: np.ndarray
    sn: np.ndarray
    random: tuple
    normal: tuple

    @property
    def nv(self) -> int:
        return len(self.names)

    @functools.cached_property
    def columns(self) -> tuple:
        """(base, su, sn) as C-contiguous (nv, N) arrays: one time series per signal
        (what the compiled loop reads)."""
        return tuple(np.ascontiguousarray(a.T) for a in (self.base, self.su, self.sn))

    @functools.cached_property
    def finite(self) -> bool:
        """Every coefficient is finite: then every signal sample is (U ∈ [0, 1), Z finite)."""
        return bool(np.isfinite(self.base).all() and np.isfinite(self.su).all()
                    and np.isfinite(self.sn).all())

    def values(self, seed: int, runs) -> np.ndarray:
        """The signals of ``runs`` (sample indices): array (R, N, nv)."""
        runs = np.atleast_1d(np.asarray(runs, dtype=np.int64))
        N = self.base.shape[0]
        V = np.broadcast_to(self.base, (runs.size, N, self.nv)).copy()
        rnd = [j for j in range(self.nv) if self.random[j]]
        if not rnd:
            return V
        keys = stream_keys(seed, runs, [s for j in rnd for s in (2 * j, 2 * j + 1)])
        for q, j in enumerate(rnd):
            k1, k2 = keys[:, 2 * q], keys[:, 2 * q + 1]
            V[:, :, j] += self.su[:, j] * uniform_samples(k1, N)
            if self.normal[j]:
                V[:, :, j] += self.sn[:, j] * normal_samples(k1, k2, N)
        return V


def _is(spec, key) -> bool:
    return isinstance(spec, dict) and set(spec) == {key}


def _coefficients(spec, t, where, name, bounds=None):
    """(base, su, sn) arrays (N,) of one signal specification (already validated);
    ``bounds`` the signal's declared (low, high) for ``"declared"``."""
    N = t.size
    zero = np.zeros(N)
    if spec == DECLARED:
        if bounds is None:
            raise UsageError(f"{where}: signal '{name}' is \"declared\" but the model declares"
                             " no bounds for it (bounds={...} in the model)")
        spec = {"uniform": [float(bounds[0]), float(bounds[1])]}
    if _is(spec, "uniform"):
        lo, hi = (float(v) for v in spec["uniform"])
        return np.full(N, lo), np.full(N, hi - lo), zero
    if _is(spec, "normal"):
        mu, sd = (float(v) for v in spec["normal"])
        return np.full(N, mu), zero, np.full(N, sd)
    if _is(spec, "piecewise"):
        base, su, sn = np.zeros(N), np.zeros(N), np.zeros(N)
        taken = np.zeros(N, dtype=bool)
        for value, cond in spec["piecewise"]:
            b, u, n = _coefficients(value, t, where, name, bounds)
            if isinstance(cond, bool):
                c = np.full(N, cond)
            else:
                e = parse_expression(cond, {"t": _T}, where=f"{where}: signal '{name}' condition",
                                     condition=True)
                c = np.broadcast_to(np.asarray(_evaluate(e, t, where, name), dtype=bool), (N,))
            use = c & ~taken
            base[use], su[use], sn[use] = b[use], u[use], n[use]
            taken |= c
        if not taken.all():  # (it was 0 there, silently)
            raise UsageError(f"{where}: signal '{name}': no piecewise condition holds at"
                             f" t = {float(t[~taken][0]):g}; add a last segment [value, true]"
                             " for the times the others leave out")
        return base, su, sn
    if isinstance(spec, str):
        e = parse_expression(spec, {"t": _T}, where=f"{where}: signal '{name}'")
        v = np.broadcast_to(np.asarray(_evaluate(e, t, where, name), dtype=float), (N,))
        return v.copy(), zero, zero
    return np.full(N, float(spec)), zero, zero


def _evaluate(e, t, where, name):
    if e is sp.true or e is True:
        return np.ones(t.size, dtype=bool)
    if e is sp.false or e is False:
        return np.zeros(t.size, dtype=bool)
    with np.errstate(all="ignore"):
        try:
            return _lambdified(e)(t)
        except (ArithmeticError, ValueError, TypeError) as exc:
            raise UsageError(f"{where}: signal '{name}': cannot evaluate {e}:"
                             f" {type(exc).__name__}") from None


@functools.lru_cache(maxsize=256)
def _lambdified(e):
    return sp.lambdify(_T, e, "numpy")


def signal_program(model: PlantModel, scenario, t: np.ndarray, *, case: str | None = None
                   ) -> SignalProgram:
    """The :class:`SignalProgram` of ``scenario`` (with the signal overrides of ``case``,
    a name from ``scenario.cases``) on the grid ``t``. Signals not given are zero."""
    where = scenario.source or "scenario"
    sigs = list(model.inputs) + list(model.faults) + list(model.disturbances) + list(model.noise)
    names = tuple(s.name for s in sigs)
    given = dict(scenario.signals)
    if case is not None:
        cases = scenario.cases or {NOMINAL_CASE: {}}
        if case not in cases:
            raise UsageError(f"{where}: no case '{case}' (cases: {', '.join(cases)})")
        given.update(cases[case])
    for key in given:
        if key not in names:
            raise UsageError(f"{where}: signal '{key}' is not an input, fault, disturbance or"
                             f" noise of {model.name} (known: {', '.join(names) or 'none'})")
    t = np.asarray(t, dtype=float)
    declared = {s.name: b for s, b in (model.bounds or {}).items()}
    cols = [_coefficients(given.get(n, 0), t, where, n, declared.get(n)) for n in names]
    N, nv = t.size, len(names)

    def stack(k):
        a = np.empty((N, nv))
        for j, c in enumerate(cols):
            a[:, j] = c[k]
        a.setflags(write=False)
        return a

    base, su, sn = stack(0), stack(1), stack(2)
    normal = tuple(bool(np.any(sn[:, j] != 0)) for j in range(nv))
    random = tuple(bool(np.any(su[:, j] != 0)) or normal[j] for j in range(nv))
    return SignalProgram(names, base, su, sn, random, normal)


# ---------------------------------------------------------------------------- per-run draws
@dataclasses.dataclass(frozen=True)
class ParameterLayout:
    """The run-time parameter vector p of both simulators: the plant's parameters (the
    model's order) then the observer's (its order). An observer parameter with the name of
    a plant parameter (a design that kept k1 symbolic) is renamed ``<name>_observer``
    (``rename``): the observer keeps its own value while the plant's is sampled."""

    plant: tuple
    observer: tuple
    rename: tuple = ()  # ((observer's symbol, its name in p), ...)

    @property
    def names(self) -> tuple:
        return tuple(p.name for p in self.plant) + tuple(str(p) for p in self.observer)

    def observer_equation(self, e):
        """An observer expression with the renamed parameters."""
        return sp.sympify(e).xreplace(dict(self.rename)) if self.rename else sp.sympify(e)


def parameter_layout(model: PlantModel, observer) -> ParameterLayout:
    plant = tuple(model.parameters)
    names = {p.name for p in plant}
    rename, obs = [], []
    for q in (tuple(observer.parameters) if observer is not None else ()):
        if str(q) in names:
            fresh = sp.Symbol(f"{q}_observer")
            rename.append((q, fresh))
            obs.append(fresh)
        else:
            obs.append(q)
    return ParameterLayout(plant, tuple(obs), tuple(rename))


@dataclasses.dataclass(frozen=True, eq=False)
class RunDraws:
    """Per-run quantities of runs (sample indices) ``samples``: ``P`` (R, np) the run-time
    parameter vector (:func:`parameter_layout` order), ``x0`` (R, nx) the plant's initial
    states, ``xi0`` (R, nξ) the observer's; ``plant`` the plant parameters the scenario
    sets (name → (R,)), for the result."""

    samples: np.ndarray
    P: np.ndarray
    x0: np.ndarray
    xi0: np.ndarray
    plant: Mapping


def _parameter_distribution(model, name, spec, where) -> tuple:
    p = next((q for q in model.parameters if q.name == name), None)
    if p is None:
        raise UsageError(f"{where}: parameter '{name}' is not a parameter of {model.name}"
                         f" (parameters: {', '.join(q.name for q in model.parameters) or 'none'})")
    box = model.uncertainty.get(p) if getattr(model, "uncertainty", None) else None
    if spec == "declared":
        if box is None:
            raise UsageError(f"{where}: parameter '{name}' is \"declared\" but {model.name}"
                             " declares no uncertainty for it (uncertainty={...} in the model)")
        return p, Distribution("uniform", float(box[0]), float(box[1]))
    d = Distribution.of(spec)
    if box is not None:
        ulo, uhi = (float(v) for v in box)
        if d.kind == "normal" and d.b > 0:
            raise UsageError(f"{where}: parameter '{name}': a normal distribution leaves the"
                             f" declared uncertainty [{ulo:g}, {uhi:g}]; use uniform or \"declared\"")
        lo, hi = (d.a, d.b) if d.kind == "uniform" else (d.a, d.a)
        if lo < ulo or hi > uhi:
            raise UsageError(f"{where}: parameter '{name}' in [{lo:g}, {hi:g}] leaves the model's"
                             f" declared uncertainty [{ulo:g}, {uhi:g}]")
    return p, d


@functools.lru_cache(maxsize=4)
def _lhs(seed: int, d: int, n: int) -> np.ndarray:
    from scipy.stats import qmc
    return qmc.LatinHypercube(d, seed=np.random.default_rng([seed, 2])).random(n)


def _uniforms(method, seed, samples, index, total):
    """(R, d) uniform samples, for the sample indices ``samples``, of the random quantities
    whose places in the fixed order are ``index`` (d of them): ``"random"`` uses stream
    PARAMETER_STREAMS + 2q of quantity q — a quantity keeps its numbers when another one
    becomes random — the quasi-random methods one dimension per random quantity."""
    R = samples.size
    d = len(index)
    if d == 0:
        return np.zeros((R, 0))
    if method == "random":
        keys = stream_keys(seed, samples, PARAMETER_STREAMS + 2 * np.asarray(index))
        return uniform_samples(keys, 1)[:, :, 0]
    if method == "sobol":
        from scipy.stats import qmc
        out = np.empty((R, d))
        # contiguous ranges of sample indices: fast_forward to each
        order = np.argsort(samples, kind="stable")
        s = samples[order]
        starts = np.flatnonzero(np.diff(s, prepend=s[0] - 2) != 1)
        for a, b in zip(starts, list(starts[1:]) + [R]):
            eng = qmc.Sobol(d, scramble=True, seed=np.random.default_rng([seed, 3]))
            if s[a]:
                eng.fast_forward(int(s[a]))
            with warnings.catch_warnings():  # balance needs powers of 2: not for chunks
                warnings.simplefilter("ignore", UserWarning)
                out[order[a:b]] = eng.random(int(b - a))
        return out
    if total is None or total < int(samples.max()) + 1:
        raise UsageError("\"sampling\": \"lhs\" needs the total number of samples")
    return _lhs(int(seed), d, int(total))[samples]


@dataclasses.dataclass(frozen=True, eq=False)
class DrawPlan:
    """How a scenario's per-run quantities are drawn (validated once; :meth:`draw` is
    cheap; picklable, so workers draw their own chunks): ``quantities`` (kind, index,
    Distribution) in the fixed order of the module docstring; ``defaults`` the observer
    states initialised by the observer's own map of x(0) (index, expression, states; the
    expression is lambdified once per process)."""

    quantities: tuple
    defaults: tuple
    method: str
    seed: int
    nx: int
    nxi: int
    nplant: int
    nobs: int
    sampled: tuple  # (name, index in P) of the plant parameters the scenario sets

    def _functions(self) -> tuple:
        """The lambdified initial maps, kept on the plan once made in this process (not
        pickled: a worker makes its own)."""
        fns = self.__dict__.get("_fns")
        if fns is None:
            fns = tuple(_initial_function(e, xs) for _, e, xs in self.defaults)
            self.__dict__["_fns"] = fns
        return fns

    def __getstate__(self):
        state = dict(self.__dict__)
        state.pop("_fns", None)
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)

    def draw(self, samples, *, total: int | None = None) -> RunDraws:
        samples = np.atleast_1d(np.asarray(samples, dtype=np.int64))
        R = samples.size
        index = [q for q, quantity in enumerate(self.quantities) if quantity[2].random]
        U = _uniforms(self.method, self.seed, samples, index, total)
        P = np.zeros((R, self.nplant + self.nobs))
        x0 = np.zeros((R, self.nx))
        xi0 = np.full((R, self.nxi), np.nan)
        col = 0
        for kind, j, d in self.quantities:
            if d.random:
                v = d.transform(U[:, col])
                col += 1
            else:
                v = np.full(R, d.a)
            if kind == "p":
                P[:, j] = v
            elif kind == "op":
                P[:, self.nplant + j] = v
            elif kind == "x":
                x0[:, j] = v
            else:
                xi0[:, j] = v
        if self.defaults:  # the observer's initial map of x(0)
            fns = self._functions()
            for (j, _, _), f in zip(self.defaults, fns):
                xi0[:, j] = f(*(x0[:, i] for i in range(self.nx)))
        plant = {name: P[:, j] for name, j in self.sampled}
        return RunDraws(samples, P, x0, xi0, plant)


def draw_plan(model: PlantModel, observer, scenario) -> DrawPlan:
    """Validate the scenario's per-run quantities against the model and the observer
    and fix how they are drawn (:class:`DrawPlan`)."""
    where = scenario.source or "scenario"
    layout = parameter_layout(model, observer)
    quantities = []  # (kind, index, Distribution)
    plant_vals = {p: Distribution("fixed", float(v)) for p, v in model.parameter_values().items()}
    for name in sorted(scenario.parameters or {}):
        p, d = _parameter_distribution(model, name, scenario.parameters[name], where)
        plant_vals[p] = d
    for p in sorted(plant_vals, key=lambda s: s.name):
        if p in layout.plant:
            quantities.append(("p", layout.plant.index(p), plant_vals[p]))
    xs = list(model.states)
    known = {s.name for s in xs}
    for key in scenario.initial:
        if key not in known:
            raise UsageError(f"{where}: initial state '{key}' is not a state of {model.name}")
    for j, s in enumerate(xs):
        quantities.append(("x", j, Distribution.of(scenario.initial.get(s.name, 0.0))))
    obs_states = list(observer.states) if observer is not None else []
    # without an observer (the plant alone) the observer's entries do not apply
    oinit = dict(scenario.observer_initial or {}) if observer is not None else {}
    onames = [str(s) for s in obs_states]
    for key in oinit:
        if key not in onames:
            raise UsageError(f"{where}: observer_initial '{key}' is not an observer state"
                             f" (states: {', '.join(onames) or 'none'})")
    for j, s in enumerate(obs_states):
        if str(s) in oinit:
            quantities.append(("xi", j, Distribution.of(oinit[str(s)])))
    opar = dict(scenario.observer_parameters or {}) if observer is not None else {}
    original = {fresh: q for q, fresh in layout.rename}
    onp = [str(original.get(p, p)) for p in layout.observer]
    for key in opar:
        if key not in onp:
            raise UsageError(f"{where}: observer_parameters '{key}' is not a parameter of the"
                             f" observer (parameters: {', '.join(onp) or 'none'})")
    for j, p in sorted(enumerate(layout.observer), key=lambda jp: str(jp[1])):
        p = original.get(p, p)
        d = Distribution.of(opar[str(p)]) if str(p) in opar else \
            Distribution("fixed", float(observer.parameters[p]))
        quantities.append(("op", j, d))
    defaults = tuple((j, sp.sympify(observer.initial.get(s, 0)), tuple(xs))
                     for j, s in enumerate(obs_states) if str(s) not in oinit)
    sampled = tuple((p.name, layout.plant.index(p)) for p in layout.plant
                    if p.name in (scenario.parameters or {}))
    return DrawPlan(tuple(quantities), defaults, scenario.sampling, int(scenario.seed), len(xs),
                    len(obs_states), len(layout.plant), len(layout.observer), sampled)


def draw_runs(model: PlantModel, observer, scenario, samples, *, total: int | None = None
              ) -> RunDraws:
    """The per-run quantities of the sample indices ``samples`` (see the module
    docstring). ``total``: the number of samples of the ensemble (``"lhs"`` only)."""
    return draw_plan(model, observer, scenario).draw(samples, total=total)


@functools.lru_cache(maxsize=256)
def _initial_function(e, xs):
    """x(0) ↦ the observer state's default initial value, vectorised over runs (cached:
    lambdify costs milliseconds, a call microseconds)."""
    f = sp.lambdify(xs, algebraic_to_float(e), "numpy")  # CRootOf: lambdify has no name for it

    def call(*x):
        v = np.asarray(f(*x), dtype=float)
        return np.broadcast_to(v, np.shape(x[0])).copy() if x else v
    return call


def check_distribution(where: str, what: str, spec, *, declared: bool = False) -> None:
    """A number, ``{"uniform": [lo, hi]}`` (lo ≤ hi) or ``{"normal": [mean, std]}``
    (std ≥ 0), all finite; ``"declared"`` too when allowed. UsageError otherwise."""
    if declared and spec == "declared":
        return
    if isinstance(spec, dict) and len(spec) == 1 and next(iter(spec)) in ("uniform", "normal"):
        (kind, pair), = spec.items()
        if not isinstance(pair, (list, tuple)) or len(pair) != 2:
            raise UsageError(f"{where}: {what}: use {{\"{kind}\": [{'low, high' if kind == 'uniform' else 'mean, std'}]}}")
        a, b = pair
        for v, label in ((a, "low" if kind == "uniform" else "mean"),
                         (b, "high" if kind == "uniform" else "std")):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not _finite_float(v):
                raise UsageError(f"{where}: {what}: {kind} {label} must be a finite number"
                                 f" (a double), got {_short(v)}")
        if kind == "uniform" and a > b:
            raise UsageError(f"{where}: {what}: uniform low {a} > high {b}")
        if kind == "uniform" and not math.isfinite(float(b) - float(a)):
            raise UsageError(f"{where}: {what}: uniform range [{a}, {b}] is wider than a"
                             " double can hold (high − low overflows)")
        if kind == "normal" and b < 0:
            raise UsageError(f"{where}: {what}: normal std {b} < 0")
        return
    if isinstance(spec, bool) or not isinstance(spec, (int, float)):
        allowed = "a number, {\"uniform\": [low, high]}, {\"normal\": [mean, std]}" + \
            (" or \"declared\"" if declared else "")
        raise UsageError(f"{where}: {what} must be {allowed}, got {spec!r}")
    if not _finite_float(spec):
        raise UsageError(f"{where}: {what} must be finite (a double), got {_short(spec)}")


def _finite_float(v) -> bool:
    """A number that is a finite double (a JSON integer beyond ±1.8e308 is not)."""
    try:
        return math.isfinite(float(v))
    except OverflowError:
        return False


def _short(v) -> str:
    text = repr(v)
    return text if len(text) <= 40 else f"{text[:20]}…({len(text)} characters)"

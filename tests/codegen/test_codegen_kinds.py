"""Compiled observers for EVERY observer kind: parity of three implementations, the
sliding-mode translation and the exact zero-order hold.

Parity: the compiled whole trajectory (CompiledSimulator: the casadi-generated joint
step inside the generated C loop), the interpreted casadi joint step iterated from
Python, and the reference numpy simulator (observer_cad.simulate.simulate) agree to
1e-12 relative — per column, relative to the column's largest magnitude, as in
tests/test_codegen.py (residuals are ≈ 0 fault-free, so elementwise relative errors mean
nothing there) — on whole trajectories of the papers' scenarios (models/scenarios/*.json)
where they exist, and on random joint states and signals (single steps, against an
independent lambdified numpy joint step).  Delayed outputs (unknown-input estimators:
d̂(t) is produced at t + delay) are compared where the reference defines them and the
NaN tails must coincide.

DREM (observer_cad.drem, 92 states) is the one exception to 1e-12 against the reference
simulator: its outputs are ill-conditioned in floating point (one ulp of x1(0) moves
them by ~1e-9), so there the compiled outputs are checked against the measured one-ulp
sensitivity; compiled vs interpreted casadi and the plant columns are still 1e-12.

Zero-order hold: observer_step(..., discretisation="zoh") against scipy's matrix
exponential of the augmented matrix, a fine RK4 of the linear ODE with the inputs held,
and scipy.signal.lsim(interp=False) over a whole trajectory; nonlinear observers are
rejected with a clear error.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

casadi = pytest.importorskip("casadi")
scipy_linalg = pytest.importorskip("scipy.linalg")
scipy_signal = pytest.importorskip("scipy.signal")

from observer_cad.codegen import CompiledSimulator, compile_observer_step, observer_step, to_casadi, zoh_matrices
from observer_cad.codegen import split_signals
from observer_cad.errors import UsageError
from observer_cad.model import load_model
from observer_cad.observers import Observer, output_symbols
from observer_cad.observers import build_observer
from observer_cad.simulation import load_scenario, scenario_from_dict, simulate
from observer_cad.synthesis import design

ROOT = Path(__file__).resolve().parents[2]
SCEN = ROOT / "models" / "scenarios"
RTOL = 1e-12
# random single steps: the compiled step takes the observer's parameters (gains, bounds) at
# run time while the numpy oracle folds them into its constants, and the delayed
# unknown-input estimators subtract nearly equal lagged values; measured ≤ 1.1e-12
RTOL_STEP = 1e-11
# whole trajectories of the delayed unknown-input estimate ρ̂ (Figs. 3 and 4): it divides
# lagged differences by a small quantity, so the order in which the expressions are summed
# — which follows Python's string hashing (PYTHONHASHSEED) — moves it by 1.05e-10
# relative: measured with PYTHONHASHSEED = 1 … 6 (the reference and the compiled run each
# take one of two values 1.05e-10 apart; every other column agrees to < 1e-15)
RTOL_DELAYED_ESTIMATE = 1e-9
LOOSE = {("unknown-input rho mismatched, delay 2 (Fig. 3)", "rho_hat"): RTOL_DELAYED_ESTIMATE,
         ("unknown-input rho mismatched, delay 2, noise (Fig. 4)", "rho_hat"):
         RTOL_DELAYED_ESTIMATE}
needs_cc = pytest.mark.skipif(
    not any((Path(d) / "cc").exists() for d in __import__("os").environ.get("PATH", "").split(":")),
    reason="no C compiler")

DIAG = {"steps": 300, "seed": 5, "initial": {"x1": 0.1, "x2": -0.2, "x3": 0.05},
        "signals": {"u": "0.2*sin(t/10)", "rho": {"uniform": [-0.05, 0.05]},
                    "d": "Piecewise((0, t < 150), (0.2, True))",
                    "w1": {"uniform": [-0.01, 0.01]}, "w2": {"uniform": [-0.01, 0.01]}}}

# case: (model file, design kwargs, build_observer options, scenario file or dict)
CASES = {
    "unknown-input k=1 (Fig. 1)": ("electric_drive.py", dict(observer="unknown-input",
                                   faults=["d"]), {}, "electric_drive_fig1.json"),
    "unknown-input k=1 (Fig. 2)": ("electric_drive.py", dict(observer="unknown-input",
                                   faults=["d"]), {}, "electric_drive_fig2.json"),
    "unknown-input rho mismatched, delay 2 (Fig. 3)": (
        "electric_drive.py", dict(observer="unknown-input", faults=["rho"]),
        {"bounds": {"rho": (-0.2, 0.2)}}, "electric_drive_rho_fig3.json"),
    "unknown-input rho mismatched, delay 2, noise (Fig. 4)": (
        "electric_drive.py", dict(observer="unknown-input", faults=["rho"]),
        {"bounds": {"rho": (-0.2, 0.2)}}, "electric_drive_rho_fig4.json"),
    "unknown-input Jordan": ("electric_drive.py", dict(observer="unknown-input", faults=["d"],
                             form="jordan", lambdas=["1/2"]), {}, "electric_drive_fig1.json"),
    "interval nonlinear three-tank": ("three_tank.py", dict(observer="interval", estimate="x1"),
                                      {}, "three_tank_interval.json"),
    "interval electric drive x2": ("electric_drive.py", dict(observer="interval", estimate="x2"),
                                   {}, "electric_drive_interval.json"),
    "interval canonical linear three-tank": (
        "three_tank_linear.py", dict(observer="interval", estimate="x1", form="canonical",
                                     eigenvalues=["-1", "-2"]), {},
        "three_tank_linear_interval.json"),
    "sliding-mode": ("sliding_example.py", dict(observer="sliding-mode", faults=["d"]), {},
                     "sliding_example.json"),
    "diagnostic canonical with feedback": ("electric_drive.py", dict(
        observer="diagnostic", form="canonical", eigenvalues=["1/2"]), {}, DIAG),
    "diagnostic Jordan": ("electric_drive.py", dict(observer="diagnostic"), {}, DIAG),
    "virtual-sensor nonlinear three-tank": ("three_tank.py", dict(observer="virtual-sensor",
                                            estimate="x1"), {}, "three_tank_interval.json"),
}

KINDS_COVERED = {"unknown-input", "interval", "sliding-mode", "diagnostic", "virtual-sensor"}


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path_factory.getbasetemp() / "occache"))


_MODELS: dict = {}


def _model(path):
    if path not in _MODELS:
        _MODELS[path] = load_model(ROOT / "models" / path)
    return _MODELS[path]


def _scenario(spec):
    if isinstance(spec, dict):
        return scenario_from_dict(spec)
    return load_scenario(SCEN / spec)


@pytest.fixture(scope="module")
def built():
    cache = {}

    def get(case):
        if case not in cache:
            path, kw, opts, sc = CASES[case]
            m = _model(path)
            o = build_observer(m, design(m, **kw), **opts)
            cache[case] = (m, o, _scenario(sc))
        return cache[case]
    return get


def _err(a, b):
    """max |a - b| relative to max |a|; NaNs must coincide."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape, (a.shape, b.shape)
    na, nb = np.isnan(a), np.isnan(b)
    assert np.array_equal(na, nb), "NaN positions differ"
    a, b = a[~na], b[~nb]
    if not a.size:
        return 0.0
    scale = max(float(np.max(np.abs(a))), 1e-300)
    return float(np.max(np.abs(a - b))) / scale


def _close(a, b, rtol=RTOL, what=""):
    e = _err(a, b)
    assert e <= rtol, f"{what}: relative error {e:.3g} > {rtol}"
    return e


def _interpreted(cs, t, V, s0):
    """The interpreted casadi joint step iterated from Python (raw, undelayed)."""
    N = t.size
    S, Y, O = np.empty((N, cs.ns)), np.empty((N, cs.ny)), np.empty((N, cs.no))
    s = np.asarray(s0, float)
    step = cs.step
    for i in range(N):
        h = t[i + 1] - t[i] if i + 1 < N else 0.0
        sn, yv, out = step(s, V[i], cs.nominal, h)
        S[i] = s
        Y[i] = np.asarray(yv, float).ravel()
        O[i] = np.asarray(out, float).ravel()
        s = np.asarray(sn, float).ravel()
    return S, Y, O


def _rerun_parity(m, o, sc, ref, res) -> str:
    """Whether the reference and the compiled trajectory reproduce when computed again:
    evidence for a failure seen once and not reproduced since (delayed unknown-input
    cases, relative error 1e-10)."""
    ref2, res2 = simulate(m, o, sc), CompiledSimulator(m, o).simulate(sc)

    def moved(a, b):
        return max(float(np.nanmax(np.abs(np.asarray(a[c], float) - np.asarray(b[c], float)),
                                   initial=0.0)) for c in a.columns)
    return (f"computed again: the reference moved by {moved(ref, ref2):.3g}, the compiled"
            f" trajectory by {moved(res, res2):.3g} (largest absolute change over the columns)")


def test_every_kind_is_covered():
    kinds = set()
    for case, (path, kw, _, _) in CASES.items():
        kinds.add(kw["observer"])
    assert KINDS_COVERED <= kinds


# ------------------------------------------------------------------ whole trajectories
@pytest.mark.slow
@needs_cc
@pytest.mark.parametrize("case", [  # the sliding-mode run takes ~4 s: slow step
    pytest.param(c, marks=pytest.mark.slow) if c == "sliding-mode" else c for c in CASES])
def test_trajectory_parity_every_kind(case, built):
    m, o, sc = built(case)
    ref = simulate(m, o, sc)
    cs = CompiledSimulator(m, o)
    res = cs.simulate(sc)
    assert res.order == ref.order and set(res.columns) == set(ref.columns)
    # sanity: the scenario is not trivial (some observer output moves)
    assert any(np.nanmax(np.abs(ref[n])) > 0 for n in o.output_names)
    errs = {}
    try:
        for c in ref.columns:
            errs[c] = _close(ref[c], res[c], rtol=LOOSE.get((case, c), RTOL),
                             what=f"compiled vs reference, column {c}")
    except AssertionError as exc:
        raise AssertionError(f"{exc}\n{_rerun_parity(m, o, sc, ref, res)}") from exc
    # interpreted casadi, the same joint step, whole trajectory
    t, _, N, V, s0 = cs.prepare(sc)
    S, Y, O = _interpreted(cs, t, V[0], s0)
    Sc, Yc, Oc = cs.run_arrays(t, V[0], s0)
    for j in range(cs.ns):
        _close(Sc[:, j], S[:, j], what=f"compiled vs interpreted, state {j}")
    for j in range(cs.ny):
        _close(Yc[:, j], Y[:, j], what=f"compiled vs interpreted, y{j + 1}")
    for j in range(cs.no):
        _close(Oc[:, j], O[:, j], what=f"compiled vs interpreted, output {j}")
    # interpreted vs reference, through the simulator's columns
    for j, x in enumerate(m.states):
        _close(ref[str(x)], S[:, j], what=f"interpreted vs reference, {x}")
    for j, (name, _) in enumerate(o.outputs):
        k = int(o.delays.get(name, 0))
        want = ref[name][:-k] if k else ref[name]
        got = O[k:, j]
        _close(want, got, what=f"interpreted vs reference, {name}")
        if k:
            assert np.all(np.isnan(ref[name][-k:]))


# ------------------------------------------------------------------ random single steps
def _numpy_joint(m, o):
    """An independent numpy joint step: lambdified RHS / map, RK4 with signals held."""
    mm = m.substitute_parameters() if m.parameters else m
    par = dict(o.parameters)
    ys = output_symbols(len(mm.outputs))
    ysub = dict(zip(ys, mm.outputs))
    s = list(mm.states) + list(o.states)
    v = list(mm.inputs) + list(mm.faults) + list(mm.disturbances) + list(mm.noise)
    rhs = list(mm.dynamics) + [sp.sympify(e).xreplace(par).xreplace(ysub) for e in o.update]
    outs = [sp.sympify(e).xreplace(par).xreplace(ysub) for _, e in o.outputs]
    f = sp.lambdify(s + v, rhs, "numpy")
    fy = sp.lambdify(s + v, list(mm.outputs), "numpy")
    fo = sp.lambdify(s + v, outs, "numpy")

    def step(sv, vv, h):
        F = lambda z: np.array(f(*z, *vv), float)  # noqa: E731
        if mm.time == "discrete":
            sn = F(sv)
        else:
            k1 = F(sv)
            k2 = F(sv + h / 2 * k1)
            k3 = F(sv + h / 2 * k2)
            k4 = F(sv + h * k3)
            sn = sv + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        return sn, np.array(fy(*sv, *vv), float), np.array(fo(*sv, *vv), float)
    return step


@needs_cc
@pytest.mark.parametrize("case", list(CASES))
def test_random_single_steps_every_kind(case, built):
    """Random joint states and signals near the scenario's trajectory (the nonlinear
    three-tank must stay in x1 > x2 > x3 > 0): compiled (N = 2 trajectory), interpreted
    casadi and an independent numpy step agree."""
    m, o, sc = built(case)
    cs = CompiledSimulator(m, o)
    t, _, N, V, s0 = cs.prepare(sc)
    Sc, _, _ = cs.run_arrays(t, V[0], s0)
    ref = _numpy_joint(m, o)
    rng = np.random.default_rng(7)
    h = float(t[1] - t[0]) if m.time == "continuous" else 1.0
    tt = np.array([0.0, h])
    for _ in range(20):
        i = int(rng.integers(0, N))
        s = Sc[i] * (1 + rng.uniform(-1e-3, 1e-3, cs.ns)) + rng.uniform(-1e-4, 1e-4, cs.ns)
        v = V[0, i] + rng.uniform(-1e-3, 1e-3, cs.nv)
        sn_ref, y_ref, o_ref = ref(s, v, h)
        S2, Y2, O2 = cs.run_arrays(tt, np.vstack([v, v]), s)
        sn_i, y_i, o_i = (np.asarray(r, float).ravel() for r in cs.step(s, v, cs.nominal, h))
        for got in (S2[1], sn_i):
            _close(sn_ref, got, what="next joint state")
        for got in (Y2[0], y_i):
            _close(y_ref, got, what="y")
        for got in (O2[0], o_i):
            _close(o_ref, got, rtol=RTOL_STEP, what="observer outputs")


# ------------------------------------------------------------------ sliding mode
def test_sliding_translation_abs_and_regularised_sign(built):
    """The sliding observer's k e / (eps + |e|) (a regularised sign) translates to fabs
    and a division; it equals numpy's value at e = 0, around ±eps and far out, is odd,
    and tends to ±k."""
    m, o, _ = built("sliding-mode")
    out = dict(o.outputs)["d_hat"]
    syms = sorted(out.free_symbols, key=str)
    par = dict(o.parameters)
    k, eps = float(par[sp.Symbol("k_sm")]), float(par[sp.Symbol("eps_sm")])
    assert any(isinstance(a, sp.Abs) for a in sp.preorder_traversal(out))
    SX = {s: casadi.SX.sym(str(s)) for s in syms}
    f = casadi.Function("f", list(SX.values()), to_casadi([out], SX))
    ops = {f.instruction_id(i) for i in range(f.n_instructions())}
    assert casadi.OP_FABS in ops and casadi.OP_DIV in ops
    g = sp.lambdify(syms, out, "numpy")
    names = [str(s) for s in syms]
    for e in (0.0, 1e-9, -1e-9, eps / 2, -eps / 2, eps, -eps, 3 * eps, 0.3, -0.3, 1e3, -1e3):
        # e = xs1 - y1 + y2: put it all in xs1 (no cancellation), then spread it
        for y in (0.0, 0.25):
            vals = {"xs1": e + y, "y1": 2 * y, "y2": y, "k_sm": k, "eps_sm": eps}
            args = [vals[n] for n in names]
            a = float(g(*args))
            b = float(f(*args))
            if y == 0.0:
                assert abs(a - b) <= 1e-15 * abs(a), (e, a, b)
                assert abs(b - (-k * e / (eps + abs(e)))) <= 1e-15 * abs(b), (e, b)
            else:   # the sum e may round differently (cancellation): relative to k
                assert abs(a - b) <= 1e-12 * k, (e, a, b)
    big = float(f(*[{"xs1": 1e9, "y1": 0, "y2": 0, "k_sm": k, "eps_sm": eps}[n] for n in names]))
    assert abs(big + k) < 1e-9
    # sympy's sign and casadi's sign agree at 0 and either side
    x = sp.Symbol("x")
    X = casadi.SX.sym("x")
    fs = casadi.Function("s", [X], to_casadi([sp.sign(x)], {x: X}))
    assert [float(fs(v)) for v in (-2.0, 0.0, 3.0)] == [-1.0, 0.0, 1.0]


# ------------------------------------------------------------------ zero-order hold
def _linear_observer():
    """A synthetic continuous observer, affine in its 3 states, with a non-normal A
    (complex pair + a real pole), signals y1, y2, u and a parameter in g."""
    x1, x2, x3, y1, y2, u, c = sp.symbols("xa1 xa2 xa3 y1 y2 u c")
    A = sp.Matrix([[-1, 3, 0], [-2, -1, sp.Rational(1, 2)], [0, 1, -sp.Rational(5, 2)]])
    X = sp.Matrix([x1, x2, x3])
    g = sp.Matrix([y1 - 2 * u + c, sp.sin(y2) + y1 * u, sp.Rational(1, 3) * y2 - 1])
    upd = list(A * X + g)
    return Observer(name="lin3", kind="virtual-sensor", time="continuous",
                    states=(x1, x2, x3), signals=(y1, y2, u), parameters={c: sp.Rational(7, 10)},
                    update=tuple(upd), outputs=(("z_hat", x1 + x3 - y1),),
                    initial={}), np.array(A.tolist(), float)


def _augmented_expm(A, b, h):
    """x(h) for x' = A x + b (b constant) from expm([[A, b], [0, 0]] h)."""
    n = A.shape[0]
    M = np.zeros((n + 1, n + 1))
    M[:n, :n] = A
    M[:n, n] = b
    E = scipy_linalg.expm(M * h)
    return E[:n, :n], E[:n, n]


def _fine_rk4(A, b, x, h, sub=4000):
    dt = h / sub
    f = lambda z: A @ z + b  # noqa: E731
    for _ in range(sub):
        k1 = f(x)
        k2 = f(x + dt / 2 * k1)
        k3 = f(x + dt / 2 * k2)
        k4 = f(x + dt * k3)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


@pytest.mark.slow
@pytest.mark.parametrize("h", [pytest.param(0.01, marks=pytest.mark.slow), 0.3, 2.0])
def test_zoh_step_is_the_exact_solution(h):
    o, A = _linear_observer()
    f = observer_step(o, h=h, discretisation="zoh")
    assert "zero-order-hold" in f.__doc__ and [f.name_in(i) for i in range(f.n_in())] == \
        ["x", "y", "u", "p"]
    A2, Ad, Gam, g = zoh_matrices(o, h)
    np.testing.assert_array_equal(A2, A)
    rng = np.random.default_rng(11)
    gf = sp.lambdify(list(o.signals) + list(o.parameters), g, "numpy")
    for _ in range(10):
        x = rng.uniform(-2, 2, 3)
        y = rng.uniform(-1, 1, 2)
        u = rng.uniform(-1, 1, 1)
        p = [0.7]
        b = np.array(gf(*y, *u, *p), float)
        Ed, xb = _augmented_expm(A, b, h)
        exact = Ed @ x + xb
        got = np.asarray(f(x, y, u, p)[0], float).ravel()
        _close(exact, got, what="ZOH vs expm of the augmented matrix")
        _close(_fine_rk4(A, b, x, h), got, rtol=1e-11, what="ZOH vs fine RK4")
    # with A invertible, Gamma = A^-1 (e^{A h} - I)
    np.testing.assert_allclose(Gam, np.linalg.solve(A, Ad - np.eye(3)), rtol=0, atol=1e-14)


@needs_cc
def test_zoh_whole_trajectory_matches_lsim_and_compiles(built, tmp_path):
    """The canonical interval observer (linear three-tank), ZOH step iterated on the
    recorded y, u of the paper-style scenario == scipy.signal.lsim(interp=False) (zero-
    order hold by matrix exponential), interpreted and compiled; the exact ZOH of the
    diagonal A = diag(-2, -1, -2, -1) is e^{-2h}, e^{-h}."""
    m, o, sc = built("interval canonical linear three-tank")
    ref = simulate(m, o, sc)
    h = float(sc.dt)
    ys, us = split_signals(o)
    Ysig = np.column_stack([ref[str(s)] for s in ys])
    Usig = np.column_stack([ref[str(s)] for s in us])
    N = Ysig.shape[0]
    A, Ad, Gam, g = zoh_matrices(o, h)
    np.testing.assert_allclose(np.diag(Ad), np.exp(np.diag(A) * h), rtol=1e-15)
    # the affine part g = B s + c as an lsim input [y, u, 1]
    svars = list(ys) + list(us)
    B = np.array(sp.Matrix(g).jacobian(svars).tolist(), float)
    c = np.array(sp.Matrix(g).xreplace({s: 0 for s in svars}).tolist(), float)
    Bc = np.hstack([B, c])
    n = len(o.states)
    Cz = np.eye(n)
    sysc = (A, Bc, Cz, np.zeros((n, Bc.shape[1])))
    U = np.hstack([Ysig, Usig, np.ones((N, 1))])
    T = np.arange(N) * h
    x0 = np.array([0.3, -0.2, 0.5, 0.4])
    _, _, X_lsim = scipy_signal.lsim(sysc, U, T, X0=x0, interp=False)
    f = observer_step(o, h=h, discretisation="zoh")
    fc = compile_observer_step(o, h=h, discretisation="zoh")
    assert fc.function.__doc__ == f.__doc__
    for F in (f, fc.function):
        x = x0.copy()
        X = np.empty((N, n))
        for i in range(N):
            X[i] = x
            x = np.asarray(F(x, Ysig[i], Usig[i], [])[0], float).ravel()
        for j in range(n):
            _close(X_lsim[:, j], X[:, j], what=f"ZOH trajectory vs lsim, state {j}")
    # ZOH and RK4 of the same observer: close (RK4 is 4th order) but not identical
    frk = observer_step(o, h=h)
    xz = np.asarray(f(x0, Ysig[5], Usig[5], [])[0], float).ravel()
    xr = np.asarray(frk(x0, Ysig[5], Usig[5], [])[0], float).ravel()
    assert 0 < np.max(np.abs(xz - xr)) < 1e-8


def test_zoh_rejects_nonlinear_and_bad_use(built):
    for case, what in (("sliding-mode", "xs1"), ("interval nonlinear three-tank", "xl1")):
        _, o, _ = built(case)
        with pytest.raises(UsageError, match=r"affine in its states.*discretisation='rk4'") as ei:
            observer_step(o, h=0.01, discretisation="zoh")
        assert what in str(ei.value) and "\n" not in str(ei.value)
    _, od, _ = built("diagnostic Jordan")
    with pytest.raises(UsageError, match="applies to continuous-time observers"):
        observer_step(od, discretisation="zoh")
    o, _ = _linear_observer()
    with pytest.raises(UsageError, match="needs a fixed step size h"):
        observer_step(o, discretisation="zoh")
    with pytest.raises(UsageError, match="must be one of rk4, zoh"):
        observer_step(o, h=0.1, discretisation="euler")
    with pytest.raises(UsageError, match="positive finite"):
        observer_step(o, h=-0.1, discretisation="zoh")
    # a state matrix that depends on a parameter cannot be exponentiated in advance
    x, y, a = sp.symbols("xq y1 a")
    op = Observer(name="param", kind="virtual-sensor", time="continuous", states=(x,),
                  signals=(y,), parameters={a: 2}, update=(-a * x + y,),
                  outputs=(("z_hat", x),))
    with pytest.raises(UsageError, match=r"constant state matrix.*depends on a"):
        observer_step(op, h=0.1, discretisation="zoh")


# ------------------------------------------------------------------ DREM
def _drem():
    try:
        from observer_cad.observers import drem_observer, load_drem
    except Exception as exc:  # noqa: BLE001 - module being written
        pytest.skip(f"observer_cad.drem not usable: {exc}")
    path = ROOT / "models" / "drem_example.py"
    if not path.is_file() or not (SCEN / "drem_example.json").is_file():
        pytest.skip("no DREM example model / scenario")
    m, spec = load_drem(path)
    return m, drem_observer(m, spec), load_scenario(SCEN / "drem_example.json")


@pytest.mark.slow  # full-length DREM trajectories, ~5 s
@needs_cc
def test_drem_trajectory_parity():
    """The DREM adaptive observer (92 states, gamma = 1e22), first 5 s of its scenario.

    Compiled vs interpreted casadi: 1e-12 (the same arithmetic).  Plant columns vs the
    reference simulator: 1e-12.  The observer's outputs are ill-conditioned in floating
    point (the mixing divides by Δ ≈ 1e-11 … 1e-12 while the regressor is still poorly
    excited): changing x1(0) by ONE ulp moves the reference's outputs by up to 1.4e-9
    relative (1.4e-8 over the full 40 s), so 1e-12 agreement between implementations
    that round differently is impossible.  The compiled outputs are asserted within 20×
    that measured one-ulp sensitivity (measured 2026-11-21: compiled vs reference 4.4e-9
    at worst, 3.1× the sensitivity; 1.8e-8 over 40 s, 1.3×)."""
    import dataclasses
    m, o, sc = _drem()
    sc = dataclasses.replace(sc, t_end=5.0)
    cs = CompiledSimulator(m, o)
    res = cs.simulate(sc)
    t, _, N, V, s0 = cs.prepare(sc)
    S, Y, O = _interpreted(cs, t, V[0], s0)
    Sc, Yc, Oc = cs.run_arrays(t, V[0], s0)
    for j in range(cs.ns):
        _close(Sc[:, j], S[:, j], what=f"compiled vs interpreted, state {j}")
    for j in range(cs.no):
        _close(Oc[:, j], O[:, j], what=f"compiled vs interpreted, output {j}")
    ref = simulate(m, o, sc)
    outs = set(o.output_names)
    for c in ref.columns:
        if c not in outs:
            _close(ref[c], res[c], what=f"compiled vs reference, column {c}")
    x1 = str(m.states[0])
    x10 = float(sc.initial.get(x1, 0.0))
    sc2 = dataclasses.replace(sc, initial={**sc.initial, x1: np.nextafter(x10, np.inf)})
    ref2 = simulate(m, o, sc2)
    ulp = max(_err(ref[c], ref2[c]) for c in outs)
    tol = max(RTOL, 20 * ulp)
    for c in outs:
        _close(ref[c], res[c], rtol=tol, what=f"compiled vs reference, output {c} (one-ulp"
               f" sensitivity {ulp:.2g})")


def test_cases_use_the_paper_scenarios():
    """Each scenario file named above exists and is the paper's (JSON with a description)."""
    for case, (_, _, _, sc) in CASES.items():
        if isinstance(sc, str):
            data = json.loads((SCEN / sc).read_text())
            assert "description" in data, sc

"""Counter-based random numbers, signal programs and per-run draws:
a run depends on (seed, run index) only — never on the batch it is computed in."""
from __future__ import annotations

import ctypes
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from observer_cad.errors import UsageError
from observer_cad.model import load_model
from observer_cad.observers import build_observer
from observer_cad.simulation import (RANDOM_C, draw_runs, normal_samples, scenario_from_dict,
                                     signal_program, simulate, stream_keys, uniform_samples)
from observer_cad.synthesis import design

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
needs_cc = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                              reason="no C compiler")


# ------------------------------------------------------------------ the generator
def test_splitmix64_reference_values():
    """The finaliser is splitmix64's: the first outputs of the generator seeded with 0
    (Vigna's reference implementation, prng.di.unimi.it/splitmix64.c)."""
    from observer_cad.simulation import mix64
    G = 0x9E3779B97F4A7C15
    got = [int(mix64(np.uint64((k * G) % 2 ** 64))) for k in (1, 2, 3)]
    assert got == [0xE220A8397B1DCDAF, 0x6E789E6AA1B965F4, 0x06C45D188009454F]


def test_uniform_samples_are_uniform_and_streams_independent():
    keys = stream_keys(5, np.arange(4), [0, 1])
    assert keys.shape == (4, 2) and len(set(keys.ravel().tolist())) == 8
    u = uniform_samples(keys[:, 0], 50_000)
    assert u.shape == (4, 50_000) and u.min() >= 0 and u.max() < 1
    assert abs(u.mean() - 0.5) < 0.005 and abs(u.var() - 1 / 12) < 0.002
    assert abs(np.corrcoef(u[0], u[1])[0, 1]) < 0.02
    z = normal_samples(keys[:, 0], keys[:, 1], 50_000)
    assert abs(z.mean()) < 0.02 and abs(z.std() - 1) < 0.02
    # a later block of samples is the continuation of the stream
    np.testing.assert_array_equal(uniform_samples(keys[:, 0], 10, first=100), u[:, 100:110])


@needs_cc
def test_c_generator_gives_the_same_bits(tmp_path, monkeypatch):
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path))
    from observer_cad.codegen import compile_source
    src = RANDOM_C + r"""
void fill(uint64_t k1, uint64_t k2, long long n, double* u, double* z) {
  for (long long i = 0; i < n; ++i) { u[i] = oc_uniform(k1, i); z[i] = oc_normal(k1, k2, i); }
}
"""
    lib = ctypes.CDLL(str(compile_source(src, "rng_test").path))
    k1, k2 = (int(k) for k in stream_keys(123, [7], [4, 5])[0])
    n = 2000
    u, z = np.empty(n), np.empty(n)
    lib.fill(ctypes.c_uint64(k1), ctypes.c_uint64(k2), ctypes.c_longlong(n),
             u.ctypes.data_as(ctypes.c_void_p), z.ctypes.data_as(ctypes.c_void_p))
    np.testing.assert_array_equal(u, uniform_samples(np.uint64(k1), n))
    np.testing.assert_allclose(z, normal_samples(np.uint64(k1), np.uint64(k2), n),
                               rtol=1e-14, atol=1e-15)


@needs_cc
def test_c_keys_are_stream_keys(tmp_path, monkeypatch):
    """The compiled loop derives every stream's key itself (oc_key): the same bits as
    stream_keys, also for seeds ≥ 2⁶³ (reduced mod 2⁶⁴ by the caller) and large runs."""
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path))
    from observer_cad.codegen import compile_source
    src = RANDOM_C + r"""
void keys(uint64_t seed, const int64_t* runs, long long R, long long S, uint64_t* out) {
  for (long long r = 0; r < R; ++r)
    for (long long s = 0; s < S; ++s) out[r * S + s] = oc_key(seed, runs[r], (uint64_t)s);
}
"""
    lib = ctypes.CDLL(str(compile_source(src, "rng_keys_test").path))
    runs = np.array([0, 1, 7, 2 ** 40 + 3, 2 ** 63 - 1], dtype=np.int64)
    for seed in (0, 123, 2 ** 63 + 5, 2 ** 64 - 1, 2 ** 70 + 9):
        out = np.empty((runs.size, 6), dtype=np.uint64)
        lib.keys(ctypes.c_uint64(seed % 2 ** 64), runs.ctypes.data_as(ctypes.c_void_p),
                 ctypes.c_longlong(runs.size), ctypes.c_longlong(6),
                 out.ctypes.data_as(ctypes.c_void_p))
        np.testing.assert_array_equal(out, stream_keys(seed, runs, np.arange(6)))


# ------------------------------------------------------------------ programs and draws
@pytest.fixture(scope="module")
def drive():
    m = load_model(MODELS / "electric_drive_uncertain.py")
    o = build_observer(m, design(m, observer="diagnostic"))
    return m, o


SCEN = {"steps": 60, "seed": 3,
        "initial": {"x1": {"uniform": [-0.1, 0.1]}, "x3": {"normal": [0, 0.05]}},
        "parameters": {"k5": "declared"},
        "signals": {"u": "2*sin(t/10)", "rho": {"normal": [0, 0.01]},
                    "w1": {"uniform": [0, 0.02]},
                    "w2": {"piecewise": [[{"uniform": [-0.01, 0.01]}, "t < 30"], [0.005, True]]}},
        "cases": {"none": {}, "d step": {"d": "Piecewise((0, t < 20), (0.2, True))"}}}


@settings(max_examples=25, deadline=None)
@given(first=st.integers(0, 40), count=st.integers(1, 8), seed=st.integers(0, 2 ** 40))
def test_a_run_does_not_depend_on_its_batch(drive, first, count, seed):
    m, o = drive
    sc = scenario_from_dict({**SCEN, "seed": seed})
    t = sc.grid(m.time)
    prog = signal_program(m, sc, t, case="d step")
    whole = prog.values(sc.seed, np.arange(50))
    part = prog.values(sc.seed, np.arange(first, first + count))
    np.testing.assert_array_equal(part, whole[first:first + count])
    for method in ("random", "sobol"):
        s2 = scenario_from_dict({**SCEN, "seed": seed, "sampling": method})
        a = draw_runs(m, o, s2, np.arange(50))
        b = draw_runs(m, o, s2, np.arange(first, first + count))
        np.testing.assert_array_equal(b.P, a.P[first:first + count])
        np.testing.assert_array_equal(b.x0, a.x0[first:first + count])
        np.testing.assert_array_equal(b.xi0, a.xi0[first:first + count])


def test_program_coefficients_and_cases(drive):
    m, o = drive
    sc = scenario_from_dict(SCEN)
    t = sc.grid(m.time)
    p0, p1 = signal_program(m, sc, t, case="none"), signal_program(m, sc, t, case="d step")
    j = {n: i for i, n in enumerate(p0.names)}
    np.testing.assert_allclose(p0.base[:, j["u"]], 2 * np.sin(t / 10), rtol=1e-15, atol=1e-15)
    assert p0.random[j["w2"]] and not p0.random[j["u"]] and p0.normal[j["rho"]]
    assert np.all(p0.su[:30, j["w2"]] == 0.02) and np.all(p0.su[30:, j["w2"]] == 0)
    assert np.all(p0.base[30:, j["w2"]] == 0.005)
    assert np.all(p0.base[:, j["d"]] == 0) and p1.base[25, j["d"]] == 0.2
    # common random numbers: the cases share every random sample
    v0, v1 = p0.values(3, [0, 1]), p1.values(3, [0, 1])
    keep = [k for n, k in j.items() if n != "d"]
    np.testing.assert_array_equal(v0[:, :, keep], v1[:, :, keep])
    with pytest.raises(UsageError, match="no case 'other'"):
        signal_program(m, sc, t, case="other")


def test_draws_respect_distributions_and_the_declared_box(drive):
    m, o = drive
    sc = scenario_from_dict(SCEN)
    d = draw_runs(m, o, sc, np.arange(4000))
    k5 = d.plant["k5"]
    assert 0.9504 <= k5.min() and k5.max() <= 0.9696 and k5.std() > 0.005
    x1, x3 = d.x0[:, 0], d.x0[:, 2]
    assert -0.1 <= x1.min() and x1.max() <= 0.1 and abs(x3.std() - 0.05) < 0.003
    assert np.all(d.x0[:, 1] == 0)
    # the observer's default initial state is its initial map of x(0), per run
    assert np.isfinite(d.xi0).all()
    lhs = scenario_from_dict({**SCEN, "sampling": "lhs"})
    a = draw_runs(m, o, lhs, np.arange(100), total=100).plant["k5"]
    # a Latin hypercube puts exactly one sample in each of the 100 strata
    strata = np.floor((a - 0.9504) / (0.9696 - 0.9504) * 100).astype(int)
    assert sorted(strata.tolist()) == list(range(100))


@pytest.mark.parametrize("change, message", [
    ({"initial": {"x1": {"normal": [0, -1]}}}, "normal std -1 < 0"),
    ({"parameters": {"k1": "declared"}}, "declares no uncertainty"),
    ({"parameters": {"k5": {"normal": [0.96, 0.001]}}}, "normal distribution leaves"),
    ({"parameters": {"k5": {"uniform": [0.9, 0.96]}}}, "leaves the model's declared uncertainty"),
    ({"sampling": "grid"}, "'sampling' must be one of"),
    ({"cases": {"x": {"nope": 1}}}, "signal 'nope' is not"),
    ({"cases": []}, "'cases' must be a non-empty object"),
    ({"observer_parameters": {"zz": 1}}, "is not a parameter of the observer"),
    ({"signals": {"u": {"normal": [0]}}}, "use {\"normal\": [mean, std]}"),
])
def test_bad_sampling_specifications(drive, change, message):
    m, o = drive
    with pytest.raises(UsageError, match=message.replace("(", r"\(").replace("{", r"\{")
                       .replace("[", r"\[")):
        sc = scenario_from_dict({**SCEN, **change})
        for case in sc.case_names:
            signal_program(m, sc, sc.grid(m.time), case=case)
        draw_runs(m, o, sc, np.arange(3))


def test_reference_simulator_runs_are_batch_independent(drive):
    m, o = drive
    sc = scenario_from_dict({k: v for k, v in SCEN.items() if k != "cases"})
    whole = simulate(m, o, sc, runs=6)
    part = simulate(m, o, sc, runs=2, first_run=3)
    for c in whole.columns:
        np.testing.assert_array_equal(part[c], whole[c][3:5])
    np.testing.assert_array_equal(part.parameters["k5"], whole.parameters["k5"][3:5])


def test_declared_signals_are_uniform_over_the_models_bounds():
    m = load_model(MODELS / "three_tank.py")  # bounds: |rho| <= 0.5, |w| <= 0.01
    sc = scenario_from_dict({"t_end": 1, "dt": 0.1, "signals": {
        "rho1": "declared", "w1": {"piecewise": [["declared", "t < 0.5"], [0, True]]}}})
    p = signal_program(m, sc, sc.grid(m.time))
    j = {n: i for i, n in enumerate(p.names)}
    assert np.all(p.base[:, j["rho1"]] == -0.5) and np.all(p.su[:, j["rho1"]] == 1.0)
    assert np.all(p.su[:5, j["w1"]] == 0.02) and np.all(p.su[5:, j["w1"]] == 0)
    v = p.values(1, np.arange(200))[:, :, j["rho1"]]
    assert -0.5 <= v.min() and v.max() < 0.5 and v.std() > 0.25
    bad = scenario_from_dict({"t_end": 1, "dt": 0.1, "signals": {"u1": "declared"}})
    with pytest.raises(UsageError, match="signal 'u1' is \"declared\" but the model declares no bounds"):
        signal_program(m, bad, bad.grid(m.time))


def test_a_quantity_keeps_its_numbers_when_another_becomes_random(drive):
    """Streams belong to quantities in the fixed order, not to the random ones only:
    drawing k5 too leaves every initial state's realisation as it was."""
    m, o = drive
    base = {"steps": 5, "seed": 4, "initial": {"x1": {"uniform": [-1, 1]}}}
    a = draw_runs(m, o, scenario_from_dict(base), np.arange(20))
    b = draw_runs(m, o, scenario_from_dict({**base, "parameters": {"k5": "declared"}}),
                  np.arange(20))
    np.testing.assert_array_equal(a.x0, b.x0)
    assert np.ptp(b.plant["k5"]) > 0


def test_huge_json_numbers_are_one_line_errors():
    for data, message in (({"steps": 3, "initial": {"x1": 10 ** 400}}, "must be finite"),
                          ({"steps": 3, "parameters": {"k5": {"uniform": [0, 10 ** 400]}}},
                           "uniform high must be a finite number"),
                          ({"steps": 3, "signals": {"u": {"normal": [0, 10 ** 400]}}},
                           "normal std must be a finite number"),
                          ({"steps": 3, "signals": {"u": 10 ** 400}}, "must be finite")):
        with pytest.raises(UsageError, match=message):
            scenario_from_dict(data)


# A single run is integrated on numpy scalars (the fast path), several runs on arrays:
# the same numpy arithmetic, so run 0 of a batch is bit for bit the single run.
_SINGLE = {
    "drive, unknown-input (discrete)": (
        "electric_drive.py", {"observer": "unknown-input", "faults": ["d"]},
        {"steps": 60, "seed": 4, "signals": {"u": "sin(t/5)", "d": "Piecewise((0, t < 30), (1, True))",
                                             "rho": {"uniform": [-0.05, 0.05]}}}),
    "tank, interval (continuous, sqrt)": (
        "three_tank.py", {"observer": "interval", "estimate": "x1"},
        {"t_end": 2, "dt": 0.01, "seed": 2, "initial": {"x1": 3, "x2": 2, "x3": 1},
         "signals": {"rho1": "declared", "w1": "declared"}}),
    "sliding mode (sign)": (
        "sliding_example.py", {"observer": "sliding-mode", "faults": ["d"]},
        {"t_end": 1, "dt": 0.001, "seed": 1, "initial": {"x1": 0, "x2": 1, "x3": 0},
         "signals": {"d": "Piecewise((0, t < 0.5), (0.8*sin(t - 0.5), True))",
                     "rho": "0.3*sin(3*t)", "w1": {"uniform": [-0.01, 0.01]}}}),
}


@pytest.mark.parametrize("case", list(_SINGLE))
def test_a_single_run_is_bit_for_bit_run_zero_of_a_batch(case):
    path, kw, scen = _SINGLE[case]
    m = load_model(MODELS / path)
    o = build_observer(m, design(m, **kw))
    sc = scenario_from_dict(scen)
    one, batch = simulate(m, o, sc), simulate(m, o, sc, runs=3)
    assert one["t"].ndim == 1
    for c in one.columns:
        np.testing.assert_array_equal(one[c], batch[c][0], err_msg=f"{case}: {c}")


def test_a_single_run_rounds_powers_as_a_batch():
    """On arrays numpy computes x**2, x**-1 and x**0.5 by exact fast paths, on float64
    scalars the ** operator calls pow (last-bit differences for ~0.07 % of inputs): the
    simulator prints powers so that both round alike. The logistic map amplifies any
    difference (this initial value differed at step 109 with ** printed)."""
    import sympy as sp
    from observer_cad import PlantModel
    x, v = sp.symbols("x v")
    m = PlantModel(name="logistic", time="discrete", states=[x, v], outputs=[x],
                   dynamics=[sp.Rational(37, 10) * x - sp.Rational(37, 10) * x ** 2,
                             v / 2 + 1 / (1 + x ** 2) + sp.sqrt(1 + x) ** 3 + x ** sp.Rational(3, 2)])
    sc = scenario_from_dict({"steps": 400, "initial": {"x": 0.31582937101109626, "v": 0}})
    one, batch = simulate(m, None, sc), simulate(m, None, sc, runs=2)
    for c in one.columns:
        np.testing.assert_array_equal(one[c], batch[c][0], err_msg=c)


def test_a_single_run_keeps_the_same_non_finite_values_as_a_batch():
    import sympy as sp
    from observer_cad import PlantModel
    x = sp.Symbol("x")
    m = PlantModel(name="leak", time="continuous", states=[x], outputs=[sp.sqrt(x), 1 / x],
                   dynamics=[-1 + 0 * x])  # x crosses 0 at t = 1: sqrt → NaN, 1/x → ±inf
    sc = scenario_from_dict({"t_end": 2, "dt": 0.1, "initial": {"x": 1}})
    one = simulate(m, None, sc, keep_nonfinite=True)
    batch = simulate(m, None, sc, runs=2, keep_nonfinite=True)
    assert np.isnan(one["y1"][-1]) and np.isinf(one["y2"][10])
    assert one.nonfinite == batch.nonfinite.replace(" (run 0)", "")
    for c in one.columns:
        np.testing.assert_array_equal(one[c], batch[c][0], err_msg=c)

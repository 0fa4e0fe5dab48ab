"""Ensembles end to end: the same summaries for any chunk size
and on every backend (a Dask LocalCluster included), the worst run found and replayed
exactly, inclusion statistics equal to the reference simulator's, parameters sampled
without recompiling, a guaranteed threshold with no false alarm over sampled plants, and
the ``observer-cad ensemble`` command (files, replay, Ctrl-C)."""
from __future__ import annotations

import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from observer_cad.codegen import STATS, CompiledSimulator
from observer_cad.ensemble import (Backend, ReplayError, default_worst_field, replay,
                                   run_ensemble)
from observer_cad.errors import UsageError
from observer_cad.model import load_model
from observer_cad.observers import build_observer
from observer_cad.residuals import decision_rule
from observer_cad.simulation import (apply_threshold, monitors, scenario_from_dict,
                                     simulate, summarise)
from observer_cad.residuals import ThresholdSpec
from observer_cad.synthesis import design

from tests.ensemble.tasks import sigint_default

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                                reason="no C compiler")

TT = {"t_end": 3, "dt": 0.01, "seed": 5,
      "initial": {"x1": {"uniform": [1.9, 2.1]}, "x2": {"uniform": [1.15, 1.25]},
                  "x3": {"normal": [0.6, 0.02]}},
      "signals": {"u1": "0.5", "u2": "0.2",
                  "rho1": {"uniform": [-0.5, 0.5]}, "rho2": {"uniform": [-0.5, 0.5]},
                  "w1": {"uniform": [-0.01, 0.01]}, "w2": {"uniform": [-0.01, 0.01]}},
      "cases": {"calm": {"rho1": 0, "rho2": 0}, "gusty": {}}}


@pytest.fixture(scope="module")
def tank():
    m = load_model(MODELS / "three_tank.py")
    o = build_observer(m, design(m, observer="interval", estimate="x1"))
    return m, o, CompiledSimulator(m, o), scenario_from_dict(TT)


def _table(res):
    cols = res.accumulator.columns()
    return {k: v for k, v in cols.items() if k != "case"}, list(cols["case"])


def _same(a, b):
    (ta, ca), (tb, cb) = _table(a), _table(b)
    assert ca == cb and list(ta) == list(tb)
    for k in ta:
        assert ta[k].view(np.uint64).tolist() == tb[k].view(np.uint64).tolist(), k


def test_summaries_do_not_depend_on_chunks_or_threads(tank):
    m, o, sim, sc = tank
    ref = run_ensemble(m, o, sc, runs=23, backend=Backend("serial"), chunk=23, simulator=sim,
                       keep=0)
    assert ref.completed == 46 and ref.cases == ("calm", "gusty")
    for chunk, backend in ((1, Backend("serial")), (7, Backend("threads", workers=2)),
                           (5, Backend("threads", workers=3))):
        _same(ref, run_ensemble(m, o, sc, runs=23, backend=backend, chunk=chunk,
                                simulator=sim, keep=0))


@pytest.mark.slow  # a pool of processes and a Dask cluster: ~4 s
def test_processes_and_a_dask_cluster_give_the_same_summaries(tank):
    distributed = pytest.importorskip("distributed")
    m, o, sim, sc = tank
    ref = run_ensemble(m, o, sc, runs=12, backend=Backend("serial"), simulator=sim, keep=0)
    _same(ref, run_ensemble(m, o, sc, runs=12, backend=Backend("processes", workers=2),
                            chunk=5, simulator=sim, keep=0))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        got = run_ensemble(m, o, sc, runs=12, chunk=4, simulator=sim, keep=0,
                           backend=Backend("dask", workers=2, address=cluster.scheduler_address))
    _same(ref, got)


@pytest.mark.slow
def test_a_local_dask_cluster_of_processes_gives_the_same_summaries(tank):
    pytest.importorskip("distributed")
    m, o, sim, sc = tank
    ref = run_ensemble(m, o, sc, runs=12, backend=Backend("serial"), simulator=sim, keep=0)
    _same(ref, run_ensemble(m, o, sc, runs=12, backend=Backend("dask", workers=2), chunk=3,
                            simulator=sim, keep=0))


def test_the_worst_run_is_found_and_replayed_exactly(tank):
    m, o, sim, sc = tank
    res = run_ensemble(m, o, sc, runs=40, backend=Backend("threads", workers=2), chunk=6,
                       simulator=sim, keep=2)
    field = default_worst_field(monitors(m, o))
    assert field == "x1.min_slack"
    cols, _ = _table(res)
    worst = int(cols["run"][np.argmin(cols["x1.min_slack"])])
    assert [k[0] for k in res.kept][0] == worst          # found
    run, case, k, traj = res.kept[0]
    assert (case, k) == res.locate(run)
    # replayed: the trajectory, summarised, gives the recorded bits (checked by the
    # runner too); and it is the run `simulate --case --run` gives
    again = summarise(monitors(m, o), traj.columns, traj["t"])
    at = int(np.flatnonzero(cols["run"] == run)[0])
    for f in again.fields:
        assert again.values[f.name][0] == cols[f.name][at] or \
            (np.isnan(again.values[f.name][0]) and np.isnan(cols[f.name][at]))
    direct = sim.simulate(sc, first_run=k, case=case)
    for c in direct.columns:
        np.testing.assert_array_equal(direct[c], traj[c])
    assert np.min(np.minimum(traj["x1"] - traj["x1_lower"], traj["x1_upper"] - traj["x1"])) \
        == cols["x1.min_slack"][at]
    with pytest.raises(UsageError, match="does not exist"):
        replay(m, o, sc, 80, runs=40, simulator=sim)


def test_a_replay_that_differs_is_an_error(tank):
    m, o, sim, sc = tank
    res = run_ensemble(m, o, sc, runs=4, backend=Backend("serial"), simulator=sim, keep=0)
    other = scenario_from_dict({**TT, "seed": 6})  # other random numbers: another run
    with pytest.raises(ReplayError, match="replay of run 1"):
        replay(m, o, other, 1, runs=4, simulator=sim, expect=res.accumulator)


def test_inclusion_statistics_equal_the_reference_simulators(tank):
    m, o, sim, sc = tank
    short = scenario_from_dict({**TT, "t_end": 1})
    comp = run_ensemble(m, o, short, runs=6, backend=Backend("threads", workers=2), chunk=4,
                        simulator=sim, keep=0)
    ref = run_ensemble(m, o, short, runs=6, engine="reference", backend=Backend("serial"),
                       chunk=4, keep=0)
    assert ref.engine.startswith("reference") and comp.engine.startswith("compiled")
    (tc, cc), (tr, cr) = _table(comp), _table(ref)
    assert cc == cr
    np.testing.assert_array_equal(tc["x1.violations"], tr["x1.violations"])
    np.testing.assert_array_equal(tc["finite"], tr["finite"])
    np.testing.assert_allclose(tc["x1.min_slack"], tr["x1.min_slack"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(tc["x1.max_width"], tr["x1.max_width"], rtol=0, atol=1e-12)
    so, sr = comp.statistics.overall.fields, ref.statistics.overall.fields
    assert so["x1.violations"].positive == sr["x1.violations"].positive
    assert so["x1.min_slack"].worst_run == sr["x1.min_slack"].worst_run


def test_sampled_plants_share_one_library_and_the_guaranteed_band_holds():
    """k5 drawn from its declared box in every run, one compiled library; the guaranteed
    threshold raises no alarm in any fault-free run and detects the fault in every
    faulty one."""
    m = load_model(MODELS / "electric_drive_uncertain.py")
    des = design(m, observer="diagnostic")
    o = apply_threshold(m, build_observer(m, des), ThresholdSpec.parse("guaranteed"))
    rule = decision_rule(m, des)
    sc = scenario_from_dict({
        "steps": 200, "seed": 11, "parameters": {"k5": "declared"},
        "signals": {"u": "2*sin(t/10)", "rho": {"uniform": [-0.05, 0.05]},
                    "w1": {"uniform": [0, 0.02]}, "w2": {"uniform": [-0.01, 0.01]}},
        "cases": {"fault-free": {}, "d = 0.2": {"d": "Piecewise((0, t < 100), (0.2, True))"}}})
    n = STATS["compiles"]
    sim = CompiledSimulator(m, o)
    res = run_ensemble(m, o, sc, runs=150, rule=rule, backend=Backend("threads", workers=2),
                       simulator=sim, keep=1)
    assert STATS["compiles"] <= n + 1          # at most the one library, none per sample
    free, faulty = res.statistics.cases["fault-free"], res.statistics.cases["d = 0.2"]
    assert free.fields["r.exceedances"].positive == 0
    assert free.fields["alarm.samples"].positive == 0
    assert faulty.fields["alarm.samples"].positive == 150
    assert faulty.fields["alarm.first"].max >= 100


# ------------------------------------------------------------------ the command
def _run(args, **kw):
    return subprocess.run([sys.executable, "-m", "observer_cad"] + [str(a) for a in args],
                          capture_output=True, text=True, cwd=ROOT, timeout=600, **kw)


@pytest.fixture
def scen_file(tmp_path):
    p = tmp_path / "tt.json"
    p.write_text(json.dumps(TT))
    return p


@pytest.mark.slow
def test_ensemble_command_writes_summary_statistics_figures_and_worst_runs(tmp_path, scen_file,
                                                                          capsys):
    from observer_cad.cli import main
    out = tmp_path / "out"
    rc = main(["ensemble", str(MODELS / "three_tank.py"), "--observer", "interval", "--estimate",
               "x1", "--scenario", str(scen_file), "--runs", "30", "--workers", "2",
               "--chunk", "7", "--out", str(out)])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    rows = list(csv.DictReader(open(out / "summary.csv")))
    assert len(rows) == 60 and [int(r["run"]) for r in rows] == list(range(60))
    assert {r["case"] for r in rows} == {"calm", "gusty"}
    assert all(int(r["sample"]) == int(r["run"]) % 30 and r["seed"] == "5" for r in rows)
    assert all(r["x1.first_violation"] == "" for r in rows)  # never violated: empty cell
    stats = json.loads((out / "statistics.json").read_text())
    assert stats["ensemble"]["runs"] == 60 and stats["ensemble"]["completed"] == 60
    assert stats["ensemble"]["interrupted"] is False
    assert stats["statistics"]["overall"]["fields"]["x1.violations"]["positive"] == 0
    assert (out / "figures" / "hist_x1_min_slack.png").is_file()
    worst = int(min(rows, key=lambda r: float(r["x1.min_slack"]))["run"])
    assert (out / "worst" / f"run_{worst}" / "signals.csv").is_file()
    assert f"worst run {worst}" in cap.out and "reproduced exactly" in cap.out
    # --replay writes one run, the one `simulate --case --run` writes
    rc = main(["ensemble", str(MODELS / "three_tank.py"), "--observer", "interval", "--estimate",
               "x1", "--scenario", str(scen_file), "--runs", "30", "--replay", str(worst),
               "--out", str(out)])
    assert rc == 0
    rc = main(["simulate", str(MODELS / "three_tank.py"), "--observer", "interval", "--estimate",
               "x1", "--scenario", str(scen_file), "--case", "calm" if worst < 30 else "gusty",
               "--run", str(worst % 30), "--out", str(tmp_path / "sim")])
    assert rc == 0
    a = (out / f"run_{worst}" / "signals.csv").read_text()
    assert a == (tmp_path / "sim" / "signals.csv").read_text()
    assert a == (out / "worst" / f"run_{worst}" / "signals.csv").read_text()


@pytest.mark.parametrize("argv, message", [
    (["--runs", "0"], "--runs 0: must be at least 1"),
    (["--runs", "5", "--backend", "threads", "--dask", "tcp://h:1"], "--dask ADDRESS runs on Dask"),
    (["--runs", "5", "--worst-by", "nope"], "no summary field 'nope'"),
    (["--runs", "5", "--engine", "reference", "--backend", "processes"],
     "the reference engine runs in this process only"),
    # (an audit: --runs 999999999999 grew to 3 GB before anything said no; now above a C
    # int it is refused by the option itself, and below by the summaries' memory)
    (["--runs", "999999999999"], "must be at most 2147483647"),
    (["--runs", "2000000000"], "summary fields would keep about"),
])
def test_ensemble_command_errors_are_one_line(tmp_path, scen_file, capsys, argv, message):
    from observer_cad.cli import main
    rc = main(["ensemble", str(MODELS / "three_tank.py"), "--observer", "interval", "--estimate",
               "x1", "--scenario", str(scen_file), "--out", str(tmp_path)] + argv)
    err = capsys.readouterr().err
    assert rc == 2 and message in err and len(err.strip().splitlines()) == 1, err


def test_ensemble_out_that_cannot_be_written_is_refused_before_the_runs(tmp_path, scen_file,
                                                                         capsys, monkeypatch):
    """A file where --out should be (or a read-only folder) is one line, exit 2, before any
    run — not an internal error after all of them."""
    import observer_cad.ensemble as ensemble
    from observer_cad.cli import main

    def never(*args, **kwargs):  # pragma: no cover - the point: not reached
        raise AssertionError("the runs started")

    monkeypatch.setattr(ensemble, "run_ensemble", never)
    (tmp_path / "afile").write_text("x")
    rc = main(["ensemble", str(MODELS / "three_tank.py"), "--observer", "interval", "--estimate",
               "x1", "--scenario", str(scen_file), "--runs", "5", "--out",
               str(tmp_path / "afile")])
    err = capsys.readouterr().err
    assert rc == 2 and "cannot write the output directory" in err, err
    assert len(err.strip().splitlines()) == 1 and (tmp_path / "afile").read_text() == "x"


@pytest.mark.slow  # a subprocess and a pool of processes: ~4 s
@pytest.mark.skipif(sys.platform == "win32", reason="SIGINT")
def test_ctrl_c_leaves_what_finished_readable(tmp_path, scen_file):
    """SIGINT after the first chunks: exit 130, summary.csv holds exactly the finished
    runs, statistics.json says so."""
    sc = json.loads(scen_file.read_text())
    sc["t_end"] = 20
    scen_file.write_text(json.dumps(sc))
    out = tmp_path / "out"
    env = dict(os.environ, OBSERVER_CAD_PROGRESS="1")
    p = subprocess.Popen([sys.executable, "-m", "observer_cad", "ensemble",
                          str(MODELS / "three_tank.py"), "--observer", "interval", "--estimate",
                          "x1", "--scenario", str(scen_file), "--runs", "200000", "--chunk", "8",
                          "--workers", "2", "--out", str(out)],
                         cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, preexec_fn=sigint_default)
    seen = ""
    deadline = time.time() + 300
    while time.time() < deadline:  # the progress bar shows runs done
        ch = p.stderr.read(1)
        if not ch:
            break
        seen += ch
        if "runs:" in seen and any(f"| {k}/400000" in seen for k in range(16, 4000, 8)):
            break
    p.send_signal(signal.SIGINT)
    stdout, rest = p.communicate(timeout=120)
    assert p.returncode == 130, seen + rest
    assert "interrupted after" in rest and "Traceback" not in rest
    stats = json.loads((out / "statistics.json").read_text())
    assert stats["ensemble"]["interrupted"] is True
    done = stats["ensemble"]["completed"]
    rows = list(csv.DictReader(open(out / "summary.csv")))
    assert 0 < len(rows) == done < 400000


def test_the_shipped_ensemble_scenario(tank):
    """models/scenarios/three_tank_ensemble.json (the example of docs/ENSEMBLES.md): declared noise and
    disturbances, two cases; no run leaves the interval."""
    from observer_cad.simulation import load_scenario
    m, o, sim, _ = tank
    sc = load_scenario(MODELS / "scenarios" / "three_tank_ensemble.json")
    res = run_ensemble(m, o, sc, runs=16, settle=5, backend=Backend("threads", workers=2),
                       simulator=sim, keep=0)
    assert res.cases == ("calm", "gusty") and res.completed == 32
    assert res.statistics.overall.fields["x1.violations"].positive == 0
    assert res.statistics.overall.fields["x1.min_slack"].min > 0


@pytest.mark.parametrize("settle, tol", [(0.0, 0.0), (1.0, 0.0), (0.5, 0.02)])
def test_interval_summaries_in_the_loop_equal_summarise(tank, settle, tol):
    """The compiled loop summarises intervals whose truth is a column while the samples
    are in registers (and then stores no trajectory); the values equal summarise()'s on
    the stored columns — with violations (noise 50× its declared bound), a settle window,
    a tolerance, and runs that leave the domain (x3 < 0: sqrt of a negative, NaN), which
    are simulated again with their columns stored."""
    from observer_cad.ensemble import Chunk
    from observer_cad.ensemble._runner import _compiled_chunk, _layout, _loop_intervals, _Payload
    from observer_cad.simulation import signal_program
    m, o, sim, _ = tank
    sc = scenario_from_dict({**TT, "signals": {**TT["signals"], "w1": {"uniform": [-0.5, 0.5]}},
                             "initial": {**TT["initial"], "x3": {"normal": [0.2, 0.3]}}})
    t = sc.grid(m.time)
    mon = monitors(m, o, settle=settle, tolerance=tol)
    lay = _layout(m, o)
    loop = _loop_intervals(mon, lay, t)
    assert loop and loop[0] == ("x1",)
    progs = tuple(signal_program(m, sc, t, case=c) for c in sc.case_names)
    with_loop = _Payload(sim.local_engine(), t, progs, sim.plan(sc), 40, sc.seed, mon, lay, loop)
    without = _Payload(sim.local_engine(), t, progs, sim.plan(sc), 40, sc.seed, mon, lay, ())
    for first, count in ((0, 20), (20, 20)):
        a = _compiled_chunk(with_loop, Chunk(1, first, count))
        b = _compiled_chunk(without, Chunk(1, first, count))
        for f in b.fields:
            x, y = a.values[f.name], b.values[f.name]
            assert np.all((x == y) | (np.isnan(x) & np.isnan(y))), f.name
    whole = _compiled_chunk(without, Chunk(1, 0, 40)).values
    assert np.count_nonzero(whole["x1.violations"]) > 5        # the case really violates
    assert 0 < np.count_nonzero(whole["finite"] == 0) < 40       # and some runs diverge


def test_several_intervals_in_the_loop_equal_summarise():
    """Two intervals (x1 and x2) summarised in the loop at once — each keeps its own
    running values — equal summarise()'s on the stored columns, violations, settle
    window and diverging runs included."""
    from observer_cad.ensemble import Chunk
    from observer_cad.ensemble._runner import _compiled_chunk, _layout, _loop_intervals, _Payload
    from observer_cad.simulation import signal_program
    m = load_model(MODELS / "three_tank.py")
    o = build_observer(m, design(m, observer="interval", estimate=["x1", "x2"]))
    sim = CompiledSimulator(m, o)
    sc = scenario_from_dict({**TT, "signals": {**TT["signals"], "w1": {"uniform": [-0.3, 0.3]}},
                             "initial": {**TT["initial"], "x3": {"normal": [0.3, 0.3]}}})
    t = sc.grid(m.time)
    mon = monitors(m, o, settle=0.5)
    lay = _layout(m, o)
    loop = _loop_intervals(mon, lay, t)
    assert loop and loop[0] == ("x1", "x2")
    progs = tuple(signal_program(m, sc, t, case=c) for c in sc.case_names)
    with_loop = _Payload(sim.local_engine(), t, progs, sim.plan(sc), 30, sc.seed, mon, lay, loop)
    without = _Payload(sim.local_engine(), t, progs, sim.plan(sc), 30, sc.seed, mon, lay, ())
    a = _compiled_chunk(with_loop, Chunk(1, 0, 30))
    b = _compiled_chunk(without, Chunk(1, 0, 30))
    for f in b.fields:
        x, y = a.values[f.name], b.values[f.name]
        assert np.all((x == y) | (np.isnan(x) & np.isnan(y))), f.name
    for sig in ("x1", "x2"):
        assert np.count_nonzero(b.values[f"{sig}.violations"]) > 3, sig
    assert not np.array_equal(b.values["x1.min_slack"], b.values["x2.min_slack"])

"""Progress on stderr for long designs: stage lines after 2 s on a
terminal (or with OBSERVER_CAD_PROGRESS=1), never in the default test output."""
from __future__ import annotations

import io

from observer_cad import design, load_model
from observer_cad.cli import main
from observer_cad.progress import Reporter, report, reporting


class _Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def test_nothing_before_the_threshold_then_throttled_lines():
    clock, out = _Clock(), io.StringIO()
    with reporting(Reporter(out, after=2.0, every=1.0, enabled=True, clock=clock)) as rep:
        report("designing: k = 1 of at most 9")       # t = 0: too early
        clock.t = 2.5
        report("designing: k = 2 of at most 9")       # printed
        clock.t = 2.9
        report("designing: k = 3 of at most 9")       # within 1 s of the last: skipped
        report("building the observer", stage=True)  # a new stage: printed
    assert [l.split(" (")[0] for l in rep.lines] == [
        "observer-cad: designing: k = 2 of at most 9", "observer-cad: building the observer"]
    assert out.getvalue().count("\n") == 2
    assert "(2.5 s)" in rep.lines[0]


def test_disabled_on_a_pipe_by_default(monkeypatch):
    monkeypatch.delenv("OBSERVER_CAD_PROGRESS", raising=False)
    assert not Reporter(io.StringIO()).enabled
    monkeypatch.setenv("OBSERVER_CAD_PROGRESS", "1")
    assert Reporter(io.StringIO()).enabled


def test_no_reporter_no_output(models_dir, capsys):
    report("anything")  # no active reporter: a no-op
    design(load_model(models_dir / "electric_drive.py"), observer="unknown-input", faults=["d"])
    assert capsys.readouterr().err == ""


def test_a_design_reports_its_steps(models_dir):
    rep = Reporter(io.StringIO(), after=0.0, every=0.0, enabled=True)
    with reporting(rep):
        design(load_model(models_dir / "electric_drive.py"), observer="unknown-input",
               faults=["rho"])
    assert any("designing (exact, canonical form): k = 2 of at most 2" in l for l in rep.lines)
    assert any("extracting the structure" in l for l in rep.lines)


def test_cli_stderr_stays_clean(models_dir, capsys, monkeypatch):
    monkeypatch.delenv("OBSERVER_CAD_PROGRESS", raising=False)
    rc = main(["design", str(models_dir / "electric_drive.py"), "--observer", "unknown-input",
               "--fault", "d"])
    assert rc == 0
    assert capsys.readouterr().err == ""


def test_heartbeat_repeats_the_latest_message_when_silent():
    clock, out = _Clock(), io.StringIO()
    rep = Reporter(out, after=2.0, every=1.0, heartbeat=5.0, enabled=True, clock=clock)
    rep("reading the model big.py", stage=True)  # t = 0: before the threshold
    rep.beat()                                    # still before the threshold
    clock.t = 2.1
    rep.beat()                                    # nothing printed yet: the pending message
    clock.t = 4.0
    rep.beat()                                    # printed 1.9 s ago: quiet
    clock.t = 7.2
    rep.beat()                                    # 5.1 s of silence: repeated
    assert [l.split(" (")[0] for l in rep.lines] == [
        "observer-cad: reading the model big.py",
        "observer-cad: reading the model big.py, still running"]


def test_reporting_starts_and_stops_its_heartbeat_thread():
    import threading
    before = {t.name for t in threading.enumerate()}
    with reporting(Reporter(io.StringIO(), enabled=True)):
        assert "observer-cad-progress" in {t.name for t in threading.enumerate()}
    assert "observer-cad-progress" not in {t.name for t in threading.enumerate()} - before

"""The --out contract on every command: an empty or blank --out refused; obstacles found
before anything is written (an ensemble: before its runs); everything staged and moved
into place together; the files a command's last run wrote and the new run does not are
removed (those observer-cad did not write never are); SIGHUP and SIGQUIT end a command
like SIGTERM, leaving no staging folder."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from observer_cad.cli import main
from observer_cad.errors import UsageError
from observer_cad.files import MANIFEST, check_output_targets, staged_directory

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
DRIVE = MODELS / "electric_drive.py"
TT = {"t_end": 1, "dt": 0.01, "seed": 5,
      "initial": {"x1": 2, "x2": 1.2, "x3": 0.6},
      "signals": {"u1": "0.5", "u2": "0.2", "rho1": {"uniform": [-0.5, 0.5]},
                  "rho2": {"uniform": [-0.5, 0.5]}, "w1": {"uniform": [-0.01, 0.01]},
                  "w2": {"uniform": [-0.01, 0.01]}}}
needs_cc = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                              reason="no C compiler")


def snapshot(d: Path) -> dict:
    return {str(p.relative_to(d)): (p.read_bytes() if p.is_file() else None)
            for p in sorted(d.rglob("*"))}


def _one_line(rc, err, needle=""):
    assert rc == 2, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("observer-cad: error:"), err
    assert needle in lines[0], lines[0]


@pytest.mark.parametrize("value", ["", "   ", "\t", "out\nx"])
@pytest.mark.parametrize("command", [
    ["simulate", str(DRIVE), "--observer", "unknown-input", "--fault", "d", "--scenario",
     str(MODELS / "scenarios" / "electric_drive_fig1.json")],
    ["codegen", str(DRIVE), "--observer", "unknown-input", "--fault", "d"],
    ["ensemble", str(MODELS / "three_tank.py"), "--observer", "interval", "--estimate", "x1",
     "--scenario", str(MODELS / "scenarios" / "three_tank_ensemble.json"), "--runs", "2"],
    ["demo", "--no-compile"],
])
def test_an_empty_blank_or_control_character_out_is_refused(tmp_path, monkeypatch, capsys,
                                                            command, value):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "keep.txt").write_text("mine")
    rc = main(command + ["--out", value])
    _one_line(rc, capsys.readouterr().err, "--out")
    assert snapshot(tmp_path) == {"keep.txt": b"mine"}


def test_check_output_targets_finds_every_kind_of_obstacle(tmp_path):
    (tmp_path / "figures").write_text("a file where a folder goes")
    (tmp_path / "summary.csv").mkdir()
    with pytest.raises(UsageError, match="figures"):
        check_output_targets(tmp_path, folders=["figures"])
    with pytest.raises(UsageError, match="a directory is in the way"):
        check_output_targets(tmp_path, files=["summary.csv"])
    with pytest.raises(UsageError, match="a file is in the way"):
        check_output_targets(tmp_path, files=["figures/hist.png"])
    check_output_targets(tmp_path, files=["statistics.json"], folders=["worst"])
    check_output_targets(tmp_path / "new", files=["a"], folders=["b"])  # nothing there yet


def _stage(out, files, command="cmd"):
    with staged_directory(out, command=command) as st:
        for rel, text in files.items():
            (st / rel).parent.mkdir(parents=True, exist_ok=True)
            (st / rel).write_text(text)


def test_a_commands_stale_files_are_removed_and_no_one_elses(tmp_path):
    out = tmp_path / "out"
    _stage(out, {"a.csv": "1", "fig/b.png": "1", "fig/c.png": "1"})
    (out / "mine.txt").write_text("user")
    (out / "fig" / "mine.png").write_text("user")
    _stage(out, {"x.c": "other command"}, command="other")
    _stage(out, {"a.csv": "2", "fig/b.png": "2"})
    assert snapshot(out) | {MANIFEST: None} == {
        "a.csv": b"2", "fig": None, "fig/b.png": b"2", "fig/mine.png": b"user",
        "mine.txt": b"user", "x.c": b"other command", MANIFEST: None}
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest == {"cmd": ["a.csv", "fig/b.png"], "other": ["x.c"]}
    _stage(out, {"a.csv": "3"})  # the folder a run emptied goes too, unless not empty
    assert not (out / "fig" / "b.png").exists() and (out / "fig" / "mine.png").exists()


def test_a_manifest_is_data_never_a_path_outside(tmp_path):
    """A tampered manifest cannot make a run remove anything outside --out, follow a
    symlinked folder, or remove a folder."""
    out, victim = tmp_path / "out", tmp_path / "victim"
    victim.mkdir()
    (victim / "precious.txt").write_text("keep")
    out.mkdir()
    (out / "linked").symlink_to(victim, target_is_directory=True)
    (out / "adir").mkdir()
    (out / MANIFEST).write_text(json.dumps({"cmd": [
        "../victim/precious.txt", str(victim / "precious.txt"), "linked/precious.txt",
        "adir", "", None, 3, "./x", "a/../../victim/precious.txt"]}))
    _stage(out, {"new.txt": "1"})
    assert (victim / "precious.txt").read_text() == "keep" and (out / "adir").is_dir()
    (out / MANIFEST).write_text("not json {")
    _stage(out, {"new.txt": "2"})  # an unreadable manifest: nothing removed, rewritten
    assert json.loads((out / MANIFEST).read_text()) == {"cmd": ["new.txt"]}


def test_an_error_while_staging_changes_nothing(tmp_path):
    out = tmp_path / "out"
    _stage(out, {"a.csv": "1", "b.csv": "1"})
    before = snapshot(out)
    with pytest.raises(RuntimeError):
        with staged_directory(out, command="cmd") as st:
            (st / "a.csv").write_text("2")
            raise RuntimeError("a plot failed")
    assert snapshot(out) == before


@needs_cc
def test_ensemble_obstacles_are_found_before_the_runs(tmp_path, capsys, monkeypatch):
    """A file named figures (or worst) in --out: one line before any run, and --out not
    changed (summary.csv and statistics.json were written before the check)."""
    import observer_cad.ensemble as ensemble

    def never(*args, **kwargs):  # pragma: no cover - the point: not reached
        raise AssertionError("the runs started")

    monkeypatch.setattr(ensemble, "run_ensemble", never)
    sc = tmp_path / "sc.json"
    sc.write_text(json.dumps(TT))
    for name in ("figures", "worst"):
        out = tmp_path / f"out_{name}"
        out.mkdir()
        (out / name).write_text("in the way")
        before = snapshot(out)
        rc = main(["ensemble", str(MODELS / "three_tank.py"), "--observer", "interval",
                   "--estimate", "x1", "--scenario", str(sc), "--runs", "2", "--out", str(out)])
        _one_line(rc, capsys.readouterr().err, name)
        assert snapshot(out) == before


@pytest.mark.slow
@needs_cc
def test_a_second_ensemble_replaces_the_first_ones_files(tmp_path, capsys):
    """The worst runs and histograms of an earlier ensemble go; a user's file stays."""
    sc = tmp_path / "sc.json"
    sc.write_text(json.dumps(TT))
    out = tmp_path / "out"
    base = ["ensemble", str(MODELS / "three_tank.py"), "--observer", "interval", "--estimate",
            "x1", "--scenario", str(sc), "--out", str(out), "--workers", "1"]
    assert main(base + ["--runs", "4", "--keep", "2"]) == 0
    first = {p for p in snapshot(out) if p.startswith("worst/run_")}
    assert len({p.split("/")[1] for p in first}) == 2
    (out / "worst" / "notes.txt").write_text("mine")
    assert main(base + ["--runs", "3", "--keep", "0"]) == 0
    capsys.readouterr()
    left = snapshot(out)
    assert not any(p.startswith("worst/run_") for p in left), left.keys()
    assert left["worst/notes.txt"] == b"mine" and "summary.csv" in left
    assert not any(p.startswith(".staging") for p in left)


@pytest.mark.slow  # a subprocess simulating until it is stopped, twice: ~10 s
@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
@pytest.mark.parametrize("signame, status", [("SIGHUP", 129), ("SIGQUIT", 131)])
def test_sighup_and_sigquit_leave_out_as_it_was(tmp_path, signame, status):
    import signal
    import time

    sc = tmp_path / "sc.json"
    sc.write_text('{"steps": 400000}')
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("user data\n")
    before = snapshot(out)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.Popen([sys.executable, "-m", "observer_cad.cli", "simulate", str(DRIVE),
                          "--observer", "unknown-input", "--fault", "d", "--engine", "reference",
                          "--scenario", str(sc), "--out", str(out)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, cwd=tmp_path)
    for _ in range(1200):  # until the staging folder exists (the results are being written)
        if any(q.name.startswith(".staging-") for q in out.iterdir()) or p.poll() is not None:
            break
        time.sleep(0.05)
    assert p.poll() is None, p.communicate()
    p.send_signal(getattr(signal, signame))
    p.communicate(timeout=120)
    assert p.returncode == status
    assert snapshot(out) == before


@needs_cc
def test_codegen_names_share_a_folder_and_each_replaces_its_own(tmp_path, capsys):
    out = tmp_path / "out"
    base = ["codegen", str(DRIVE), "--observer", "unknown-input", "--fault", "d", "--out",
            str(out)]
    assert main(base + ["--name", "first"]) == 0
    assert main(base + ["--name", "second"]) == 0
    capsys.readouterr()
    names = {p.name for p in out.iterdir()}
    assert {"first.c", "first.h", "second.c", "second.h"} <= names
    manifest = json.loads((out / MANIFEST).read_text())
    assert set(manifest) == {"codegen --name first", "codegen --name second"}

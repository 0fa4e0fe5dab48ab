"""The ensemble's memory estimate counts the runs there are; the compile cache's checks,
stated exactly: the ``.sha256`` beside a library detects corruption, not a library
replaced together with its checksum — except for libraries this process compiled, which
are checked against a hash kept in memory; a ``.ref`` must name its own library."""
from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path

import pytest

ca = pytest.importorskip("casadi")

from observer_cad.codegen import compile_function, verify_library  # noqa: E402
from observer_cad.codegen import _compile  # noqa: E402
from observer_cad.codegen._compile import lookup_fingerprint  # noqa: E402
from observer_cad.ensemble._runner import held_runs  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
needs_cc = pytest.mark.skipif(shutil.which(os.environ.get("CC") or "cc") is None,
                              reason="no C compiler")


def test_held_runs_is_never_more_than_the_runs():
    assert held_runs(20, 2147483647, 1000) == 20
    assert held_runs(20, 7, 1000) == 20
    assert held_runs(10_000, 7, 4) == 28
    assert held_runs(5, 1, 1) == 1


def test_the_ensemble_asks_for_the_memory_of_the_runs_there_are(monkeypatch):
    """--runs 20 --workers 1000 (or --chunk 2147483647) was refused with 'would need about
    6.9 GiB': the estimate used chunk × workers."""
    from observer_cad.ensemble import Backend, _runner, run_ensemble
    from observer_cad.model import load_model
    from observer_cad.observers import build_observer
    from observer_cad.simulation import scenario_from_dict
    from observer_cad.synthesis import design

    seen = {}

    class Stop(Exception):
        pass

    def spy(scenario, time, *, runs, columns):
        seen["runs"] = runs
        raise Stop

    monkeypatch.setattr(_runner, "check_memory", spy)
    m = load_model(ROOT / "models" / "three_tank.py")
    o = build_observer(m, design(m, observer="interval", estimate="x1"))
    sc = scenario_from_dict({"t_end": 1, "dt": 0.01, "initial": {"x1": 2, "x2": 1.2, "x3": 0.6},
                             "signals": {"u1": "0.5", "u2": "0.2"},
                             "cases": {"a": {}, "b": {}}})
    for chunk, workers in ((2147483647, 2), (1, 1000), (5, 3)):
        with pytest.raises(Stop):
            run_ensemble(m, o, sc, runs=20, chunk=chunk,
                         backend=Backend("threads", workers=workers))
        assert seen["runs"] == min(40, min(chunk, 20) * workers)


def tiny(k, name="ocad_harden"):
    x = ca.SX.sym("x", 2)
    return ca.Function(name, [x], [k * x + 1], ["x"], ["y"])


def _forge(target: Path, source: Path) -> None:
    """Replace ``target`` by ``source``'s bytes with a matching .sha256 (what a writer of
    the cache folder can do)."""
    data = source.read_bytes()
    tmp = target.with_name(".forged.tmp")
    tmp.write_bytes(data)  # a new file moved over the old (never rewritten in place: it
    os.chmod(tmp, 0o644)   # may be mapped by this process)
    os.replace(tmp, target)
    target.with_name(target.name + ".sha256").write_text(
        f"{hashlib.sha256(data).hexdigest()}  {target.name}\n")


@needs_cc
def test_a_forged_library_is_refused_in_the_process_that_built_it(tmp_path, monkeypatch):
    good = compile_function(tiny(2.0), cache=tmp_path / "c1")
    evil = compile_function(tiny(3.0), cache=tmp_path / "c2")  # same name, one constant edited
    assert verify_library(good.path) is None
    _forge(good.path, evil.path)
    assert "not the library this process compiled" in verify_library(good.path)
    # rebuilt, not loaded: the right values
    again = compile_function(tiny(2.0), cache=tmp_path / "c1")
    assert [float(v) for v in again(ca.DM([1, 2])).full().ravel()] == [3.0, 5.0]
    # another process has no such memory: the checksum alone cannot tell (documented)
    _forge(again.path, evil.path)
    monkeypatch.setattr(_compile, "_BUILT", {})
    assert verify_library(again.path) is None


@needs_cc
def test_a_ref_must_name_its_own_library(tmp_path, monkeypatch):
    cache = tmp_path / "c"
    ident = ("harden-ref-test",)
    compile_function(tiny(2.0), cache=cache, identity=ident, name="ocad_harden")
    other = compile_function(tiny(3.0), cache=cache)  # another valid library in the cache
    refs = list(cache.glob("ocad_harden-*.ref"))
    assert len(refs) == 1
    rec = json.loads(refs[0].read_text())
    fp = rec["fingerprint"]
    assert lookup_fingerprint(fp, "ocad_harden", cache=cache) is not None
    # redirected to a library whose name does not carry the recorded key: refused
    bad = dict(rec, library=other.path.name)
    refs[0].write_text(json.dumps(bad))
    assert lookup_fingerprint(fp, "ocad_harden", cache=cache) is None
    # a consistent forgery (library and key both changed): refused by the process that
    # recorded the .ref; another process would believe it (documented)
    other_key = other.path.name[len("ocad_harden-"):-len(".so")]
    forged = dict(rec, library=other.path.name, key=other_key + "0" * (64 - len(other_key)))
    refs[0].write_text(json.dumps(forged))
    assert lookup_fingerprint(fp, "ocad_harden", cache=cache) is None
    monkeypatch.setattr(_compile, "_REFS", {})
    assert lookup_fingerprint(fp, "ocad_harden", cache=cache) is not None


def test_the_docs_state_what_the_checksum_detects():
    text = (ROOT / "docs" / "RUNNING.md").read_text()
    assert "*corruption*, not *forgery*" in text
    assert "replaced or unverifiable library is rebuilt atomically,\n  never loaded" not in text
    assert "detects *corruption*" in _compile.__doc__ or "corruption" in _compile.__doc__

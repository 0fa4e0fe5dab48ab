"""The time budget of the Jordan minimality proof (METHOD §2b, "k is minimal over λ"): a
budget stops a long proof and the condition reports the range the least order lies in;
the exhaustive proof (``proof_seconds=None``) gives the result of running it to the end;
the option is validated in one line and carried by the design's request."""
from __future__ import annotations

import json

import pytest
import sympy as sp

from observer_cad import UsageError, design, load_model
from observer_cad.model import random_model
from observer_cad.synthesis import DesignRequest, design_jordan
from observer_cad.synthesis.core import PROOF_SECONDS
from observer_cad.synthesis.jordan.minimality import (UNLIMITED, ProofClock, ProofStopped,
                                                     box_cover, proof_seconds_value)


def _minimal(d):
    return next(c for c in d.conditions if c.name == "k is minimal over λ")


def _plane_plant():
    """random_model(8, 2, 0, seed=8, discrete), z = (x1, x2): five rows; four (q + 2) are
    ruled out only by the decision on planes of R⁴ (q_plus_two_rows_possible)."""
    return random_model(8, 2, 0, seed=8, time="discrete"), sp.eye(8)[:2, :]


@pytest.mark.slow
def test_budget_stops_a_long_proof_and_reports_the_range():
    m, M = _plane_plant()
    full = design_jordan(m, observer="virtual-sensor", estimate=M, proof_seconds=None)
    stopped = design_jordan(m, observer="virtual-sensor", estimate=M, proof_seconds=0)
    assert full.k == stopped.k == 5 and stopped.certificate.passed
    assert full.matrices.Phi == stopped.matrices.Phi  # the search is not budgeted
    assert _minimal(full).holds and "exactly 4 are impossible" in _minimal(full).detail
    cond = _minimal(stopped)
    assert not cond.holds and not cond.required
    assert "lies in [4, 5] (the proof stopped at its time budget of 0 s" in cond.detail
    assert "whether 4 rows are possible" in cond.detail
    assert "4 rows: not decided: the proof's time budget of 0 s ran out" in cond.detail


def test_exhaustive_and_an_ample_budget_give_the_same_design():
    m = random_model(6, 2, 0, seed=0, time="continuous")
    a = design_jordan(m, observer="interval", estimate=sp.eye(6)[:2, :], proof_seconds=None)
    b = design_jordan(m, observer="interval", estimate=sp.eye(6)[:2, :], proof_seconds=1e6)
    assert json.dumps(a.to_json(), sort_keys=True, default=str) == \
        json.dumps(b.to_json(), sort_keys=True, default=str)
    assert _minimal(a).holds and "time budget" not in _minimal(a).detail


def test_proof_seconds_round_trips_through_the_request(models_dir):
    m = load_model(models_dir / "three_tank_linear.py")
    d = design(m, observer="virtual-sensor", estimate="x1")
    assert d.request.proof_seconds == PROOF_SECONDS
    assert "proof_seconds" not in d.request.to_json()  # the default: as before
    e = design(m, observer="virtual-sensor", estimate="x1", proof_seconds="exhaustive")
    assert e.request.proof_seconds is None and e.request.to_json()["proof_seconds"] is None
    assert DesignRequest.from_json(e.request.to_json(), {}) == e.request
    again = design(m, **e.request.options())
    assert again.request == e.request and again.k == e.k
    f = design(m, observer="virtual-sensor", estimate="x1", proof_seconds=0.5)
    assert DesignRequest.from_json(f.request.to_json(), {}).proof_seconds == 0.5
    with pytest.raises(UsageError, match="proof_seconds"):
        DesignRequest.from_json(dict(e.request.to_json(), proof_seconds="soon"), {})


@pytest.mark.parametrize("bad", [-1, "-0.5", float("nan"), "soon", True])
def test_a_bad_budget_is_a_one_line_error(bad):
    m = random_model(4, 2, 0, seed=0, time="continuous")
    with pytest.raises(UsageError) as exc:
        design_jordan(m, observer="virtual-sensor", estimate="x1", proof_seconds=bad)
    assert len(str(exc.value).splitlines()) == 1 and "proof_seconds" in str(exc.value)


def test_cli_proof_seconds(models_dir, capsys):
    from observer_cad.cli import main
    path = str(models_dir / "three_tank_linear.py")
    base = ["design", path, "--observer", "virtual-sensor", "--estimate", "x1"]
    rc = main(base + ["--proof-seconds", "-1"])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "proof_seconds" in err
    rc = main(base + ["--proof-seconds", "exhaustive", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0 and out["request"]["proof_seconds"] is None
    rc = main(base + ["--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0 and "proof_seconds" not in out["request"]


def test_proof_clock_and_the_option():
    with pytest.raises(ProofStopped):
        ProofClock.start(0).check()
    UNLIMITED.check()
    ProofClock.start(None).check()
    ProofClock.start(60).check()
    assert ProofClock.start(2).describe() == "2 s" and UNLIMITED.describe() == "no limit"
    assert proof_seconds_value(None) is None and proof_seconds_value("exhaustive") is None
    assert proof_seconds_value("inf") is None and proof_seconds_value("2") == 2.0
    assert proof_seconds_value(0) == 0.0


def test_the_box_cover_checks_the_clock():
    """A family of cubics with a member: the cover cannot close, and a spent clock stops it
    before its first cell."""
    ell = [[1, 2, 0, 0]]  # ℓ(p) = p_0 + 2 p_1
    assert not box_cover(3, ell, "continuous").proven
    with pytest.raises(ProofStopped):
        box_cover(3, ell, "continuous", clock=ProofClock.start(0))

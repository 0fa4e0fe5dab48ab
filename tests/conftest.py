import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))


@pytest.fixture(scope="session")
def models_dir():
    return ROOT / "models"


#: symbolic designs the oracle has already passed in this process (the same design, made by
#: many tests, is checked once)
_ORACLE_PASSED: set = set()


@pytest.fixture(autouse=True)
def _symbolic_designs_exclude_their_denominators(monkeypatch):
    """Every symbolic design any test makes is checked by the independent oracle of
    ``assumption_oracle`` when the test ends (an error at teardown names the design and the
    denominator its assumptions miss): the assumptions of a design exclude every zero of
    every denominator it reports."""
    from observer_cad.synthesis import Design

    made = []
    original = Design.__post_init__

    def recording(self):
        original(self)
        if self.structure is not None and self.structure.model.parameters:
            made.append(self)

    monkeypatch.setattr(Design, "__post_init__", recording)
    yield
    monkeypatch.setattr(Design, "__post_init__", original)
    if made:
        from assumption_oracle import check_design
        for d in made:
            key = (d.model_name, str(d.task), tuple(str(M) for _, M in d.matrices.items()),
                   tuple(str(e) for e in d.equations), tuple(str(e) for _, e in d.outputs),
                   d.assumptions)
            if key in _ORACLE_PASSED:
                continue
            problems = check_design(d, points=1)
            assert not problems, f"symbolic design {d!r}: {problems[0]}"
            _ORACLE_PASSED.add(key)

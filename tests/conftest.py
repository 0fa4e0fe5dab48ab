import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))


@pytest.fixture(scope="session")
def models_dir():
    return ROOT / "models"


@pytest.fixture(autouse=True)
def _symbolic_designs_exclude_their_denominators(monkeypatch):
    """Issue 11 item 6: every symbolic design any test makes is checked by the
    independent oracle of ``assumption_oracle`` when the test ends (an error at
    teardown names the design and the denominator its assumptions miss)."""
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
        seen = set()
        for d in made:
            key = (d.model_name, str(d.task), tuple(str(M) for _, M in d.matrices.items()),
                   d.assumptions)
            if key in seen:
                continue
            seen.add(key)
            problems = check_design(d, points=1)
            assert not problems, f"symbolic design {d!r}: {problems[0]}"

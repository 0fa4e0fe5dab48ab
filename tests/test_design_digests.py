"""Moving code does not change what it designs: every request of the corpus
(``tests/design_corpus.py``: the shipped models × kinds × forms × symbolic, random plants
on the exact and float paths, residual banks) gives the design — the SHA-256 of its JSON —
or the refusal recorded in ``tests/data/design_digests.json``. Every tenth request runs in
the default run, the rest in the slow step. After a change that is meant to change
designs, ``python3 tests/design_corpus.py --write`` records the new digests (and the
commit says why they changed)."""
from __future__ import annotations

import json

import pytest

from design_corpus import DIGESTS, outcome, requests

RECORDED = json.loads(DIGESTS.read_text(encoding="utf-8"))
CORPUS = requests()


def test_the_corpus_is_the_recorded_one():
    assert sorted(r[0] for r in CORPUS) == sorted(RECORDED)


@pytest.mark.parametrize("request_", [
    pytest.param(r, id=r[0], marks=() if i % 10 == 0 else pytest.mark.slow)
    for i, r in enumerate(CORPUS)])
def test_design_unchanged(request_):
    assert outcome(request_) == RECORDED[request_[0]]

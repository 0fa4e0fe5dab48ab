"""Banks prefer strongly isolating rows: without a requested structure the bank takes rows
whose residuals see every fault they respond to with a nonzero steady-state gain (strong
fault detectability at frequency 0, Varga 2017, Ch. 3), and falls back to rows that see
some faults only as transients only when no achievable row is strongly realised — and
then says which faults are isolated only transiently.

The published examples are those of FaultDetectionTools.jl (docs/REFERENCES.md):
Yuan et al. 1997 and the Boeing 747 (test/test_fdigenspec.jl, whose weak structure
matrices hold rows that are not strong ones), and Varga 2017, Example 5.10, the triplex
sensor (Examples/Ex5_10.jl)."""
from __future__ import annotations

import json

import pytest
import sympy as sp

from observer_cad import PlantModel
from observer_cad.analysis import ResidualBank, analyze, design_bank, load_design
from observer_cad.errors import UsageError
from observer_cad.reporting import format_bank

from .varga_examples import boeing_747, triplex_sensor, yuan_1997

# test/test_fdigenspec.jl: the rows of the weak structure matrix that are not rows of
# the strong one (FDfreq = [0, 1]), and the strong rows
YUAN_WEAK_ONLY = {"11100110", "11101010", "11110101", "11110111", "11111001", "11111011"}
YUAN_STRONG = {"00010011", "01101110", "01111101", "01111111", "10101110", "10111101",
               "10111111", "11001100", "11011111", "11101110", "11111101", "11111111"}
BOEING_STRONG = {"11111", "00111", "11001", "11110"}
BOEING_WEAK_ONLY = {"00001", "00110", "11000"}


def _transient(d) -> set:
    """The faults a designed residual sees only as a transient (its fault signature)."""
    return {s.name for s in (d.signature or d.with_signature().signature) if s.transient_only}


def _text(row) -> str:
    return "".join(map(str, row))


def _isolated_by(patterns, faults) -> set:
    """The pairs some row among ``patterns`` tells apart (both seen by some row)."""
    rows = [tuple(int(c) for c in p) for p in patterns]
    cols = {f: tuple(r[j] for r in rows) for j, f in enumerate(faults)}
    return {(a, b) for i, a in enumerate(faults) for b in faults[i + 1:]
            if any(cols[a]) and any(cols[b]) and cols[a] != cols[b]}


def _strongly_isolated(bank) -> set:
    return {p for p, ok in bank.strongly_isolable if ok}


def _boeing_model() -> PlantModel:
    """The Boeing 747 of varga_examples as a plant model (its fifth fault also in y2)."""
    st = boeing_747()
    return PlantModel.from_statespace((st.F, sp.Matrix(st.D), st.H, sp.Matrix(st.Dy)),
                                      faults=list(range(5)), time="continuous",
                                      name="boeing_747")


def _assert_strong(bank: ResidualBank, published_strong: set):
    """Every row strongly realised and a row of the published strong structure matrix;
    the strong structure matrix equals the weak one; nothing only transient."""
    assert not any(_transient(d) & set(bank.faults) for d in bank.designs)
    assert bank.strong_structure == bank.structure_matrix
    assert {_text(r) for r in bank.structure_matrix} <= published_strong
    assert bank.transient_only == () and bank.transient_note == ""
    assert [p for p, ok in bank.strongly_isolable] == [p for p, ok in bank.isolable]
    assert [ok for p, ok in bank.strongly_isolable] == [ok for p, ok in bank.isolable]


@pytest.mark.slow
def test_yuan_bank_takes_strong_rows_only():
    """Yuan 1997: the generalised scheme's rows 11110111 (f5 decoupled) and 11111011
    (f6 decoupled) are achievable but see faults only as transients (published: weak,
    not strong rows); the bank leaves them out and says so, every row it keeps is a
    published strong row and strongly realised, and it isolates strongly every pair the
    published strong rows can."""
    model = yuan_1997().model
    a = analyze(model, frequencies=[0])
    assert a.strong_structure, "the analysis finds strong rows: a strong bank exists"
    bank = design_bank(model)
    _assert_strong(bank, YUAN_STRONG)
    rows = {_text(r) for r in bank.structure_matrix}
    assert not rows & YUAN_WEAK_ONLY
    assert "11110111 (f6 transient only)" in bank.choice
    assert "11111011 (f5, f7 transient only)" in bank.choice
    # the analysis agrees: each kept row is one of its strong rows
    strong = {_text(tuple(s.row(a.faults)[f] for f in a.faults)) for s in a.strong_structure}
    assert rows <= strong
    assert all(bank.detectable.values())
    # with the analysis's strong rows among the candidates the bank isolates strongly every
    # pair the published strong rows isolate: all but f4/f8 and f5/f6 (no strong row
    # tells them apart)
    assert _strongly_isolated(bank) == _isolated_by(YUAN_STRONG, bank.faults)
    assert {p for p, ok in bank.strongly_isolable if not ok} == {("f4", "f8"), ("f5", "f6")}


@pytest.mark.slow  # with the Yuan bank, over the default run's budget
def test_boeing_bank_rows_are_strong():
    """Boeing 747: the row 00001 (f5 alone) is achievable but sees f5 only as a
    transient (published: a weak, not a strong row): the bank's rows are strong ones."""
    model = _boeing_model()
    bank = design_bank(model)
    _assert_strong(bank, BOEING_STRONG)
    assert not {_text(r) for r in bank.structure_matrix} & BOEING_WEAK_ONLY
    # f1/f2 and f3/f4 have equal columns in every published strong row; the rest isolated
    assert _strongly_isolated(bank) == _isolated_by(BOEING_STRONG, bank.faults)
    assert {p for p, ok in bank.strongly_isolable if not ok} == {("f1", "f2"), ("f3", "f4")}


def test_triplex_sensor_generalised_scheme_of_order_zero():
    """Varga 2017, Example 5.10: the triplex sensor. The published structure matrix
    [0 1 1; 1 0 1; 1 1 0] is the bank's (the generalised scheme), every residual of
    order 0 (a difference of two sensors), weakly and strongly alike; the analysis's
    achievable rows are those and 111, each of least order 0."""
    model = triplex_sensor()
    bank = design_bank(model)
    assert bank.scheme == "generalised observer scheme"
    assert [_text(r) for r in bank.structure_matrix] == ["011", "101", "110"]
    assert [d.k for d in bank.designs] == [0, 0, 0]
    _assert_strong(bank, {"011", "101", "110"})
    assert all(ok for _, ok in bank.isolable)
    a = analyze(model, frequencies=[0])
    weak = {_text(tuple(s.row(a.faults)[f] for f in a.faults)) for s in a.structure}
    strong = {_text(tuple(s.row(a.faults)[f] for f in a.faults)) for s in a.strong_structure}
    assert weak == strong == {"011", "101", "110", "111"}
    assert a.min_order == {"f1": 0, "f2": 0, "f3": 0}
    assert all(p.isolable for p in a.pairs)


def _transient_model(time: str) -> PlantModel:
    """One fault seen only as a transient: y = x1 − x2 with x1' = −2 x1 + 2 f,
    x2' = −x2 + f, i.e. y = s / ((s + 1)(s + 2)) f; in discrete time
    x1+ = x1/2 + f, x2+ = 3/4 x2 + f/2, y = x1 − x2 (gain at z = 1: 2 − 2 = 0). A second
    fault g enters x1 alone and is seen with a nonzero gain; x3, measured, makes the
    residual of order 2 one of order < n."""
    x1, x2, x3, f, g = sp.symbols("x1 x2 x3 f g")
    if time == "continuous":
        dyn = [-2 * x1 + 2 * f + g, -x2 + f, -x3]
    else:
        dyn = [x1 / 2 + f + g, sp.Rational(3, 4) * x2 + f / 2, x3 / 2]
    return PlantModel(name=f"transient_{time}", time=time, states=[x1, x2, x3], faults=[f, g],
                      outputs=[x1 - x2, x3], dynamics=dyn)


@pytest.mark.parametrize("time", ["continuous", "discrete"])
def test_weak_fallback_says_which_faults_are_transient(time):
    """No achievable row sees f with a nonzero steady-state gain (s = 0, z = 1): the bank
    falls back to the weak rows, its choice says no bank isolates strongly, and its
    strong structure matrix, JSON and text name f as isolated only transiently."""
    model = _transient_model(time)
    bank = design_bank(model)
    assert any(bank.detectable.values())
    assert bank.strong_structure != bank.structure_matrix
    for d, row, srow in zip(bank.designs, bank.structure_matrix, bank.strong_structure):
        assert srow == tuple(0 if f in _transient(d) else c for f, c in zip(bank.faults, row))
        assert all(s <= w for s, w in zip(srow, row))
    assert not any(r[0] for r in bank.strong_structure) and any(r[0] for r in bank.structure_matrix)
    assert "no bank isolates strongly" in bank.choice
    assert bank.transient_only and "f" in bank.transient_only
    assert bank.transient_note.startswith("Isolated only transiently")
    js = bank.to_json()
    assert js["strong_structure"] == [list(r) for r in bank.strong_structure]
    assert js["transient_only"] == list(bank.transient_only)
    text = format_bank(bank)
    assert bank.transient_note in text and "Strong structure matrix" in text
    assert bank.transient_note in bank._repr_markdown_()


def test_strong_structure_round_trips_and_is_checked(tmp_path):
    """The JSON's strong structure reads back; a file without it (written before it was
    recorded) still reads, as a design file too; a tampered one is refused in one line."""
    model = _transient_model("continuous")
    bank = design_bank(model)
    data = json.loads(json.dumps(bank.to_json()))
    for name, content in (("new", data), ("old", {k: v for k, v in data.items()
                                                   if k not in ("strong_structure",
                                                                "transient_only")})):
        path = tmp_path / f"{name}.json"
        path.write_text(json.dumps(content), encoding="utf-8")
        loaded = load_design(path, model)
        assert loaded.strong_structure == bank.strong_structure
        assert loaded.choice == bank.choice
    back = ResidualBank.from_json(data, model)
    assert back.strong_structure == bank.strong_structure
    old = dict(data)
    del old["strong_structure"]
    assert ResidualBank.from_json(old, model).structure_matrix == bank.structure_matrix
    bad = dict(data, strong_structure=[list(r) for r in bank.structure_matrix])
    with pytest.raises(UsageError, match="strong_structure"):
        ResidualBank.from_json(bad, model)


@pytest.mark.slow  # the generalised scheme's row 101 is a fourth-order search (~20 s)
def test_dedicated_scheme_when_the_generalised_one_is_only_weak():
    """A hand-made plant: y1 = x1 − x5 sees f2 through s/((s + 1)(s + 2)) (a transient)
    and f3 with a nonzero gain, y2 sees f2 through a third-order chain, y3 sees f1.
    The least-order residual decoupled from f1 uses y1 alone (order 2) and sees f2 only
    as a transient, so the generalised scheme is achievable only weakly; every dedicated
    row is strongly realised, and the bank takes the dedicated scheme."""
    x1, x2, x3, x4, x5, x6, f1, f2, f3 = sp.symbols("x1 x2 x3 x4 x5 x6 f1 f2 f3")
    model = PlantModel(
        name="weak_gos", time="continuous", states=[x1, x2, x3, x4, x5, x6],
        faults=[f1, f2, f3], outputs=[x1 - x5, x2, x4],
        dynamics=[-2 * x1 + 2 * f2 + f3, -x2 + x3, -3 * x3 + x6, -x4 + f1, -x5 + f2,
                  -4 * x6 + f2])
    bank = design_bank(model)
    assert bank.scheme == "dedicated observer scheme"
    assert [_text(r) for r in bank.structure_matrix] == ["100", "010", "001"]
    _assert_strong(bank, {"100", "010", "001"})
    assert "generalised observer scheme achievable only with faults seen as transients:" \
           " row(s) 011 (f2 transient only)" in bank.choice

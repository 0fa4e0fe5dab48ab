"""Frozen design files: every kind (and a residual bank) written by write_design_json reads
back with the same matrices and the same simulated output; a changed model is refused in
one line; every value a file reports is recomputed at load, and a tampered one is refused
naming its field."""
import json
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from observer_cad.analysis import ResidualBank, design_bank, load_design
from observer_cad.errors import UsageError
from observer_cad.model import load_model, structure_digest, extract_structure
from observer_cad.observers import build_observer
from observer_cad.reporting import read_design_json, write_design_json
from observer_cad.simulation import load_scenario, simulate
from observer_cad.synthesis import design

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"

SCENARIOS = {
    "drive": {"steps": 40, "seed": 2, "signals": {"u": "0.2*sin(t/10)",
              "rho": {"uniform": [-0.05, 0.05]}, "d": "Piecewise((0, t < 20), (0.5, True))"}},
    "tank": {"t_end": 2, "dt": 0.01, "seed": 4, "initial": {"x1": 2, "x2": 1.2, "x3": 0.6},
             "signals": {"u1": "0.5", "u2": "0.2", "w1": {"uniform": [-0.01, 0.01]},
                         "w2": {"uniform": [-0.01, 0.01]}}},
    "sliding": {"t_end": 1, "dt": 0.001, "seed": 1, "initial": {"x1": 0, "x2": 1, "x3": 0},
                "signals": {"d": "Piecewise((0, t < 0.5), (0.8*sin(t - 0.5), True))",
                            "rho": "0.3*sin(3*t)"}},
    "faults": {"t_end": 2, "dt": 0.01, "seed": 3, "initial": {"x1": 1, "x2": 1, "x3": 1},
               "signals": {"u1": "1", "u2": "0.5", "rho": "0.1*sin(t)",
                           "f3": "Piecewise((0, t < 1), (0.2, True))"}},
    "isolation": None,  # the model's own scenario
}

KINDS = {
    "unknown-input": ("electric_drive.py", dict(observer="unknown-input", faults=["d"]), "drive"),
    "unknown-input-jordan": ("electric_drive.py", dict(observer="unknown-input", faults=["d"],
                                                      form="jordan", lambdas=["1/2"]), "drive"),
    "diagnostic": ("electric_drive.py", dict(observer="diagnostic"), "drive"),
    "diagnostic-canonical": ("electric_drive.py", dict(observer="diagnostic", form="canonical",
                                                      eigenvalues=["1/2"]), "drive"),
    "virtual-sensor": ("three_tank.py", dict(observer="virtual-sensor", estimate="x1"), "tank"),
    "interval": ("three_tank.py", dict(observer="interval", estimate="x1"), "tank"),
    "sliding-mode": ("sliding_example.py", dict(observer="sliding-mode"), "sliding"),
    "robust": ("three_tank_faults.py", dict(observer="diagnostic", faults=["f3"],
                                            form="canonical", robust=True), "faults"),
}


def _scenario(tmp_path, key):
    path = tmp_path / f"{key}.json"
    path.write_text(json.dumps(SCENARIOS[key]))
    return load_scenario(path)


def _same_matrices(a, b):
    """Exact designs: equal; float designs: equal to the 15 digits their JSON prints."""
    ma, mb = a.matrices.as_dict(), b.matrices.as_dict()
    assert sorted(ma) == sorted(mb)
    for name in ma:
        A, B = sp.Matrix(ma[name]), sp.Matrix(mb[name])
        if a.certificate.exact:
            assert A == B, name
        else:
            np.testing.assert_allclose(np.array(A, dtype=float), np.array(B, dtype=float),
                                       rtol=1e-13, atol=1e-15, err_msg=name)


@pytest.mark.slow
@pytest.mark.parametrize("kind", sorted(KINDS))
def test_every_kind_round_trips_with_the_same_simulation(tmp_path, kind):
    file, options, scen = KINDS[kind]
    model = load_model(MODELS / file)
    d = design(model, **options)
    path = write_design_json(d, tmp_path / "d.json")
    back = read_design_json(path, model)
    _same_matrices(d, back)
    assert back.conditions == d.conditions and back.assumptions == d.assumptions
    assert back.signature_map == d.signature_map and back.approximate == d.approximate
    if d.approximate:  # (an approximate design builds no observer: nothing to simulate)
        assert back.residual_norm == pytest.approx(d.residual_norm, rel=1e-12)
        return
    scenario = _scenario(tmp_path, scen)
    r1 = simulate(model, build_observer(model, d), scenario)
    r2 = simulate(model, build_observer(model, back), scenario)
    assert r1.order == r2.order
    for c in r1.order:
        if d.certificate.exact:
            np.testing.assert_array_equal(np.asarray(r1[c]), np.asarray(r2[c]), err_msg=c)
        else:
            np.testing.assert_allclose(np.asarray(r1[c]), np.asarray(r2[c]), rtol=1e-9,
                                       atol=1e-12, err_msg=c)
    # and the file read twice gives the same observer: what the CLI's --design runs
    r3 = simulate(model, build_observer(model, read_design_json(path, model)), scenario)
    for c in r1.order:
        np.testing.assert_array_equal(np.asarray(r2[c]), np.asarray(r3[c]), err_msg=c)


def test_a_symbolic_design_round_trips_with_its_assumptions(tmp_path):
    model = load_model(MODELS / "electric_drive.py")
    d = design(model, observer="unknown-input", faults=["rho"], symbolic=True)
    back = read_design_json(write_design_json(d, tmp_path / "s.json"), model)
    _same_matrices(d, back)
    assert {str(a) for a in back.assumptions} == {str(a) for a in d.assumptions} \
        >= {"Ne(k1, 0)", "Ne(k4, 0)"}


def test_a_residual_bank_round_trips(tmp_path):
    model = load_model(MODELS / "three_tank_isolation.py")
    bank = design_bank(model)
    path = write_design_json(bank, tmp_path / "bank.json")
    back = read_design_json(path, model)
    assert isinstance(back, ResidualBank)
    assert back.structure_matrix == bank.structure_matrix and back.scheme == bank.scheme
    for a, b in zip(bank.designs, back.designs):
        _same_matrices(a, b)
    assert read_design_json(path)["kind"] == "residual-bank"  # the raw JSON reads too
    scenario = load_scenario(MODELS / "scenarios" / "three_tank_isolation.json")
    r1 = simulate(model, build_observer(model, bank), scenario)
    r2 = simulate(model, build_observer(model, back), scenario)
    for c in r1.order:
        np.testing.assert_array_equal(np.asarray(r1[c]), np.asarray(r2[c]), err_msg=c)


def test_a_drem_design_round_trips(tmp_path):
    from observer_cad.observers import DremDesign, drem_design, load_drem
    model, spec = load_drem(MODELS / "drem_example.py")
    d = drem_design(model, spec)
    data = json.loads(json.dumps(d.to_json(equations=False)))
    assert "model_hash" in data
    back = DremDesign.from_json(data, model, spec)
    assert back.to_json(equations=False) == d.to_json(equations=False)
    data["conditions"][0]["holds"] = not data["conditions"][0]["holds"]
    with pytest.raises(UsageError, match="'conditions' differs"):
        DremDesign.from_json(data, model, spec)


def test_the_structure_hash_is_stable_and_sees_a_change(tmp_path):
    model = load_model(MODELS / "electric_drive.py")
    a = structure_digest(extract_structure(model))
    assert a == structure_digest(extract_structure(load_model(MODELS / "electric_drive.py")))
    text = (MODELS / "electric_drive.py").read_text()
    changed = tmp_path / "electric_drive.py"
    changed.write_text(text)
    assert structure_digest(extract_structure(load_model(changed))).sha256 == a.sha256


@pytest.mark.slow
def test_the_structure_hash_does_not_depend_on_the_process(tmp_path):
    """The same digest in processes with different string-hash seeds (sympy's printing
    order is canonical, not the order of a set)."""
    import os
    import subprocess
    import sys
    code = ("from observer_cad.model import load_model, extract_structure, structure_digest;"
            f"print(structure_digest(extract_structure(load_model({str(MODELS / 'three_tank.py')!r}))).sha256)")
    out = set()
    for seed in ("1", "2", "3"):
        env = dict(os.environ, PYTHONHASHSEED=seed)
        out.add(subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                               text=True, check=True).stdout.strip())
    model = load_model(MODELS / "three_tank.py")
    assert out == {structure_digest(extract_structure(model)).sha256}


def _changed_model(tmp_path):
    """electric_drive with one parameter default changed (the structure is the same shape)."""
    text = (MODELS / "electric_drive.py").read_text()
    old = "k1: sp.Rational(1, 500)"
    assert old in text, "the electric drive declares k1's default"
    new = text.replace(old, "k1: sp.Rational(1, 400)")
    path = tmp_path / "electric_drive_changed.py"
    path.write_text(new)
    return load_model(path)


def test_a_changed_model_is_refused_in_one_line(tmp_path):
    model = load_model(MODELS / "electric_drive.py")
    path = write_design_json(design(model, observer="unknown-input", faults=["d"]),
                             tmp_path / "d.json")
    with pytest.raises(UsageError) as exc:
        load_design(path, _changed_model(tmp_path))
    msg = str(exc.value)
    assert "\n" not in msg and "different model" in msg and "design again" in msg
    assert str(path) in msg and "F" in msg.split("differs in:")[1]


@pytest.fixture(scope="module")
def files():
    """JSON of a numeric unknown-input design, a symbolic one and a diagnostic one."""
    ed = load_model(MODELS / "electric_drive.py")
    edu = load_model(MODELS / "electric_drive_uncertain.py")
    sm = load_model(MODELS / "sliding_example.py")
    return {
        "ui": (ed, design(ed, observer="unknown-input", faults=["d"]).to_json()),
        "sym": (ed, design(ed, observer="unknown-input", faults=["rho"], symbolic=True).to_json()),
        "diag": (edu, design(edu, observer="diagnostic").to_json()),
        "sm": (sm, design(sm, observer="sliding-mode").to_json()),
    }


def _condition(data):
    data["conditions"].append({"name": "everything fine: trust me", "holds": True,
                               "detail": "", "reference": "", "required": True})


def _flip(data):
    data["conditions"][0]["holds"] = not data["conditions"][0]["holds"]


TAMPERING = [
    # (file, change, what the refusal names)
    ("ui", _condition, "conditions include 'everything fine: trust me'"),
    ("ui", _flip, "condition 'decoupling necessary condition"),
    ("ui", lambda d: d.__setitem__("closed_loop_eigenvalues", ["7"]), "closed_loop_eigenvalues"),
    ("sym", lambda d: d.__setitem__("assumptions", ["Ne(k4, 0)"]), "assumptions lack Ne(k1, 0)"),
    ("sym", lambda d: d["assumptions"].append("Ne(k2, 0)"), "assumptions include Ne(k2, 0)"),
    ("diag", lambda d: d["matrices"].__setitem__("Phi", [["q", "0", "5*q"]]),
     "matrices.Phi: 'q' is not a symbol"),
    ("diag", lambda d: (d["matrices"].__setitem__("Phi", [["q", "0", "5*q"]]),
                        d.__setitem__("parameters", {"q": "1"})),
     "matrices.Phi: 'q' is not a parameter of the model"),
    ("diag", lambda d: d.pop("model_hash"), "no 'model_hash'"),
    ("diag", lambda d: d.pop("request"), "no 'request'"),
    ("diag", lambda d: d["model_hash"].__setitem__("sha256", "0" * 64), "different model"),
    ("sm", lambda d: d["parameters"].__setitem__("k_sm", "3"), "parameters hold 3"),
    ("sm", lambda d: d["parameters"].__setitem__("gain", "3"), "parameters"),
    ("ui", lambda d: d.__setitem__("form", "jordan"), "form"),
    ("ui", lambda d: d["states"].__setitem__(0, "zz"), "'xs1' is not a symbol"),
    ("sym", lambda d: d["conditions"].pop(), "conditions lack"),
]


@pytest.mark.parametrize("key, change, names", TAMPERING,
                         ids=[f"{k}-{n[:30]}" for k, _, n in TAMPERING])
def test_a_tampered_file_is_refused_naming_the_field(tmp_path, files, key, change, names):
    model, data = files[key]
    data = json.loads(json.dumps(data))
    change(data)
    path = tmp_path / "t.json"
    path.write_text(json.dumps(data))
    with pytest.raises(UsageError) as exc:
        load_design(path, model)
    msg = str(exc.value)
    assert "\n" not in msg and names in msg, msg


def test_a_tampered_bank_is_refused(tmp_path):
    model = load_model(MODELS / "three_tank_isolation.py")
    data = json.loads(json.dumps(design_bank(model).to_json()))
    data["designs"][1]["conditions"][0]["holds"] = not data["designs"][1]["conditions"][0]["holds"]
    path = tmp_path / "b.json"
    path.write_text(json.dumps(data))
    with pytest.raises(UsageError, match="residual r2: the recorded condition"):
        load_design(path, model)
    data = json.loads(json.dumps(design_bank(model).to_json()))
    data["scheme"] = "dedicated observer scheme"
    path.write_text(json.dumps(data))
    with pytest.raises(UsageError, match="recorded scheme differs"):
        load_design(path, model)


MORE_FORMS = [
    ("three_tank_linear.py", dict(observer="interval", estimate="x1", form="canonical",
                                  eigenvalues=["-1", "-2"])),
    ("three_tank_linear.py", dict(observer="virtual-sensor", estimate="x1", form="canonical",
                                  variant="004")),
    ("nonmonotone_chain.py", dict(observer="interval", estimate="x1")),
    ("electric_drive.py", dict(observer="diagnostic", symbolic=True)),
    ("three_tank_faults.py", dict(observer="diagnostic", faults=["f1"], method="float")),
]


@pytest.mark.parametrize("file, options", MORE_FORMS,
                         ids=[f"{f}-{o['observer']}-{o.get('form', '')}{o.get('method', '')}"
                              for f, o in MORE_FORMS])
def test_more_forms_round_trip(tmp_path, file, options):
    """Canonical interval designs (T and the diagonal form), seed 004's virtual sensor, a
    γ-shift interval observer, a symbolic diagnostic design and a float one."""
    model = load_model(MODELS / file)
    d = design(model, **options)
    back = load_design(write_design_json(d, tmp_path / "d.json"), model)
    _same_matrices(d, back)
    assert [c.name for c in back.conditions] == [c.name for c in d.conditions]
    assert back.assumptions == d.assumptions


def test_a_bank_column_the_model_lacks_is_refused_naming_the_file(tmp_path):
    from observer_cad.errors import ModelError
    m = load_model(Path(__file__).resolve().parents[2] / "models" / "three_tank_isolation.py")
    data = design_bank(m).to_json()
    data["faults"][0] = "zz"
    path = tmp_path / "bank.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ModelError) as e:
        load_design(path, m)
    msg = str(e.value)
    assert "\n" not in msg and str(path) in msg and "'zz'" in msg

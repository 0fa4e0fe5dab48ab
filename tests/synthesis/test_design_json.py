"""A design survives its JSON: Design.from_json(design.to_json()) rebuilds the same observer
for every kind, the recorded request reproduces the same design, and a tampered or foreign
JSON is refused (it is data: parsed by a whitelist and re-certified, never trusted)."""
import json
import re

import pytest
import sympy as sp

from observer_cad import Design, UsageError, build_observer, design, load_model
from observer_cad.errors import CertificateError, ModelError

CASES = {
    "virtual-sensor-jordan": ("three_tank.py", dict(observer="virtual-sensor", estimate="x1")),
    "virtual-sensor-canonical": ("three_tank_linear.py",
                                 dict(observer="virtual-sensor", estimate="x1", form="canonical")),
    "virtual-sensor-004": ("three_tank_linear.py",
                           dict(observer="virtual-sensor", estimate="x1", form="canonical",
                                variant="004", eigenvalues=[-1, -2])),
    "interval-jordan-nonlinear": ("three_tank.py", dict(observer="interval", estimate="x1")),
    "interval-jordan-linear": ("three_tank_linear.py", dict(observer="interval", estimate="x1")),
    "interval-canonical": ("three_tank_linear.py",
                           dict(observer="interval", estimate="x1", form="canonical",
                                eigenvalues=[-1, -2])),
    "unknown-input-canonical": ("electric_drive.py", dict(observer="unknown-input", faults=["d"])),
    "unknown-input-symbolic": ("electric_drive.py",
                               dict(observer="unknown-input", faults=["rho"], symbolic=True)),
    "unknown-input-jordan": ("electric_drive.py",
                             dict(observer="unknown-input", faults=["d"], form="jordan",
                                  lambdas=["1/2"])),
    "diagnostic-jordan": ("electric_drive.py", dict(observer="diagnostic")),
    "diagnostic-canonical": ("electric_drive.py",
                             dict(observer="diagnostic", form="canonical", eigenvalues=["1/2"])),
    "sliding-mode": ("sliding_example.py", dict(observer="sliding-mode", faults=["d"])),
}


def _same(a, b) -> bool:
    return sp.simplify(sp.sympify(a) - sp.sympify(b)) == 0


def _assert_same_observer(o1, o2):
    assert o1.kind == o2.kind and o1.time == o2.time
    assert [str(s) for s in o1.states] == [str(s) for s in o2.states]
    assert [str(s) for s in o1.signals] == [str(s) for s in o2.signals]
    assert len(o1.update) == len(o2.update)
    for e1, e2 in zip(o1.update, o2.update):
        assert _same(e1, e2), (e1, e2)
    assert [n for n, _ in o1.outputs] == [n for n, _ in o2.outputs]
    for (_, e1), (_, e2) in zip(o1.outputs, o2.outputs):
        assert _same(e1, e2), (e1, e2)
    assert {str(k): float(v) for k, v in o1.parameters.items()} == \
        {str(k): float(v) for k, v in o2.parameters.items()}
    assert dict(o1.delays) == dict(o2.delays)


def _same_matrices(d1, d2):
    m1, m2 = d1.matrices.as_dict(), d2.matrices.as_dict()
    assert set(m1) == set(m2)
    for name in m1:
        diff = (sp.Matrix(m1[name]) - sp.Matrix(m2[name])).applyfunc(sp.simplify)
        assert diff == sp.zeros(*diff.shape), name


@pytest.fixture(scope="module")
def designed(models_dir):
    out = {}
    for key, (fname, opts) in CASES.items():
        model = load_model(models_dir / fname)
        out[key] = (model, design(model, **opts))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("key", sorted(CASES))
def test_from_json_rebuilds_the_same_observer(designed, key):
    model, d = designed[key]
    data = json.loads(json.dumps(d.to_json()))  # through text, as a file would
    back = Design.from_json(data, model)
    assert back.observer == d.observer and back.k == d.k and back.form == d.form
    assert back.task == d.task
    assert back.certificate.passed
    _same_matrices(d, back)
    if d.symbolic:  # a symbolic design has no numeric observer; the design itself came back
        assert back.assumptions == d.assumptions
        return
    _assert_same_observer(build_observer(model, d), build_observer(model, back))


@pytest.mark.parametrize("key", sorted(CASES))
def test_recorded_request_reproduces_the_design(designed, key):
    model, d = designed[key]
    again = design(model, **d.request.options())
    _same_matrices(d, again)
    assert again.lambdas == d.lambdas and again.request == d.request


def test_request_records_the_choices_made(designed):
    _, d = designed["diagnostic-jordan"]
    assert d.request.lambdas == tuple(d.lambdas) and d.request.method == "exact"
    _, c = designed["diagnostic-canonical"]
    assert c.request.eigenvalues == tuple(c.closed_loop_eigenvalues)


def test_tampered_matrix_fails_the_certificate(designed):
    model, d = designed["virtual-sensor-jordan"]
    data = json.loads(json.dumps(d.to_json()))
    data["matrices"]["J_star"][0][0] = "123"
    with pytest.raises(CertificateError):
        Design.from_json(data, model)


@pytest.mark.parametrize("key", ["diagnostic-canonical", "virtual-sensor-004"])
def test_tampered_gain_fails_the_pole_certificate(designed, key):
    """K is re-checked on reading: det(sI − F* + K H*) must equal Π(s − μ) for the recorded
    closed-loop eigenvalues."""
    model, d = designed[key]
    data = json.loads(json.dumps(d.to_json()))
    data["matrices"]["K"][0][0] = "123"
    with pytest.raises(CertificateError, match="pole placement failed its exact check"):
        Design.from_json(data, model)


@pytest.mark.parametrize("payload", [
    "__import__('os').system('touch PWNED')",
    "x1.__class__",
    "(lambda: 1)()",
    "open('f')",
    "'text'",
    "[1, 2]",
    "2**10**10",
])
def test_expressions_are_data(designed, payload, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    model, d = designed["diagnostic-jordan"]
    data = json.loads(json.dumps(d.to_json()))
    data["equations"][0] = payload
    with pytest.raises(UsageError):
        Design.from_json(data, model)
    assert not (tmp_path / "PWNED").exists()


def test_design_for_another_model_is_refused(designed, models_dir):
    _, d = designed["unknown-input-canonical"]
    other = load_model(models_dir / "three_tank_linear.py")
    with pytest.raises((UsageError, ModelError, CertificateError)):
        Design.from_json(json.loads(json.dumps(d.to_json())), other)


def test_not_a_design():
    with pytest.raises(UsageError):
        Design.from_json({"hello": 1}, None)


@pytest.mark.slow  # the DREM design itself takes ~10 s
def test_drem_design_rebuilds_from_its_json(models_dir):
    from observer_cad.observers import DremDesign, build_observer, drem_design, load_drem
    model, spec = load_drem(models_dir / "drem_example.py")
    d = drem_design(model, spec, gamma=2)
    data = json.loads(json.dumps(d.to_json(equations=False)))
    back = DremDesign.from_json(data, model, spec)
    o1, o2 = build_observer(model, d), build_observer(model, back)
    assert [str(e) for e in o1.update] == [str(e) for e in o2.update]
    assert [(n, str(e)) for n, e in o1.outputs] == [(n, str(e)) for n, e in o2.outputs]
    data["gamma"] = "__import__('os')"
    with pytest.raises(UsageError):
        DremDesign.from_json(data, model, spec)


@pytest.mark.parametrize("filters", [[{"poles": "-1"}], [{"poles": []}], [{"K": ["1"]}], ["-1"]])
def test_drem_json_with_malformed_poles_is_one_line(models_dir, filters):
    """'poles' given as text was read character by character ("cannot read '-'")."""
    from observer_cad.observers import DremDesign, load_drem
    model, spec = load_drem(models_dir / "drem_example.py")
    with pytest.raises(UsageError, match="filter 1 needs 'poles' as a non-empty list"):
        DremDesign.from_json({"observer": "drem", "filters": filters, "gamma": "1"}, model,
                             spec)


def test_read_design_json_with_the_model_gives_a_buildable_design(designed, tmp_path):
    from observer_cad.reporting import read_design_json, write_design_json
    model, d = designed["unknown-input-canonical"]
    path = write_design_json(d, tmp_path / "d.json")
    back = read_design_json(path, model)
    _assert_same_observer(build_observer(model, d), build_observer(model, back))
    with pytest.raises(UsageError, match="build_observer takes a Design, not a dict"):
        build_observer(model, read_design_json(path))


def test_measured_estimate_names_z(capsys, models_dir):
    from observer_cad.cli import main
    assert main(["design", str(models_dir / "electric_drive.py"), "--observer", "interval",
                 "--estimate", "x1"]) == 2
    assert "z = x1 is measured directly: z = y1" in capsys.readouterr().err


@pytest.mark.parametrize("key", ["diagnostic-canonical", "diagnostic-jordan",
                                 "virtual-sensor-004", "interval-jordan-nonlinear",
                                 "sliding-mode", "unknown-input-canonical"])
def test_equations_and_outputs_follow_from_the_matrices(designed, key):
    """The observer is built from the file's equations and outputs, so they are checked
    against the certified matrices (an audit loaded "u/5 + y1 + 100*y2" and
    r = 1000*xs1 + y1 into a diagnostic observer): one changed term is refused."""
    model, d = designed[key]
    data = json.loads(json.dumps(d.to_json()))
    bad = json.loads(json.dumps(data))
    bad["equations"][0] = f"{bad['equations'][0]} + 100*y1"
    with pytest.raises(UsageError, match="equations are not the ones its matrices give"):
        Design.from_json(bad, model)
    if data["outputs"]:
        name = next(iter(data["outputs"]))
        bad = json.loads(json.dumps(data))
        bad["outputs"][name] = f"1000*({bad['outputs'][name]}) + y1"
        with pytest.raises(UsageError, match=f"output {name} is not the one"):
            Design.from_json(bad, model)
    bad = json.loads(json.dumps(data))
    bad["equations"] = bad["equations"][:-1]
    with pytest.raises(UsageError, match="equations are not"):
        Design.from_json(bad, model)


@pytest.mark.parametrize("change", [
    lambda d: d.__setitem__("equations", 5),
    lambda d: d.__setitem__("certificate", "x"),
    lambda d: d["matrices"].__setitem__("Phi", [["1"]]),
    lambda d: d["matrices"].__setitem__("J_star", [["1", "2", "3", "4", "5"]]),
    lambda d: d.__setitem__("outputs", {"z": 5}),
    lambda d: d.__setitem__("lambdas", 7),
    lambda d: d.__setitem__("conditions", [5]),
    lambda d: d.__setitem__("states", ["xs1", 5]),
    lambda d: d.__setitem__("nonlinear", [{"index": "a"}]),
])
def test_wrong_types_and_shapes_are_one_line_errors(designed, change):
    """Values of the wrong type or shape anywhere in a design's JSON are a UsageError (an
    audit found raw TypeError, AttributeError and DMShapeError)."""
    model, d = designed["virtual-sensor-jordan"]
    data = json.loads(json.dumps(d.to_json()))
    change(data)
    with pytest.raises((UsageError, CertificateError)) as exc:
        Design.from_json(data, model)
    assert len(str(exc.value).splitlines()) == 1


@pytest.mark.parametrize("key", ["interval-jordan-nonlinear", "virtual-sensor-jordan"])
def test_argument_substitutions_are_the_models_terms(designed, key):
    """A nonlinear design's Ψ*_j come from the file: each must be the model's term with
    A*_1 x* + A*_2 y as its argument, one for every nonzero column of C*. A changed
    function (in the substitution and the equations alike) or one left out is refused:
    by the design's re-check against the model's own equations (which runs as the design
    is built), or by the file check that follows it."""
    model, d = designed[key]
    data = json.loads(json.dumps(d.to_json()))
    assert data["nonlinear"], "the case must have argument substitutions"
    Design.from_json(json.loads(json.dumps(data)), model)  # as written: read back
    bad = json.loads(json.dumps(data))
    f = bad["nonlinear"][0]["function"]
    bad["nonlinear"][0]["function"] = f"100*({f})"
    bad["equations"] = [e.replace(f, f"100*({f})") for e in bad["equations"]]
    against_model = "against the model's own equations: FAILED: model: Phi f - F"
    with pytest.raises((UsageError, CertificateError),
                       match=f"argument substitution|{re.escape(against_model)}"):
        Design.from_json(bad, model)
    bad = json.loads(json.dumps(data))
    bad["nonlinear"] = bad["nonlinear"][1:]
    with pytest.raises((UsageError, CertificateError),
                       match=f"argument substitutions are for the terms|{re.escape(against_model)}"):
        Design.from_json(bad, model)


def test_lambdas_are_the_diagonal_of_f_star(designed):
    model, d = designed["virtual-sensor-jordan"]
    data = json.loads(json.dumps(d.to_json()))
    data["lambdas"][0] = "-7"
    with pytest.raises(UsageError, match="lambdas are not the diagonal"):
        Design.from_json(data, model)


@pytest.mark.parametrize("value, problem", [("0.001", "failed"), ("-5", "positive"),
                                            ("0", "positive"), (None, "positive")])
def test_sliding_gains_from_a_file_are_checked_on_building(designed, value, problem):
    """A sliding-mode design's gains are parameters of its JSON: building the observer
    recomputes k1 > d*|D*| from the model (a failed condition when not), and a gain that
    is not a finite positive number is refused (an audit's k_sm = 0.001 and −5 built
    estimators off by 0.9 and 5.9 that reported the recorded gain bound as met)."""
    from observer_cad import build_observer

    model, d = designed["sliding-mode"]
    data = json.loads(json.dumps(d.to_json()))
    if value is None:
        del data["parameters"]["k_sm"]
    else:
        data["parameters"]["k_sm"] = value
    back = Design.from_json(data, model)
    if problem == "failed":
        obs = build_observer(model, back, allow_failed=True)
        failed = [c.name for c in obs.failed_conditions]
        assert any("d*|D*|" in n for n in failed), failed
        assert not build_observer(model, Design.from_json(
            json.loads(json.dumps(d.to_json())), model)).failed_conditions
    else:
        with pytest.raises(UsageError, match="must be a finite positive number"):
            build_observer(model, back)


def test_sliding_gain_bound_recomputed_for_the_gains_of_the_file(designed):
    """The design records δ and N* (what the bound rests on besides the model), so building
    recomputes the whole bound k1 > d*|D*| + w*|J* + λR*| + δN* for the gains it is given:
    k_sm = 1.05 against a bound of 1.07 built before with the recorded condition
    "2.14 > 1.07" still met. A file without them (written before) falls back to the
    necessary k1 > d*|D*|; malformed values, or on another kind of design, are refused."""
    from observer_cad import build_observer

    model, d = designed["sliding-mode"]
    assert d.sliding_inputs is not None and d.sliding_inputs.delta == 1.0
    genuine = json.loads(json.dumps(d.to_json()))
    assert genuine["sliding_inputs"] == {"delta": 1.0, "lipschitz": None}
    assert not build_observer(model, Design.from_json(genuine, model)).failed_conditions
    data = json.loads(json.dumps(genuine))
    data["parameters"]["k_sm"] = "1.05"
    obs = build_observer(model, Design.from_json(data, model), allow_failed=True)
    failed = [c for c in obs.failed_conditions]
    assert [c.name for c in failed] == [
        "sliding gain bound k1 > d*|D*| + w*|J* + λR*| + δN* (recomputed on building)"]
    assert "k1 = 1.05, bound = 1.07" in failed[0].detail
    old = {k: v for k, v in data.items() if k != "sliding_inputs"}
    obs = build_observer(model, Design.from_json(old, model))
    assert not obs.failed_conditions  # (only d*|D*| = 1 is checked without δ and N*)
    assert any("d*|D*|" in c.name and c.holds for c in obs.conditions)
    for bad in ({"delta": -1}, {"delta": "1"}, {"delta": 1, "gain": 2}, [1], {"lipschitz": 1}):
        with pytest.raises(UsageError, match="sliding"):
            Design.from_json({**genuine, "sliding_inputs": bad}, model)
    m2, d2 = designed["unknown-input-canonical"]
    with pytest.raises(UsageError, match="sliding-mode design only"):
        Design.from_json({**json.loads(json.dumps(d2.to_json())),
                          "sliding_inputs": {"delta": 1}}, m2)


@pytest.mark.parametrize("name", ["J_diag", "F_diag", "T", "Phi_diag"])
def test_diagonal_form_follows_from_t_and_the_certified_matrices(designed, name):
    """Interval observers of a canonical design are built from its seed-001 diagonal form:
    T, F_diag, J_diag, … are recomputed from T and the certified matrices on reading (an
    audit changed J_diag and the true x1 left its interval in 1882 of 2001 samples)."""
    model, d = designed["interval-canonical"]
    data = json.loads(json.dumps(d.to_json()))
    assert "T" in data["matrices"]
    Design.from_json(json.loads(json.dumps(data)), model)
    data["matrices"][name][0][0] = f"({data['matrices'][name][0][0]}) + 1"
    with pytest.raises(UsageError, match="not what its T makes|F_diag is not diagonal"):
        Design.from_json(data, model)


def test_signature_naming_an_unknown_fault_is_refused(designed):
    model, d = designed["diagnostic-jordan"]
    data = json.loads(json.dumps(d.to_json()))
    data["signature"] = {**(data.get("signature") or {}), "nosuchfault": True}
    with pytest.raises(UsageError, match="not a fault of the model"):
        Design.from_json(data, model)


def test_third_audit_round_tampers_are_refused(designed):
    """A third audit's tampers that were accepted: L* ≠ 0 in a decoupled design (the
    unknown-input estimator reads L* and gained disturbance-bound terms), a k that is not
    Φ's number of rows (interval observers then failed with an IndexError), and an output
    left out (the virtual sensor failed with a KeyError; a sliding-mode observer lost d_hat)."""
    model, d = designed["unknown-input-canonical"]
    data = json.loads(json.dumps(d.to_json()))
    assert "L_star" in data["matrices"]
    data["matrices"]["L_star"] = [["1"] * len(r) for r in data["matrices"]["L_star"]]
    with pytest.raises(UsageError, match="records L\\* ≠ 0"):
        Design.from_json(data, model)
    for key in ("interval-canonical", "virtual-sensor-jordan", "sliding-mode"):
        model, d = designed[key]
        data = json.loads(json.dumps(d.to_json()))
        data["k"] = d.k + 1
        with pytest.raises(UsageError, match="but Φ has"):
            Design.from_json(data, model)
    for key, name in (("virtual-sensor-jordan", "z"), ("sliding-mode", "r"),
                      ("sliding-mode", "d_hat"), ("diagnostic-jordan", "r")):
        model, d = designed[key]
        data = json.loads(json.dumps(d.to_json()))
        del data["outputs"][name]
        with pytest.raises(UsageError, match=f"outputs lack {name}"):
            Design.from_json(data, model)

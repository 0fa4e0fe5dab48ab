"""A design that fails its certificate is an error, never an output."""
import pytest
import sympy as sp

import observer_cad.synthesis.canonical._exact as canonical  # fault injection into the synthesis (its exact steps)
from observer_cad import CertificateError, design_canonical, load_model
from observer_cad.synthesis import certify_reduced_model
from observer_cad.cli import main


def _drive_matrices():
    k1, k2, k3, k4, k5, k6 = sp.symbols("k1:7")
    F = sp.Matrix([[1, k1, 0], [0, k2, k3], [0, k4, k5]])
    return dict(F=F, G=sp.Matrix([0, 0, k6]), H=sp.Matrix([[1, 0, 0], [0, 0, 1]]),
                C=sp.zeros(3, 0), D=sp.Matrix([0, 0, 1]), L=sp.Matrix([0, 1, 0]),
                Phi=sp.Matrix([[-k4, 0, k1]]), F_star=sp.Matrix([[0]]),
                J_star=sp.Matrix([[-k4, k1 * k5]]), R_star=sp.Matrix([[-k4, k1]]),
                H_star=sp.Matrix([[1]]), G_star=sp.Matrix([[k1 * k6]]), D_star=sp.Matrix([[k1]]))


def test_correct_matrices_pass():
    cert = certify_reduced_model(**_drive_matrices())
    assert cert.passed and cert.exact
    assert [i.name for i in cert.identities] == [
        "Phi F - F* Phi - J* H", "H* Phi - R* H", "Phi G - G*", "Phi D - D*", "Phi L"]


@pytest.mark.parametrize("name,bad", [
    ("J_star", sp.Matrix([[-sp.Symbol("k4"), sp.Symbol("k5")]])),   # a dropped factor k1
    ("G_star", sp.Matrix([[sp.Symbol("k6")]])),
    ("D_star", sp.Matrix([[1]])),
    ("Phi", sp.Matrix([[-sp.Symbol("k4"), 1, sp.Symbol("k1")]])),     # Phi L != 0
])
def test_each_corrupted_matrix_is_caught(name, bad):
    mats = _drive_matrices()
    mats[name] = bad
    with pytest.raises(CertificateError):
        certify_reduced_model(**mats)
    cert = certify_reduced_model(**mats, raise_on_failure=False)
    assert not cert.passed
    assert "FAILED" in cert.summary()


def test_float_certificate_uses_tolerance():
    import numpy as np
    mats = {k: np.array(sp.Matrix(v).subs({s: 2 for s in sp.symbols("k1:7")}), dtype=float)
            if v.shape[1] else np.zeros(v.shape) for k, v in _drive_matrices().items()}
    assert certify_reduced_model(**mats, exact=False, tolerance=1e-12).passed
    mats["J_star"] = mats["J_star"] + 1e-6
    assert not certify_reduced_model(**mats, exact=False, tolerance=1e-9,
                                     raise_on_failure=False).passed


def test_synthesis_bug_raises_and_cli_prints_no_design(monkeypatch, models_dir, capsys):
    """Corrupt the synthesis (a wrong Phi row): the design must not come out."""
    real = canonical.member_to_phi

    def broken(v, F, H, k):
        R, J, Phi = real(v, F, H, k)
        Phi = Phi.copy()
        Phi[0, 1] += 1
        return R, J, Phi
    monkeypatch.setattr(canonical, "member_to_phi", broken)
    model = load_model(models_dir / "electric_drive.py")
    with pytest.raises(CertificateError):
        design_canonical(model, unknown_input="d", symbolic=True)
    rc = main(["design", str(models_dir / "electric_drive.py"), "--observer", "unknown-input",
               "--fault", "d"])
    out, err = capsys.readouterr()
    assert rc == 2
    assert "certificate" in err and "Phi" not in out

"""Design and Observer read well in a notebook: a short repr, Markdown with LaTeX."""
from observer_cad import build_observer, design, load_model


def test_design_and_observer_reprs(models_dir):
    m = load_model(models_dir / "electric_drive.py")
    d = design(m, observer="unknown-input", faults=["d"])
    r = repr(d)
    assert len(r) < 200 and "unknown-input" in r and "certified" in r and "k = 1" in r
    md = d._repr_markdown_()
    assert r"$$\Phi = " in md and "| ✅ |" in md
    assert d._repr_latex_().startswith(r"$\begin{aligned}\Phi &=")
    o = build_observer(m, d)
    assert len(repr(o)) < 200 and "d_hat" in repr(o)
    assert "$$" in o._repr_markdown_()


def test_unknown_input_design_prints_the_estimator_formula(capsys, models_dir):
    """design --observer unknown-input shows the d̂ formula simulate and codegen use
    (gains g, the bounds d_min/d_max and α), not only the residual."""
    from observer_cad.cli import main
    assert main(["design", str(models_dir / "electric_drive.py"), "--observer", "unknown-input",
                 "--fault", "d"]) == 0
    out = capsys.readouterr().out
    assert "d_hat = " in out and "alpha" in out and "d_min" in out and "d_max" in out
    assert "parameters: g = " in out


def test_analysis_reprs(models_dir):
    from observer_cad import analyze
    a = analyze(load_model(models_dir / "three_tank_faults.py"))
    r = repr(a)
    assert len(r) < 200 and "faults detectable" in r
    md = a._repr_markdown_()
    assert "| fault | detectable | minimal order | strongly detectable | reason |" in md
    assert md.count("\n| f") >= len(a.faults)
    # the strong answers: f1, f2 strongly detectable at order 2 (f3 decoupled), f3 not at all
    assert "| f1 | ✅ | 2 | ✅ (order 2) |" in md and "| f3 | ❌ | — | ❌ |" in md
    assert "Strong structure rows (every 1 with a nonzero gain at the analysed frequencies ω = 0)" in md
    assert "| f3 | 1 | 1 | 0 | 2 |" in md
    # a fault seen only as a transient: y = x1 − x2 with x1' = −x1 + f, x2' = −2 x2 + 2 f,
    # whose transfer −s/((s + 1)(s + 2)) vanishes at s = 0
    import sympy as sp
    from observer_cad import PlantModel
    x1, x2, f = sp.symbols("x1 x2 f")
    m = PlantModel(name="washout", time="continuous", states=[x1, x2], faults=[f],
                   outputs=[x1 - x2], dynamics=[-x1 + f, -2 * x2 + 2 * f])
    md = analyze(m)._repr_markdown_()
    assert "| f | ✅ |" in md and "❌ transient only" in md
    assert "none: no fault is strongly detectable" in md

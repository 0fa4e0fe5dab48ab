"""The operating envelope (bounds on states and inputs) and the initial-state box of a
PlantModel: validated with one-line errors and shown by `show`."""
import pytest
import sympy as sp

from observer_cad import PlantModel
from observer_cad.errors import ModelError

x1, x2, u, w = sp.symbols("x1 x2 u w")


def _model(**kw):
    return PlantModel(name="t", time="continuous", states=[x1, x2], inputs=[u], noise=[w],
                      outputs=[x1 + w], dynamics=[x2, -x1 - x2 + u], **kw)


def test_envelope_and_initial_box_are_kept_exactly():
    m = _model(bounds={x1: (-1, 1), u: (0, 2), w: (-0.01, 0.01)},
               initial={x1: (0, "1/2"), x2: (0, 0)})
    assert m.bounds[x1] == (-1, 1) and m.bounds[w] == (sp.Rational(-1, 100), sp.Rational(1, 100))
    assert m.initial == {x1: (0, sp.Rational(1, 2)), x2: (0, 0)}
    assert _model().initial == {}


@pytest.mark.parametrize("kw, message", [
    (dict(initial={x1: (0, 1)}), "the initial box names some states but not 'x2'"),
    (dict(bounds={x1: (-1, 1)}, initial={x1: (0, 3), x2: (0, 0)}),
     "initial box of 'x1' \\[0, 3\\] leaves its bounds \\[-1, 1\\]"),
    (dict(initial={u: (0, 1)}), "initial box given for 'u', which is not a state"),
    (dict(initial={x1: (1, 0), x2: (0, 0)}), "initial box of 'x1' have low 1 > high 0"),
    (dict(initial={x1: (0,), x2: (0, 0)}), "initial box of 'x1' must be a pair"),
    (dict(initial=[1]), "initial must be a mapping"),
    (dict(bounds={x1: (2, 1)}), "bounds of 'x1' have low 2 > high 1"),
    (dict(bounds={x1: "wide"}), "bounds of 'x1' must be a pair"),
])
def test_bad_declarations_get_one_line(kw, message):
    with pytest.raises(ModelError, match=message) as err:
        _model(**kw)
    assert "\n" not in str(err.value)


def test_show_lists_the_envelope_and_the_initial_box(models_dir, capsys):
    from observer_cad.cli import main
    assert main(["show", str(models_dir / "dc_motor_sampled.py")]) == 0
    out = capsys.readouterr().out
    assert "i in [-4, 4]" in out and "u in [-5, 5]" in out
    assert "initial      i(0) in [-1/2, 1/2], w(0) in [-1, 1], wl(0) in [-1, 1]" in out

"""The cases of ``observer-cad demo``: what each seed paper's example runs.

* electric drive (seed 000 §9, discrete): unknown-input estimators of the fault d
  (k = 1, Fig. 1–2) and of the disturbance ρ (k = 2, mismatched, ρ* = 0.2,
  g = (−0.4, −0.1), Fig. 3–4), the Jordan-form estimator of seed 000 §8, a residual
  generator (seed 002 §2) and an interval observer for the speed x2;
* nonlinear three-tank (seed 002 §8, continuous): the Jordan virtual sensor
  x*' = u1 − √(x* − y1) (Fig. 2) and the interval observer of x1 (Fig. 3, two noise
  levels);
* linear three-tank (seeds 001 §7 and 004 §5): virtual sensors for x1 (canonical form,
  plain and seed 004's variant; Jordan form) and interval observers for x1 (001 methods
  1 and 2, Fig. 2);
* the sliding-mode example (this project's model, seed 002 §5);
* diagnosability (:data:`DIAGNOSABILITY`): the analysis of ``three_tank_faults.py``
  (which faults can be detected with ρ decoupled, which pairs isolated, the achievable
  structure matrix, the reasons and suggestions), and an isolating residual bank for
  ``three_tank_isolation.py`` (every level measured), compiled, simulated with a step
  fault in tank 2 and plotted (:data:`BANK_FIGURE`).

Each :class:`Case` names the model, the design's options, the scenarios it is simulated
on (:class:`Run`), the command line that reproduces it and a note for the report.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import sympy as sp

__all__ = ["CASES", "EXAMPLES_DIR", "Case", "Run", "DIAGNOSABILITY", "DiagnosabilityExample",
           "BANK_FIGURE", "ANALYSIS_JSON", "BANK_JSON"]

R = sp.Rational

#: The example models (``*.py``) and their scenarios (``scenarios/*.json``), which ship
#: inside the package: in a source checkout ``observer_cad/examples`` is a symbolic link
#: to the repository's ``models/`` (one copy of every file), and an installed package
#: holds the files themselves (pyproject ``package-data``). The demo reads its models
#: here, so it runs from any directory, with or without the repository.
EXAMPLES_DIR = Path(__file__).resolve().parent.parent / "examples"


@dataclasses.dataclass(frozen=True)
class Run:
    """One simulation of a case: a scenario file of ``models/scenarios``."""

    scenario: str
    #: "zero": start the observer at x*(0) = 0 instead of its default Φ x(0), so that
    #: the convergence of the estimate is visible.
    observer_start: str | None = None


@dataclasses.dataclass(frozen=True)
class Case:
    """One design of the demo: what the paper does, and how it is reproduced."""

    key: str
    heading: str
    paper: str
    model: str
    design: dict
    runs: tuple = ()
    options: dict = dataclasses.field(default_factory=dict)  # build_observer(**options)
    bounds: dict = dataclasses.field(default_factory=dict)  # model bounds overridden
    cli: str = ""
    note: str = ""


CASES = (
    Case("drive_d", "Electric drive: estimate the fault d (k = 1)",
         "seed 000 §9, Fig. 1–2", "electric_drive.py",
         dict(observer="unknown-input", faults=["d"], symbolic=True),
         runs=(Run("electric_drive_fig1"), Run("electric_drive_fig2")),
         cli="observer-cad design models/electric_drive.py --observer unknown-input --fault d --symbolic\n"
             "observer-cad simulate models/electric_drive.py --observer unknown-input --fault d"
             " --scenario models/scenarios/electric_drive_fig1.json --out out/fig1",
         note="Designed with k1…k6 kept symbolic (the paper's matrices, up to a common"
              " factor); simulated at the model's values (a forward-Euler DC motor, see"
              " models/electric_drive.py). g = −0.7, d̲ = −0.4, d̄ = 0.4, x̲*(0) = −1,"
              " x̄*(0) = 1 as in the paper."),
    Case("drive_rho", "Electric drive: estimate the disturbance ρ with d = 0 (k = 2, mismatched)",
         "seed 000 §9, Fig. 3–4", "electric_drive.py",
         dict(observer="unknown-input", faults=["rho"], symbolic=True),
         runs=(Run("electric_drive_rho_fig3"), Run("electric_drive_rho_fig4")),
         options=dict(bounds={"rho": (R(-1, 5), R(1, 5))}, g=[R(-2, 5), R(-1, 10)]),
         cli="observer-cad design models/electric_drive.py --observer unknown-input --fault rho --symbolic\n"
             "observer-cad simulate models/electric_drive.py --observer unknown-input --fault rho"
             " --bound rho=-0.2,0.2 --gain -0.4 -0.1"
             " --scenario models/scenarios/electric_drive_rho_fig3.json --out out/fig3",
         note="ρ* = 0.2, g1 = −0.4, g2 = −0.1 as in the paper. ρ enters the second row only"
              " (mismatched case): ρ̂(t) is available at step t + 2."),
    Case("drive_d_jordan", "Electric drive: Jordan-form estimator of d (λ = 1/2)",
         "seed 000 §8", "electric_drive.py",
         dict(observer="unknown-input", faults=["d"], form="jordan"),
         runs=(Run("electric_drive_fig1"),),
         cli="observer-cad design models/electric_drive.py --observer unknown-input --fault d --form jordan",
         note="The one-dimensional λ-model of seed 000 §8 on the scenario of Fig. 1."),
    Case("drive_diag", "Electric drive: residual generator for d, decoupled from ρ",
         "seed 002 §2 (Jordan form) on the drive of seed 000 §9", "electric_drive.py",
         dict(observer="diagnostic", form="jordan"),
         runs=(Run("electric_drive_diagnostic"),),
         cli="observer-cad design models/electric_drive.py --observer diagnostic --form jordan"),
    Case("drive_interval", "Electric drive: interval observer for the motor speed x2 (λ = 4/5)",
         "seed 002 §4 / seed 001 method 2 on the drive of seed 000 §9", "electric_drive.py",
         dict(observer="interval", estimate="x2", lambdas=["4/5"]),
         runs=(Run("electric_drive_interval"),),
         cli="observer-cad design models/electric_drive.py --observer interval --estimate x2 --lambda 4/5",
         note="λ = 4/5 gives Φ = (0, 1, 0): the fault does not reach x*, only the load"
              " torque's bound |ρ| ≤ 0.05 does (width 2·0.05/(1 − 4/5) = 0.5 rad/s)."),
    Case("tank_vs", "Nonlinear three-tank: Jordan virtual sensor for x1",
         "seed 002 §8, Fig. 2", "three_tank.py",
         dict(observer="virtual-sensor", estimate="x1"),
         runs=(Run("three_tank_fig2"),),
         cli="observer-cad design models/three_tank.py --observer virtual-sensor --estimate x1",
         note="λ = −1 gives the one-dimensional sensor x*' = u1 − √(x* − y1), z = x*,"
              " decoupled from ρ1 and ρ2."),
    Case("tank_interval", "Nonlinear three-tank: interval observer for x1 (|w| ≤ 0.01)",
         "seed 002 §8, Fig. 3", "three_tank.py",
         dict(observer="interval", estimate="x1"),
         runs=(Run("three_tank_interval"),),
         cli="observer-cad design models/three_tank.py --observer interval --estimate x1"),
    Case("tank_interval_w05", "Nonlinear three-tank: interval observer for x1 (|w| ≤ 0.05)",
         "seed 002 §8, Fig. 3 (second noise level)", "three_tank.py",
         dict(observer="interval", estimate="x1"),
         runs=(Run("three_tank_interval_w05"),),
         bounds={"w1": (R(-1, 20), R(1, 20)), "w2": (R(-1, 20), R(1, 20))},
         cli="observer-cad design models/three_tank.py --observer interval --estimate x1"
             " --bound w1=-0.05,0.05 --bound w2=-0.05,0.05"),
    Case("lin_vs_plain", "Linear three-tank: canonical-form virtual sensor for x1 (k = 2)",
         "seed 001 §7 / seed 004 §5", "three_tank_linear.py",
         dict(observer="virtual-sensor", estimate="x1", form="canonical", eigenvalues=["-1", "-2"]),
         runs=(Run("three_tank_linear_virtual", "zero"),),
         cli="observer-cad design models/three_tank_linear.py --observer virtual-sensor"
             " --estimate x1 --form canonical --eigenvalues -1 -2"),
    Case("lin_vs_004", "Linear three-tank: seed 004's virtual sensor (virtual output drives the model)",
         "seed 004 §5", "three_tank_linear.py",
         dict(observer="virtual-sensor", estimate="x1", form="canonical", variant="004",
              eigenvalues=["-1", "-2"]),
         runs=(Run("three_tank_linear_virtual", "zero"),),
         cli="observer-cad design models/three_tank_linear.py --observer virtual-sensor"
             " --estimate x1 --form canonical --variant 004 --eigenvalues -1 -2"),
    Case("lin_vs_jordan", "Linear three-tank: Jordan-form virtual sensor for x1 (k = 1)",
         "seed 002 §3 on the tank of seed 001 §7", "three_tank_linear.py",
         dict(observer="virtual-sensor", estimate="x1"),
         runs=(Run("three_tank_linear_virtual", "zero"),),
         cli="observer-cad design models/three_tank_linear.py --observer virtual-sensor --estimate x1"),
    Case("lin_interval_m2", "Linear three-tank: interval observer for x1, method 2 (Jordan, k = 1)",
         "seed 001 §7, observer (7.2), Fig. 2", "three_tank_linear.py",
         dict(observer="interval", estimate="x1"),
         runs=(Run("three_tank_linear_interval"),),
         cli="observer-cad design models/three_tank_linear.py --observer interval --estimate x1"),
    Case("lin_interval_m1", "Linear three-tank: interval observer for x1, method 1 (canonical → diagonal, k = 2)",
         "seed 001 §7, method 1", "three_tank_linear.py",
         dict(observer="interval", estimate="x1", form="canonical", eigenvalues=["-1", "-2"]),
         runs=(Run("three_tank_linear_interval"),),
         cli="observer-cad design models/three_tank_linear.py --observer interval --estimate x1"
             " --form canonical --eigenvalues -1 -2"),
    Case("sliding", "Sliding-mode estimator of the fault d",
         "seed 002 §5 (this project's example model)", "sliding_example.py",
         dict(observer="sliding-mode"),
         runs=(Run("sliding_example"),),
         cli="observer-cad design models/sliding_example.py --observer sliding-mode"),
)


@dataclasses.dataclass(frozen=True)
class DiagnosabilityExample:
    """The report's diagnosability example: the analysis of one model, and an
    isolating residual bank (:func:`~observer_cad.synthesis.design_bank`, best scheme)
    for another, simulated on ``scenario``."""

    analysis_model: str
    bank_model: str
    scenario: str
    analysis_cli: str = ""
    bank_cli: str = ""
    analysis_note: str = ""
    note: str = ""


DIAGNOSABILITY = DiagnosabilityExample(
    "three_tank_faults.py", "three_tank_isolation.py", "three_tank_isolation",
    analysis_cli="observer-cad analyze models/three_tank_faults.py",
    bank_cli="observer-cad analyze models/three_tank_isolation.py\n"
             "observer-cad design models/three_tank_isolation.py --observer diagnostic --isolate\n"
             "observer-cad simulate models/three_tank_isolation.py --observer diagnostic --isolate"
             " --scenario models/scenarios/three_tank_isolation.json --out out/bank",
    analysis_note="f3 enters tank 3 exactly as ρ does, so no residual decoupled from ρ can see it,"
                  " whatever is measured. f1 and f2 are each detected by an order-2 residual (the"
                  " k = 2 of seed 001 §7), but with two outputs, one disturbance and one more fault"
                  " to decouple there is no room left to tell them apart; measuring x1 as well would"
                  " give an order-1 residual for each direction. The bank below is built on such a"
                  " plant.",
    note="The same three tanks with the third level sensor added (x1 measured too) and the"
         " disturbance ρ entering every tank alike (a common supply line): no fault enters as ρ"
         " does, and each can be decoupled together with ρ.")


#: the figure of the residual bank (r1 … rm under a step fault), under ``figures/``
BANK_FIGURE = "three_tank_isolation_residuals.png"
#: the analysis and the bank as JSON (``analyze --json``, ``design --isolate --json``), under ``designs/``
ANALYSIS_JSON = "three_tank_faults_analysis.json"
BANK_JSON = "three_tank_isolation_bank.json"

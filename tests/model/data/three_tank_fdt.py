"""The three-tank system of the Fault Diagnosis Toolbox, written as its users write it
(Frisk, Krysander & Jung 2017, "A toolbox for analysis and design of model based
diagnosis systems for large scale models", IFAC World Congress; the toolbox's three-tank
example): pressures p1..p3, the inflow q0, flow faults fV1..fV3 in the valves, leak
faults fT1..fT3 in the tanks, each right-hand side a parameter dividing a parenthesised
sum that holds a fault. The measured flow q2 and the pressure p1 are the outputs (the
sensor faults and the inflow sensor of the original are left out here). The parameter
values are this project's choice.
"""
import sympy as sp

from observer_cad import PlantModel

p1, p2, p3 = sp.symbols("p1 p2 p3")
q0 = sp.Symbol("q0")
fV1, fV2, fV3, fT1, fT2, fT3 = sp.symbols("fV1 fV2 fV3 fT1 fT2 fT3")
Rv1, Rv2, Rv3, CT1, CT2, CT3 = sp.symbols("Rv1 Rv2 Rv3 CT1 CT2 CT3")

model = PlantModel(
    name="three_tank_fdt", time="continuous", states=[p1, p2, p3], inputs=[q0],
    faults=[fV1, fV2, fV3, fT1, fT2, fT3],
    outputs=[p1, (p2 - p3) / Rv2],
    dynamics=[fT1 + (q0 - (p1 - p2) / Rv1 - fV1) / CT1,
              fT2 + ((p1 - p2) / Rv1 + fV1 - (p2 - p3) / Rv2 - fV2) / CT2,
              fT3 + ((p2 - p3) / Rv2 + fV2 - p3 / Rv3 - fV3) / CT3],
    parameters={Rv1: 1, Rv2: 2, Rv3: 3, CT1: 1, CT2: 2, CT3: 5},
)

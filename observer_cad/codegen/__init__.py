"""Compiled observers: sympy → casadi step functions, C code generation with a cache,
whole-trajectory simulation in one compiled call, standalone C export.

    from observer_cad.codegen import observer_step, compile_function, CompiledSimulator
    f = observer_step(obs, h=0.01)            # casadi Function x, y, u, p -> x_next, out
    c = compile_function(f).function          # same function, compiled (cached .so)
    c = compile_observer_step(obs, h=0.01).function   # same, a repeat skips translation
    z = observer_step(obs, h=0.01, discretisation="zoh")  # exact ZOH (affine observers)
    res = CompiledSimulator(model, obs).simulate(scenario)   # == simulate(model, obs, scenario)
    export_observer(obs, "out", dt=0.01)      # out/NAME.c, NAME.h, NAME_example.c (standalone C)
"""
from .compile import (CodegenError, CompiledFunction, STATS, cache_dir, compile_function,
                      compile_observer_step, compile_or_interpret, compile_plant_step,
                      compile_source, fingerprint, generate_c, structure)
from .translate import (DISCRETISATIONS, Translator, describe, joint_step, observer_step,
                        plant_step, rk4, to_casadi, zoh_matrices)
from .export import export_observer, export_sources
from .trajectory import CompiledSimulator, simulate_compiled

__all__ = ["CodegenError", "CompiledFunction", "STATS", "cache_dir", "compile_function",
           "compile_observer_step", "compile_or_interpret", "compile_plant_step",
           "compile_source", "fingerprint", "generate_c", "structure", "DISCRETISATIONS",
           "Translator", "describe", "joint_step", "observer_step", "plant_step", "rk4",
           "to_casadi", "zoh_matrices",
           "CompiledSimulator", "simulate_compiled", "export_observer", "export_sources"]

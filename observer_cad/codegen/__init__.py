"""Stage 8 — compiled observers: sympy → casadi step functions, C code generation with a cache,
whole-trajectory simulation in one compiled call, standalone C export.

    from observer_cad.codegen import observer_step, compile_function, CompiledSimulator
    f = observer_step(obs, h=0.01)            # casadi Function x, y, u, p -> x_next, out
    c = compile_function(f).function          # same function, compiled (cached .so)
    c = compile_observer_step(obs, h=0.01).function   # same, a repeat skips translation
    z = observer_step(obs, h=0.01, discretisation="zoh")  # exact ZOH (affine observers)
    res = CompiledSimulator(model, obs).simulate(scenario)   # == simulate(model, obs, scenario)
    export_observer(obs, "out", dt=0.01)      # out/NAME.c, NAME.h, NAME_example.c (standalone C)
    export_fmu(obs, "out", dt=0.01)           # out/NAME.fmu (FMI 2.0 co-simulation; or 3.0)
    ref = reference_run(obs, columns, dt=0.01)   # the same steps in Python, on recorded columns
    compare_columns(ref, read_csv_columns("run.csv")).ok   # another run (FMU, C, monitor) equal?
"""
from ._compile import (CodegenError, cache_dir, usable_cache_dir, verify_library, compiler, generate_c, compile_source, compile_function, CompiledFunction, STATS, FLAGS, LARGE_SOURCE, LARGE_LEVEL, size_aware_flags, structure, fingerprint, compile_observer_step, compile_plant_step)
from ._decide_c import (DecisionSources)
from ._export import (export_observer, export_sources, ExportedSources, EXAMPLE_FLAGS, silence_unused_parameters)
from ._trajectory import (CompiledSimulator, simulate_compiled)
from ._translate import (to_casadi, Translator, observer_step, plant_step, joint_step, describe, split_signals, rk4, zoh_matrices)
from ._monitor_engine import (CompiledMonitorEngine)
from ._library import (LibrarySpec, library_spec, load_library, loaded_libraries)
from ._fmu import (export_fmu, FmuExport, FmuVariable, fmi_variable_name)
from ._replay import (reference_run, fmu_samples, compare_columns, ColumnComparison, read_csv_columns)

__all__ = [
    "DecisionSources", "CodegenError", "cache_dir", "usable_cache_dir", "verify_library",
    "compiler", "generate_c", "compile_source", "compile_function", "CompiledFunction", "STATS",
    "FLAGS", "LARGE_SOURCE", "LARGE_LEVEL", "size_aware_flags", "structure", "fingerprint",
    "compile_observer_step", "compile_plant_step", "export_observer", "export_sources",
    "ExportedSources", "EXAMPLE_FLAGS", "silence_unused_parameters", "CompiledSimulator",
    "simulate_compiled", "to_casadi", "Translator", "observer_step", "plant_step", "joint_step",
    "describe", "split_signals", "rk4", "zoh_matrices", "LibrarySpec", "library_spec",
    "load_library", "loaded_libraries", "export_fmu", "FmuExport", "FmuVariable",
    "fmi_variable_name", "reference_run", "fmu_samples", "compare_columns", "ColumnComparison",
    "read_csv_columns", "CompiledMonitorEngine"
]

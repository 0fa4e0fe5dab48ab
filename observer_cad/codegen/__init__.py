"""Stage 8 — compiled observers: sympy → casadi step functions, C code generation with a cache,
whole-trajectory simulation in one compiled call, standalone C export.

    from observer_cad.codegen import observer_step, compile_function, CompiledSimulator
    f = observer_step(obs, h=0.01)            # casadi Function x, y, u, p -> x_next, out
    c = compile_function(f).function          # same function, compiled (cached .so)
    c = compile_observer_step(obs, h=0.01).function   # same, a repeat skips translation
    z = observer_step(obs, h=0.01, discretisation="zoh")  # exact ZOH (affine observers)
    res = CompiledSimulator(model, obs).simulate(scenario)   # == simulate(model, obs, scenario)
    export_observer(obs, "out", dt=0.01)      # out/NAME.c, NAME.h, NAME_example.c (standalone C)
    export_fmu(obs, "out", dt=0.01)           # out/NAME.fmu (FMI 2.0 co-simulation)
"""
from ._compile import (CACHE_LOCK, CodegenError, cache_dir, usable_cache_dir, verify_library, compiler, generate_c, compile_source, compile_function, compile_or_interpret, CompiledFunction, STATS, FLAGS, LARGE_SOURCE, LARGE_LEVEL, size_aware_flags, structure, fingerprint, lookup_fingerprint, record_fingerprint, forget_fingerprint, compile_observer_step, compile_plant_step)
from ._decide_c import (MAX_C_RESIDUALS, DecisionSources, decision_sources)
from ._export import (export_observer, export_sources, ExportedSources, EXAMPLE_FLAGS, silence_unused_parameters)
from ._fmu import (export_fmu, FmuExport, FmuVariable, fmi_variable_name, FMU_FLAGS, fmu_platform, FMI_VERSIONS)
from ._replay import (reference_run, fmu_samples, compare_columns, ColumnComparison, DECISION_COLUMNS, read_csv_columns)
from ._loops import loop_source
from ._trajectory import (CompiledSimulator, simulate_compiled, TRAJ_FLAGS)
from ._translate import (to_casadi, Translator, observer_step, plant_step, joint_step, describe, split_signals, rk4, zoh_matrices, DISCRETISATIONS, observer_step_name, plant_step_name, joint_step_name, observer_identity, plant_identity, joint_identity)
from ._library import (LibrarySpec, library_spec, load_library, loaded_libraries)

__all__ = ["MAX_C_RESIDUALS", "DecisionSources", "decision_sources", "CACHE_LOCK", "CodegenError", "cache_dir", "usable_cache_dir", "verify_library", "compiler", "generate_c", "compile_source", "compile_function", "compile_or_interpret", "CompiledFunction", "STATS", "FLAGS", "LARGE_SOURCE", "LARGE_LEVEL", "size_aware_flags", "structure", "fingerprint", "lookup_fingerprint", "record_fingerprint", "forget_fingerprint", "compile_observer_step", "compile_plant_step", "export_observer", "export_sources", "ExportedSources", "EXAMPLE_FLAGS", "silence_unused_parameters", "export_fmu", "FmuExport", "FmuVariable", "fmi_variable_name", "FMU_FLAGS", "fmu_platform", "FMI_VERSIONS", "reference_run", "fmu_samples", "compare_columns", "ColumnComparison", "DECISION_COLUMNS", "read_csv_columns", "CompiledSimulator", "simulate_compiled", "loop_source", "TRAJ_FLAGS", "to_casadi", "Translator", "observer_step", "plant_step", "joint_step", "describe", "split_signals", "rk4", "zoh_matrices", "DISCRETISATIONS", "observer_step_name", "plant_step_name", "joint_step_name", "observer_identity", "plant_identity", "joint_identity", "LibrarySpec", "library_spec", "load_library", "loaded_libraries"]

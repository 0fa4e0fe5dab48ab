"""Stage 9 — ensembles of runs, after code generation.

::

    from observer_cad.ensemble import Backend, run_ensemble
    res = run_ensemble(model, observer, scenario, runs=10_000,
                       backend=Backend("threads"))          # or "processes", "dask", "serial"
    print(res.statistics.to_text())                     # quantiles, worst runs per case
    worst = res.accumulator.worst("x1.min_slack", 3)    # replay(...) reproduces them exactly

The lower level::

    from observer_cad.ensemble import Backend, map_chunks, progress_bar
    backend = Backend("processes", workers=2)        # or "serial", "threads", "dask"
    with progress_bar(len(chunks), desc="chunks") as bar:
        for chunk, result in map_chunks(task, payload, chunks, backend=backend, progress=bar):
            ...                                      # any order; chunks carry their run indices

Compiled code reaches the workers as a :class:`observer_cad.codegen.LibrarySpec` in the
payload, loaded there with :func:`observer_cad.codegen.load_library`.
"""
from ._backends import (DASK_MISSING, Backend, Interrupted, map_chunks, progress_bar)
from ._statistics import (EnsembleStatistics, FieldStatistics, GroupStatistics, Statistics, SummaryRow, DEFAULT_QUANTILES)
from ._runner import (Chunk, EnsembleResult, run_ensemble, replay, replay_worst, ReplayError, default_worst_field)

__all__ = [
    "DASK_MISSING", "Backend", "Interrupted", "map_chunks", "progress_bar", "Chunk",
    "EnsembleResult", "run_ensemble", "replay", "replay_worst", "ReplayError",
    "default_worst_field", "EnsembleStatistics", "FieldStatistics", "GroupStatistics",
    "Statistics", "SummaryRow", "DEFAULT_QUANTILES"
]

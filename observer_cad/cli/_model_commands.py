"""The commands that look at a model without designing an observer: ``show`` (the
extracted structure) and ``analyze`` (which faults can be detected and isolated).
"""
from __future__ import annotations

import json

__all__ = ["cmd_show", "cmd_analyze"]


def cmd_show(args) -> int:
    from ..model import load_model
    from ..reporting import format_structure, structure_to_json
    from ..model import extract_structure
    st = extract_structure(load_model(args.model))
    if args.json:
        print(json.dumps(structure_to_json(st), indent=2))
    else:
        print(format_structure(st))
    return 0


def cmd_analyze(args) -> int:
    from ..model import load_model
    from ..reporting import analysis_to_json, format_analysis
    from ..analysis import analyze
    result = analyze(load_model(args.model), faults=args.fault or None,
                     disturbances=args.disturbance, candidates=args.candidate,
                     symbolic=args.symbolic, method=args.method, rtol=args.rtol,
                     frequencies=args.frequency if args.frequency is not None else (0,))
    if args.json:
        print(json.dumps(analysis_to_json(result), indent=2))
    else:
        print(format_analysis(result))
    return 0

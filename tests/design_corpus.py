"""A corpus of design requests and the digest of what each gives, so that a change meant
to move code without changing behaviour can be checked: every shipped model × observer
kind × target × form × (numeric, --symbolic), random plants (exact and float paths) and
residual banks. A request's outcome is the SHA-256 of its design's JSON (sorted keys) or,
when it is refused, the class of the error.

``python3 tests/design_corpus.py --write`` records the digests in
``tests/data/design_digests.json``; ``tests/test_design_digests.py`` compares.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DIGESTS = ROOT / "tests" / "data" / "design_digests.json"
FORMS = (None, "canonical", "jordan")


def _kinds(model) -> list:
    out = [dict(observer="unknown-input", faults=[f.name])
           for f in model.faults + model.disturbances]
    out.append(dict(observer="diagnostic"))
    for f in model.faults:
        out.append(dict(observer="sliding-mode", faults=[f.name]))
        out.append(dict(observer="diagnostic", faults=[f.name]))
    for x in model.states:
        out.append(dict(observer="virtual-sensor", estimate=x.name))
        out.append(dict(observer="interval", estimate=x.name))
    return out


def requests() -> list:
    """(key, kind of request, model source, options) for the whole corpus."""
    from observer_cad import load_model
    out = []
    for path in sorted((ROOT / "models").glob("*.py")):
        if "drem" in path.stem:
            continue
        model = load_model(path)
        for kind in _kinds(model):
            for form in FORMS:
                for symbolic in ((False, True) if model.parameters else (False,)):
                    opts = dict(kind, form=form, symbolic=symbolic)
                    key = f"{path.stem} {json.dumps(opts, sort_keys=True)}"
                    out.append((key, "design", ("file", path.name), opts))
    for n, l, seed, time in ((4, 2, 0, "continuous"), (5, 2, 1, "discrete"),
                             (5, 3, 2, "continuous"), (6, 3, 3, "discrete")):
        src = ("random", dict(n=n, l=l, p=1, seed=seed, time=time))
        for kind in (dict(observer="unknown-input", faults=["d"]), dict(observer="diagnostic"),
                     dict(observer="virtual-sensor", estimate="x1"),
                     dict(observer="interval", estimate="x1")):
            for form in ("canonical", "jordan"):
                opts = dict(kind, form=form)
                out.append((f"random {json.dumps(src[1], sort_keys=True)}"
                            f" {json.dumps(opts, sort_keys=True)}", "design", src, opts))
    src = ("random", dict(n=24, l=4, p=1, seed=2, time="discrete", integer=False))
    for kind in (dict(observer="unknown-input", faults=["d"], form="canonical"),
                 dict(observer="diagnostic", form="jordan"),
                 dict(observer="virtual-sensor", estimate="x1", form="jordan")):
        opts = dict(kind, method="float")
        out.append((f"random {json.dumps(src[1], sort_keys=True)}"
                    f" {json.dumps(opts, sort_keys=True)}", "design", src, opts))
    for name in ("three_tank_isolation", "three_tank_faults", "electric_drive_uncertain"):
        out.append((f"{name} bank", "bank", ("file", f"{name}.py"), {}))
    return out


def _model(src):
    from observer_cad import load_model
    from observer_cad.model import random_model
    kind, what = src
    if kind == "file":
        return load_model(ROOT / "models" / what)
    return random_model(what["n"], what["l"], what["p"], seed=what["seed"], time=what["time"],
                        integer=what.get("integer", True))


def outcome(request) -> str:
    """The digest of one request's outcome."""
    from observer_cad import design
    from observer_cad.errors import ObserverCadError
    from observer_cad.analysis import design_bank
    _, kind, src, opts = request
    model = _model(src)
    try:
        made = design(model, **opts) if kind == "design" else design_bank(model)
    except ObserverCadError as exc:
        return f"refused: {type(exc).__name__}"
    data = made.to_json()
    # the model's structure hash says which model a design file is for, not what was
    # designed (and it is the same for every design of a model): left out of the digest
    for d in [data] + list(data.get("designs", [])):
        d.pop("model_hash", None)
    text = json.dumps(data, sort_keys=True, default=str)
    return "sha256: " + hashlib.sha256(text.encode("utf-8")).hexdigest()


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--write", action="store_true", help="record the digests")
    args = p.parse_args(argv)
    found = {}
    for req in requests():
        found[req[0]] = outcome(req)
        print(f"{found[req[0]][:20]}  {req[0]}", flush=True)
    if args.write:
        DIGESTS.parent.mkdir(parents=True, exist_ok=True)
        DIGESTS.write_text(json.dumps(found, indent=1, sort_keys=True) + "\n", encoding="utf-8")
        print(f"wrote {len(found)} digests to {DIGESTS.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

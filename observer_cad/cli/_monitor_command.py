"""The command ``monitor``: the observer (its threshold and decisions) over recorded data,
a file at once or rows on stdin as they arrive (``--data -``)."""
from __future__ import annotations

import sys
from pathlib import Path

from ..errors import UsageError
from ..residuals import ThresholdSpec
from ..progress import report
from ._from_args import (design_or_load, monitor_engine, observer_options, refuse_failed,
                         threshold_from_args, unsampled_band_note)
from ._parser import PROG

__all__ = ["cmd_monitor"]


def _pairs(items, option: str) -> dict:
    """NAME=VALUE items of a repeatable option as a dict (text values)."""
    out = {}
    for item in items:
        k, sep, v = item.partition("=")
        if not sep or not k.strip() or not v.strip():
            raise UsageError(f"{option} {item!r}: use NAME=VALUE")
        out[k.strip()] = v.strip()
    return out


def cmd_monitor(args) -> int:
    from ..model import parse_number
    from ..simulation import Monitor, read_table
    if args.symbolic:
        raise UsageError("monitor needs numeric parameters: drop --symbolic")
    rename = _pairs(args.column, "--column")
    initial = {k: float(parse_number(v, where=f"--initial {k}={v}"))
               for k, v in _pairs(args.initial, "--initial").items()}
    data = None if args.data == "-" else read_table(args.data)  # read before the design's work
    model, result = design_or_load(args, numeric=True)
    for sig in rename:
        if sig != "t" and model.symbol(sig) is None and not (
                sig.startswith("y") and sig[1:].isdigit()
                and 1 <= int(sig[1:]) <= len(model.outputs)):
            raise UsageError(f"--column {sig}={rename[sig]}: '{sig}' is neither t nor an input or"
                             f" output (y1 …) of {model.name}")
    report("building the observer", stage=True)
    from ..observers import build_observer
    observer = build_observer(model, result, **observer_options(args, result))
    refuse_failed(observer)
    if model.time == "continuous" and args.sample_time is not None:
        raise UsageError(f"--sample-time applies to discrete-time models; {model.name} is"
                         " continuous (its sample time is the interval of t)")

    def monitor_at(h):
        """(the monitor with the band of the data's sample time h, its engine's name)."""
        obs = threshold_from_args(args, model, observer, sample_time=h)
        refuse_failed(obs)
        rule = None
        if obs.threshold is not None:
            from ..residuals import decision_rule
            rule = decision_rule(model, result, persistence=args.persistence)
        elif args.persistence != 1:
            raise UsageError("--persistence applies with --threshold")
        engine, how = monitor_engine(args, obs)
        return Monitor(model, obs, rule=rule, sample_time=args.sample_time, initial=initial,
                       engine=engine), how
    if data is None:
        if _band_needs_h(args, model):  # the band of the data's h, once two rows give it
            return _stream(args, None, rename, "", later=(monitor_at, observer, model))
        mon, how = monitor_at(None)
        return _stream(args, mon, rename, how)
    mon, how = monitor_at(_data_step(data, rename))
    report("monitoring", stage=True)
    res = mon.run(data, rename=rename, source=str(args.data))
    return _finish(args, mon, res, how)


def _band_needs_h(args, model) -> bool:
    """Whether the band --threshold asks for depends on the data's sample time: a
    guaranteed band on a continuous-time model is the sampled-data one at h, or that of
    continuous observation with its "sampling" condition saying what h leaves out."""
    return model.time == "continuous" and args.threshold is not None \
        and ThresholdSpec.parse(args.threshold).kind == "guaranteed"


def _data_step(data, rename):
    """The first interval of the data's t column (None for a stream or a t that is not
    numeric: the monitor's own checks report it)."""
    try:
        t = data[rename.get("t", "t")]
        return float(t[1]) - float(t[0]) if len(t) > 1 and float(t[1]) > float(t[0]) else None
    except (TypeError, KeyError, ValueError, IndexError):
        return None


def _finish(args, mon, res, how: str) -> int:
    """Write monitor.csv, its units and monitor.png (atomically, together), then print
    what was found."""
    import numpy as np
    from ..files import staged_directory
    from ..reporting import plot_monitor, write_signals_csv
    decisions = None
    if mon.rule is not None:
        from ..residuals import decide
        decisions = decide(mon.rule, res.columns)
    out, lines = Path(args.out), []
    n = int(np.asarray(res["t"]).size)
    if n == 0:
        raise UsageError(f"{args.data}: no rows")
    with staged_directory(out) as stage:
        path = write_signals_csv(res, stage, name="monitor.csv")
        lines.append(f"wrote {out / path.name} ({n} rows, columns: {', '.join(res.order)};"
                     f" {how})")
        units = ", ".join(f"{c} [{u}]" for c, u in res.units.items() if c in res.order)
        lines.append(f"wrote {out / 'monitor.units.json'} ("
                     f"{'units: ' + units if units else 'no units: the model declares none'})")
        title = f"{mon.model.name}, {mon.observer.kind}"
        fig = plot_monitor(res, stage / "monitor.png", outputs=mon.outputs,
                           decisions=decisions, time=mon.model.time, title=title)
        lines.append(f"wrote {out / Path(fig).relative_to(stage)}")
    print("\n".join(lines))
    _print_findings(mon, res)
    return 0


def _print_findings(mon, res) -> None:
    """The sample time, the envelope warning, the threshold, the first alarm and the
    diagnosis at the end."""
    import numpy as np
    t = np.asarray(res["t"])
    unit = "" if mon.model.time == "discrete" else " s"
    if mon.model.time == "continuous":
        print(f"sample time h = {mon.h:.10g} s (the observer's RK4 step, inputs held over it)")
    if mon.assumed_zero:
        print(f"initial state: the observer starts as if {' = '.join(mon.assumed_zero)} = 0 at"
              f" t = {float(t[0]):g} (not measured; --initial NAME=VALUE sets them)")
    _warn_envelope(mon, res)
    if mon.rule is None:
        return
    print(f"threshold: {mon.observer.threshold.text()}")
    note = unsampled_band_note(mon.observer)
    if note:
        print(note)
    alarm = np.asarray(res["alarm"]) != 0
    diag = np.asarray(res["diagnosis"])
    if alarm.any():
        k = int(np.flatnonzero(alarm)[0])
        print(f"first alarm at t = {t[k]:g}{unit} ({diag[k]}); alarm in {int(alarm.sum())} of"
              f" {alarm.size} samples (persistence {mon.rule.persistence})")
    else:
        print(f"no alarm in {alarm.size} samples (persistence {mon.rule.persistence})")
    print(f"diagnosis at the end (t = {t[-1]:g}{unit}): {diag[-1]}")


def _warn_envelope(mon, res) -> None:
    """One warning line when the data leave the declared envelope: the first time, the
    signal and its range, how many samples."""
    import numpy as np
    ok = np.asarray(res["in_bounds"]) != 0
    if ok.all():
        return
    k = int(np.flatnonzero(~ok)[0])
    which = next(((n, lo, hi) for n, (lo, hi) in mon.envelope.items() if n in res.columns
                  and not (lo <= float(np.asarray(res[n])[k]) <= hi)), None)
    what = (f"{which[0]} = {float(np.asarray(res[which[0]])[k]):g} outside its declared range"
            f" [{which[1]:g}, {which[2]:g}]" if which else "a signal outside its declared range")
    print(f"{PROG}: warning: the data leave the declared envelope at t ="
          f" {float(np.asarray(res['t'])[k]):g} ({what}); {int((~ok).sum())} of {ok.size} samples"
          " out (in_bounds = 0): no guarantee is claimed there", file=sys.stderr)


def _stream(args, mon, rename: dict, how: str, *, later=None) -> int:
    """--data -: rows from stdin as they arrive, each change of alarm or diagnosis printed
    (flushed) at once; at the end of the input the files as for a file. ``later``:
    (``monitor_at(h)``, the observer, the model) when the band depends on the data's
    sample time: the monitor is made once the first two rows give h, then steps them."""
    import csv
    from ..simulation import declared_envelope, monitor_signals, parse_row
    src = "<stdin>"
    if mon is not None:
        mon.source = src
    signals = mon.signals if mon is not None else tuple(
        s for group in monitor_signals(later[1]) for s in group)
    envelope = mon.envelope if mon is not None else declared_envelope(later[2])
    line = sys.stdin.readline().lstrip("\ufeff")
    header = [h.strip() for h in next(csv.reader([line]), [])]
    if not header or header == [""]:
        raise UsageError(f"{src}: no header row (t and the signals' columns)")
    col = {s: rename.get(s, s) for s in ("t",) + signals}
    missing = [c for c in col.values() if c not in header]
    if missing:
        raise UsageError(f"{src}: no column '{missing[0]}'; columns: {', '.join(header)}")
    extra = [c for c in envelope if c not in col and rename.get(c, c) in header]
    col.update({c: rename.get(c, c) for c in extra})
    print(f"monitoring rows from stdin ({', '.join(col.values())}; " + (
        how if mon is not None else "the guaranteed band needs the data's sample time: made"
        " once the first two rows give it") + ")", flush=True)
    row, warned, first = 0, False, []
    try:
        for line in sys.stdin:
            if not line.strip():
                continue
            row += 1
            cells = next(csv.reader([line]))
            vals = parse_row(cells, header, list(dict.fromkeys(col.values())), source=src,
                             row=row)
            v = {s: vals[c] for s, c in col.items()}
            t = v.pop("t")
            if not all(map(_finite, v.values())) or not _finite(t):
                bad = next(s for s in ["t"] + list(v) if not _finite(v.get(s, t)))
                raise UsageError(f"{src}, row {row}, column '{col[bad]}': not a finite number")
            if mon is None:
                first.append((t, v))
                if len(first) < 2:
                    continue
                mon, how = _monitor_from_two_rows(later[0], first, src)
                for k, (tk, vk) in enumerate(first):
                    warned = _stream_step(mon, tk, vk, k + 1, warned)
                continue
            warned = _stream_step(mon, t, v, row, warned)
    except (KeyboardInterrupt, SystemExit) as exc:  # Ctrl-C, or SIGTERM (SystemExit 143)
        print(f"{PROG}: interrupted after {row} rows; " + (
            "writing them" if mon is not None else "nothing written (the band waited for a"
            " second row)"), file=sys.stderr)
        if row and mon is not None:
            _finish(args, mon, mon.result(), how)
        return exc.code if isinstance(exc, SystemExit) and isinstance(exc.code, int) else 130
    if row == 0:
        raise UsageError(f"{src}: no rows after the header")
    if mon is None:
        raise UsageError(f"{src}: one row: the guaranteed band is that of the data's sample"
                         " time, which needs two rows")
    return _finish(args, mon, mon.result(), how)


def _monitor_from_two_rows(monitor_at, first, src):
    """(monitor, its engine's name) with the band of h = t1 − t0 of the first two rows,
    said on one line (flushed)."""
    (t0, _), (t1, _) = first
    if not t1 > t0:
        raise UsageError(f"{src}, row 2, column 't': t = {t1:.17g} does not increase (the row"
                         f" before has {t0:.17g})")
    mon, how = monitor_at(t1 - t0)
    mon.source = src
    print(f"sample time h = {t1 - t0:.10g} s (the first two rows; {how}); threshold:"
          f" {mon.observer.threshold.text()}", flush=True)
    return mon, how


def _stream_step(mon, t: float, v: dict, row: int, warned: bool) -> bool:
    """One row through the monitor, its change of alarm or diagnosis printed (flushed);
    returns whether the envelope warning has been given."""
    s = mon.step(t, {k: x for k, x in v.items() if not k.startswith("y")},
                 {k: x for k, x in v.items() if k.startswith("y")})
    if s.alarm is not None and (s.changed and (row > 1 or s.alarm)):
        print(f"t = {t:g}: " + (f"alarm, diagnosis {s.diagnosis}" if s.alarm
                                else f"alarm cleared ({s.diagnosis})"), flush=True)
    if not s.in_bounds and not warned:
        warned = True
        print(f"{PROG}: warning: t = {t:g}: the data leave the declared envelope (no"
              " guarantee while they are out; in_bounds = 0)", file=sys.stderr, flush=True)
    return warned


def _finite(x: float) -> bool:
    import math
    return math.isfinite(x)

"""FMI co-simulation export of a monitor: ``NAME.fmu``, built from the standalone C.

    from observer_cad.codegen import export_fmu
    fmu = export_fmu(obs, "out", dt=0.01, rule=rule)   # out/NAME.fmu (a zip), FMI 2.0
    fmu = export_fmu(obs, "out", dt=0.01, fmi_version="3.0")   # FMI 3.0
    fmu.path, fmu.variables, fmu.renamed                 # where, what, names mapped

The archive holds

* ``modelDescription.xml`` (FMI 2.0 by default, co-simulation): Real inputs — the measurements
  ``y1 …``, the known inputs ``u …`` and, with a rule whose thresholds are not observer
  outputs, the threshold inputs ``<r>_lower``/``<r>_upper`` (start NaN: not out); Real
  outputs — the observer's outputs (residuals, estimates, bands ``r_lower``/``r_upper``);
  with a rule, Boolean outputs ``<r>_alarm`` per residual and ``alarm`` and the Integer
  output ``diagnosis_code`` (Σ alarm_i 2^(i−1); every code's diagnosis is listed in its
  description); Real parameters — the observer's parameters (tunable) and its initial
  state ``<state>_start`` (fixed); ``DefaultExperiment stepSize`` = the sample time.
* ``sources/``: ``NAME.c``, ``NAME.h`` (the standalone export, :func:`export_sources`)
  and ``NAME_fmu.c`` (the FMI functions, :mod:`._fmu_c`);
* ``binaries/<platform>/NAME.<so|dylib|dll>``: those sources compiled with the system C
  compiler (``$CC`` or ``cc``; a missing compiler is a one-line
  :class:`~observer_cad.errors.UsageError`);
* ``documentation/index.html``: the variables, the timing and the renamed names.

FMI 3.0 (``fmi_version="3.0"``, :mod:`._fmu3_c`): the same variables and timing as
``Float64``/``Int32``/``Boolean`` with value references unique across types (the Real
ones as in 2.0, then the independent variable ``time``, ``diagnosis_code``, the alarms),
an ``instantiationToken`` instead of the GUID, ``binaries/x86_64-linux`` (FMI 3.0's
platform tuples) and ``sources/buildDescription.xml``.

Timing: the samples are at ``t_start + k·Ts``, ``Ts`` the sample time (the RK4/ZOH step
``dt`` of a continuous-time observer — the step function is exactly the exported C's —
or ``sample_time`` of a discrete one, default 1); ``fmi2DoStep(t, h)`` takes every sample
due in ``[t, t + h)``; the outputs read after it are those of the last sample, held
(one sample of latency, no direct feedthrough). See :mod:`._fmu_c`.

Names: FMI's structured naming convention is used, so every variable name is a C-like
identifier. A name that is not (``ξ1``, ``x.1``, a leading digit) is mapped —
transliterated to ASCII, other characters replaced by ``_``, ``_`` put before a leading
digit — and, like a name that would repeat another, made unique with ``_2``, ``_3`` …;
every mapped name is listed in ``FmuExport.renamed``, in the variable's description and
in ``documentation/index.html``.

The archive is written atomically and is reproducible: fixed member dates, the GUID a
hash of the sources and the model description.
"""
from __future__ import annotations

import dataclasses
import hashlib
import html
import io
import math
import os
import re
import subprocess
import sys
import tempfile
import uuid
import zipfile
from pathlib import Path
from typing import Mapping
from xml.sax.saxutils import quoteattr

from ..errors import UsageError
from ..files import atomic_write_bytes
from ..observers import Observer
from ..residuals import DecisionRule
from ..version import package_version
from ._compile import CodegenError
from ._ctext import ascii_text
from ._export import export_sources
from ._fmu_c import fmu_wrapper_source
from ._fmu3_c import fmu3_wrapper_source
from ._translate import split_signals

__all__ = ["export_fmu", "FmuExport", "FmuVariable", "fmi_variable_name", "FMU_FLAGS",
           "fmu_platform", "FMI_VERSIONS"]

#: how the binary in the FMU is compiled (plus -shared, the sources, -lm, -o)
FMU_FLAGS = ("-std=c99", "-O2", "-fPIC", "-fvisibility=hidden")

_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


@dataclasses.dataclass(frozen=True)
class FmuVariable:
    """One scalar variable of the model description: its FMI ``name``, the ``source``
    name in the observer (or the rule), type (``Real``/``Integer``/``Boolean``),
    causality, variability, value reference, start value (None: calculated) and
    description."""

    name: str
    source: str
    type: str
    causality: str
    variability: str
    value_reference: int
    start: float | None
    description: str


@dataclasses.dataclass(frozen=True)
class FmuExport:
    """What :func:`export_fmu` wrote: the archive's ``path``, the model identifier
    ``name``, ``fmi_version``, ``sample_time``, the ``variables`` in model-description
    order, ``renamed`` (pairs (source name, FMI name) of the names that were mapped),
    the binary's ``platform`` folder and the ``guid``."""

    path: Path
    name: str
    fmi_version: str
    sample_time: float
    variables: tuple
    renamed: tuple
    platform: str
    guid: str

    def variable(self, source: str) -> FmuVariable:
        """The variable of the observer's (or rule's) name ``source``."""
        for v in self.variables:
            if v.source == source:
                return v
        raise UsageError(f"the FMU {self.name} has no variable for '{source}'")

    @property
    def outputs(self) -> tuple:
        """The output variables, in order."""
        return tuple(v for v in self.variables if v.causality == "output")

    @property
    def inputs(self) -> tuple:
        """The input variables, in order."""
        return tuple(v for v in self.variables if v.causality == "input")


def fmi_variable_name(text: str) -> str:
    """``text`` as a name of FMI's structured convention (a C-like identifier): ASCII
    transliteration, other characters ``_``, ``_`` before a leading digit or for ''."""
    s = re.sub(r"[^A-Za-z0-9_]", "_", ascii_text(str(text)))
    if not s or s[0].isdigit():
        s = "_" + s
    return s


def fmu_platform(fmi_version: str = "2.0") -> tuple:
    """``(folder, suffix)`` of this platform's binary in an FMU: FMI 2.0's names
    (``linux64`` …) or FMI 3.0's platform tuples (``x86_64-linux`` …)."""
    import platform
    if sys.platform.startswith("linux"):
        system, suffix = "linux", ".so"
    elif sys.platform == "darwin":
        system, suffix = "darwin", ".dylib"
    elif sys.platform in ("win32", "cygwin"):
        system, suffix = "win" if fmi_version == "2.0" else "windows", ".dll"
    else:
        raise UsageError(f"fmu: no FMI binary folder for platform {sys.platform!r}")
    if fmi_version == "2.0":
        return f"{system}{'64' if sys.maxsize > 2 ** 32 else '32'}", suffix
    machine = platform.machine().lower()
    arch = {"amd64": "x86_64", "x86_64": "x86_64", "arm64": "aarch64", "aarch64": "aarch64",
            "i386": "x86", "i686": "x86"}.get(machine)
    if arch is None:
        raise UsageError(f"fmu: no FMI 3.0 platform tuple for the machine {machine!r}")
    return f"{arch}-{system}", suffix


class _Names:
    """Unique FMI names; the map of the names that changed."""

    def __init__(self):
        self.used, self.renamed = set(), []

    def __call__(self, source: str) -> str:
        base = fmi_variable_name(source)
        name, k = base, 1
        while name in self.used:
            k += 1
            name = f"{base}_{k}"
        self.used.add(name)
        if name != source:
            self.renamed.append((source, name))
        return name


def _output_description(o: str, rule, outs) -> str:
    if rule is not None and o in rule.residuals:
        return f"residual {o}"
    for side in ("lower", "upper"):
        if o.endswith(f"_{side}") and o[:-len(side) - 1] in outs:
            return f"{side} band of {o[:-len(side) - 1]}"
    return f"observer output {o}"


def _variables(observer: Observer, src, rule, version: str = "2.0") -> tuple:
    """The variables in model-description order and the renamed pairs. Value references:
    FMI 2.0 numbers each type from 0; FMI 3.0 numbers them across types (the Real ones as
    in 2.0, then ``time``, ``diagnosis_code``, the alarms)."""
    names = _Names()
    if version == "3.0":
        names("time")
    ys, us = split_signals(observer)
    dec = src.decisions
    outs = list(observer.output_names)
    real, booleans, integers = [], [], []

    def add(lst, source, typ, caus, var, start, desc):
        lst.append(FmuVariable(names(source), source, typ, caus, var, len(lst), start, desc))

    for s in ys:
        add(real, str(s), "Real", "input", "continuous", 0.0, f"measurement {s}")
    for s in us:
        add(real, str(s), "Real", "input", "continuous", 0.0, f"known input {s}")
    for col in (dec.input_columns if dec is not None else []):
        add(real, col, "Real", "input", "continuous", math.nan,
            f"threshold {col} (NaN: not available, the residual is not out)")
    delays = {str(k): int(v) for k, v in observer.delays.items() if int(v)}
    for o in outs:
        lag = f" (the estimate for sample k - {delays[o]})" if o in delays else ""
        add(real, o, "Real", "output", "discrete", None,
            _output_description(o, rule, outs) + lag)
    for p, v in observer.parameters.items():
        add(real, str(p), "Real", "parameter", "tunable", float(v), f"observer parameter {p}")
    for x, v in zip(observer.states, src.x0):
        add(real, f"{x}_start", "Real", "parameter", "fixed", float(v),
            f"initial value of the observer state {x}")
    if rule is not None:
        for r in rule.residuals:
            add(booleans, f"{r}_alarm", "Boolean", "output", "discrete", None,
                f"{r} out of its band for {rule.persistence} consecutive sample(s)")
        add(booleans, "alarm", "Boolean", "output", "discrete", None, "any residual alarm")
        table = "; ".join(f"{k} = {t}" for k, t in enumerate(rule.table()))
        add(integers, "diagnosis_code", "Integer", "output", "discrete", None,
            f"diagnosis code, sum of alarm_i 2^(i-1) over {', '.join(rule.residuals)}: {table}")
    first = []
    if version == "3.0":
        n = len(real)
        first = [FmuVariable("time", "time", "Real", "independent", "continuous", n, None,
                             "simulation time")]
        integers = [dataclasses.replace(v, value_reference=n + 1) for v in integers]
        booleans = [dataclasses.replace(v, value_reference=n + 2 + v.value_reference)
                    for v in booleans]
    variables = tuple(dataclasses.replace(v, description=v.description + (
        f" (observer name '{v.source}')" if v.name != v.source else ""))
        for v in first + real + integers + booleans)
    return variables, tuple(names.renamed)


def _xml_number(v: float) -> str:
    if math.isnan(v):
        return "NaN"
    if math.isinf(v):
        return "INF" if v > 0 else "-INF"
    return repr(float(v))


def _model_description(name: str, observer: Observer, variables, ts: float, guid: str) -> str:
    """modelDescription.xml (FMI 2.0, co-simulation)."""
    desc = f"{observer.kind} monitor {observer.name} ({observer.time} time), sample time {ts!r}"
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             f'<fmiModelDescription fmiVersion="2.0" modelName={quoteattr(observer.name)}'
             f' guid="{guid}"',
             f'  description={quoteattr(desc)}',
             f'  generationTool="observer_cad {package_version()}"'
             ' variableNamingConvention="structured" numberOfEventIndicators="0">',
             f'  <CoSimulation modelIdentifier="{name}"'
             ' canHandleVariableCommunicationStepSize="true" canInterpolateInputs="false"'
             ' maxOutputDerivativeOrder="0" canRunAsynchronuously="false"'
             ' canBeInstantiatedOnlyOncePerProcess="false"'
             ' canNotUseMemoryManagementFunctions="true"'
             ' canGetAndSetFMUstate="false" canSerializeFMUstate="false"'
             ' providesDirectionalDerivative="false">',
             '    <SourceFiles>',
             f'      <File name="{name}.c"/>',
             f'      <File name="{name}_fmu.c"/>',
             '    </SourceFiles>',
             '  </CoSimulation>',
             '  <LogCategories>',
             '    <Category name="logError" description="errors"/>',
             '  </LogCategories>',
             f'  <DefaultExperiment startTime="0.0" stepSize="{_xml_number(ts)}"/>',
             '  <ModelVariables>']
    for v in variables:
        attrs = _variable_attributes(v)
        if v.causality == "output":
            attrs += ' initial="calculated"'
        start = "" if v.start is None else f' start="{_xml_number(v.start)}"'
        lines.append(f'    <ScalarVariable {attrs}><{v.type}{start}/></ScalarVariable>')
    lines += ['  </ModelVariables>', '  <ModelStructure>', '    <Outputs>']
    outs = [i for i, v in enumerate(variables, start=1) if v.causality == "output"]
    lines += [f'      <Unknown index="{i}" dependencies=""/>' for i in outs]
    lines += ['    </Outputs>', '    <InitialUnknowns>']
    lines += [f'      <Unknown index="{i}"/>' for i in outs]
    lines += ['    </InitialUnknowns>', '  </ModelStructure>', '</fmiModelDescription>', '']
    return "\n".join(lines)


def _variable_attributes(v) -> str:
    """The attributes FMI 2.0 and 3.0 share for a variable: name, value reference,
    description, causality, variability (and initial="exact" for a parameter)."""
    attrs = (f'name={quoteattr(v.name)} valueReference="{v.value_reference}"'
             f' description={quoteattr(v.description)} causality="{v.causality}"'
             f' variability="{v.variability}"')
    return attrs + (' initial="exact"' if v.causality == "parameter" else "")


def _model_description3(name: str, observer: Observer, variables, ts: float,
                         token: str) -> str:
    """modelDescription.xml (FMI 3.0, co-simulation)."""
    types = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean"}
    desc = f"{observer.kind} monitor {observer.name} ({observer.time} time), sample time {ts!r}"
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             f'<fmiModelDescription fmiVersion="3.0" modelName={quoteattr(observer.name)}'
             f' instantiationToken="{token}"',
             f'  description={quoteattr(desc)}',
             f'  generationTool="observer_cad {package_version()}"'
             ' variableNamingConvention="structured">',
             f'  <CoSimulation modelIdentifier="{name}"'
             ' canHandleVariableCommunicationStepSize="true" hasEventMode="false"'
             ' canGetAndSetFMUState="false" canSerializeFMUState="false"'
             ' providesDirectionalDerivatives="false" providesAdjointDerivatives="false"'
             ' maxOutputDerivativeOrder="0" providesIntermediateUpdate="false"'
             ' canReturnEarlyAfterIntermediateUpdate="false"/>',
             '  <LogCategories>',
             '    <Category name="logError" description="errors"/>',
             '  </LogCategories>',
             f'  <DefaultExperiment startTime="0.0" stepSize="{_xml_number(ts)}"/>',
             '  <ModelVariables>']
    for v in variables:
        attrs = _variable_attributes(v)
        start = "" if v.start is None else f' start="{_xml_number(v.start)}"'
        lines.append(f'    <{types[v.type]} {attrs}{start}/>')
    lines += ['  </ModelVariables>', '  <ModelStructure>']
    outs = [v.value_reference for v in variables if v.causality == "output"]
    lines += [f'    <Output valueReference="{r}" dependencies=""/>' for r in outs]
    lines += [f'    <InitialUnknown valueReference="{r}"/>' for r in outs]
    lines += ['  </ModelStructure>', '</fmiModelDescription>', '']
    return "\n".join(lines)


def _documentation(name: str, observer: Observer, variables, renamed, ts: float) -> str:
    """documentation/index.html: the variables, the timing, the renamed names."""
    rows = "\n".join(
        f"<tr><td>{html.escape(v.name)}</td><td>{html.escape(v.source)}</td><td>{v.type}</td>"
        f"<td>{v.causality}</td><td>{v.variability}</td>"
        f"<td>{'' if v.start is None else html.escape(_xml_number(v.start))}</td>"
        f"<td>{html.escape(v.description)}</td></tr>" for v in variables)
    ren = ("".join(f"<li>{html.escape(a)} &rarr; {html.escape(b)}</li>" for a, b in renamed)
           if renamed else "<li>none: every name is a valid FMI name</li>")
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{html.escape(name)}</title></head><body>
<h1>{html.escape(observer.name)}: {html.escape(observer.kind)} monitor ({observer.time} time)</h1>
<p>Generated by observer_cad {html.escape(package_version())}. Sample time Ts = {ts!r}
(DefaultExperiment stepSize). The samples are at t_start + k&middot;Ts; fmi2DoStep(t, h)
takes every sample due in [t, t + h) with the inputs as set; the outputs read after it
are those of the last sample, held until the next (one sample of latency, no direct
feedthrough). In initialization mode the outputs preview sample 0.</p>
<h2>Variables</h2>
<table border="1"><tr><th>FMI name</th><th>observer name</th><th>type</th><th>causality</th>
<th>variability</th><th>start</th><th>description</th></tr>
{rows}
</table>
<h2>Renamed (not valid FMI structured names, or repeated)</h2>
<ul>{ren}</ul>
</body></html>
"""


def _checked_sample_time(observer: Observer, dt, sample_time) -> float:
    if observer.time == "continuous":
        if dt is None:
            raise UsageError("fmu: a continuous-time observer needs dt (the step baked into"
                             " the FMU's step function, its sample time)")
        if sample_time is not None:
            raise UsageError("fmu: the sample time of a continuous-time observer is dt;"
                             " sample_time applies to discrete observers")
        return float(dt)
    ts = 1.0 if sample_time is None else sample_time
    try:
        ts = float(ts)
    except (TypeError, ValueError):
        raise UsageError(f"fmu: sample_time must be a number, got {sample_time!r}") from None
    if not (math.isfinite(ts) and ts > 0):
        raise UsageError(f"fmu: sample_time must be a positive finite number, got {sample_time!r}")
    return ts


def _c_compiler(cc=None) -> str:
    import shutil
    name = cc or os.environ.get("CC") or "cc"
    path = shutil.which(name)
    if path is None:
        raise UsageError(f"fmu: C compiler '{name}' not found (the FMU holds a binary built"
                         " with it; set CC to a C compiler, e.g. gcc)")
    return path


def _compile_binary(cc: str, files: Mapping, name: str, suffix: str) -> bytes:
    """The shared library of the sources ``files`` (name → text)."""
    with tempfile.TemporaryDirectory(prefix="observer_cad_fmu_") as tmp:
        for fn, text in files.items():
            Path(tmp, fn).write_text(text, encoding="ascii", errors="replace")
        lib = Path(tmp, name + suffix)
        srcs = [fn for fn in files if fn.endswith(".c")]
        cmd = [cc, *FMU_FLAGS, "-shared", *srcs, "-lm", "-o", str(lib)]
        try:
            r = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True, timeout=600)
        except (OSError, subprocess.TimeoutExpired) as exc:
            raise CodegenError(f"fmu: the C compiler '{cc}' did not run: {exc}") from None
        if r.returncode != 0 or not lib.is_file():
            first = next((ln for ln in r.stderr.splitlines() if "error" in ln),
                         r.stderr.strip().splitlines()[0] if r.stderr.strip() else "")
            raise CodegenError(f"fmu: compiling the FMU's binary failed: {first}")
        return lib.read_bytes()


def _zip(members: Mapping) -> bytes:
    """A zip of ``members`` (path → bytes) with fixed dates: the same content, the same
    archive."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for path, data in members.items():
            info = zipfile.ZipInfo(path, date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = (0o755 if path.startswith("binaries/") else 0o644) << 16
            z.writestr(info, data)
    return buf.getvalue()


FMI_VERSIONS = ("2.0", "3.0")


def _build_description(N: str) -> str:
    """sources/buildDescription.xml of an FMI 3.0 FMU."""
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            '<fmiBuildDescription fmiVersion="3.0">\n'
            f'  <BuildConfiguration modelIdentifier="{N}">\n'
            '    <SourceFileSet language="C99">\n'
            f'      <SourceFile name="{N}.c"/>\n'
            f'      <SourceFile name="{N}_fmu.c"/>\n'
            '    </SourceFileSet>\n'
            '    <Library name="m"/>\n'
            '  </BuildConfiguration>\n'
            '</fmiBuildDescription>\n')


def _wrapper(version: str, N: str, token: str, src, ts: float, offsets: dict) -> str:
    nthr = len(src.decisions.input_columns) if src.decisions is not None else 0
    make = fmu_wrapper_source if version == "2.0" else fmu3_wrapper_source
    return make(N, token, nthr_in=nthr, dec=src.decisions, sample_time=repr(ts),
                n_real=offsets)


def _description(version: str, N: str, observer, variables, ts: float, token: str) -> str:
    make = _model_description if version == "2.0" else _model_description3
    return make(N, observer, variables, ts, token)


def export_fmu(observer: Observer, out_dir, *, name: str | None = None,
               dt: float | None = None, sample_time: float | None = None,
               initial: Mapping | None = None, discretisation: str = "rk4",
               rule: DecisionRule | None = None, cc: str | None = None,
               fmi_version: str = "2.0") -> FmuExport:
    """Write ``out_dir/NAME.fmu``, an FMI co-simulation FMU of ``observer`` (see the
    module docstring); returns an :class:`FmuExport`.

    ``name``, ``dt``, ``initial``, ``discretisation``, ``rule``: as for
    :func:`export_observer` (``dt`` required in continuous time: it is the sample
    time); ``sample_time``: a discrete observer's sample period (default 1);
    ``cc``: the C compiler (default ``$CC`` or ``cc``); ``fmi_version``: ``"2.0"``
    (default) or ``"3.0"``.
    """
    if fmi_version not in FMI_VERSIONS:
        raise UsageError(f"fmu: FMI version must be one of {', '.join(FMI_VERSIONS)},"
                         f" got {fmi_version!r}")
    ts = _checked_sample_time(observer, dt, sample_time)
    src = export_sources(observer, name=name, dt=dt, initial=initial,
                         discretisation=discretisation, rule=rule)
    N = src.name
    cc_path = _c_compiler(cc)
    folder, suffix = fmu_platform(fmi_version)
    variables, renamed = _variables(observer, src, rule, fmi_version)
    n_in = sum(v.causality == "input" for v in variables)
    n_out = sum(v.causality == "output" and v.type == "Real" for v in variables)
    n_par = len(observer.parameters)
    offsets = {"inputs": 0, "outputs": n_in, "params": n_in + n_out,
               "starts": n_in + n_out + n_par, "total": n_in + n_out + n_par + len(src.x0)}
    draft = "\0".join([src.c, src.h, _wrapper(fmi_version, N, "T", src, ts, offsets),
                       _description(fmi_version, N, observer, variables, ts, "T")])
    digest = hashlib.sha256(draft.encode()).hexdigest()
    guid = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, "observer_cad:" + digest)) + "}"
    sources = {f"{N}.c": src.c, f"{N}.h": src.h,
               f"{N}_fmu.c": _wrapper(fmi_version, N, guid, src, ts, offsets)}
    binary = _compile_binary(cc_path, sources, N, suffix)
    members = {"modelDescription.xml": _description(fmi_version, N, observer, variables, ts,
                                                    guid).encode("utf-8")}
    members.update({f"sources/{fn}": text.encode("ascii", "replace")
                    for fn, text in sources.items()})
    if fmi_version == "3.0":
        members["sources/buildDescription.xml"] = _build_description(N).encode("utf-8")
    members[f"binaries/{folder}/{N}{suffix}"] = binary
    members["documentation/index.html"] = _documentation(N, observer, variables, renamed,
                                                         ts).encode("utf-8")
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{out_dir}: cannot create the output directory: {exc.strerror}") from None
    path = out / f"{N}.fmu"
    try:
        atomic_write_bytes(path, _zip(members))
    except OSError as exc:
        raise UsageError(f"{path}: cannot write: {exc.strerror}") from None
    return FmuExport(path, N, fmi_version, ts, variables, renamed, folder, guid)

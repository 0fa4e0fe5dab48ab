"""C text of the FMI 3.0 co-simulation wrapper: ``NAME_fmu.c`` of an FMI 3.0 FMU.

The same core as the FMI 2.0 wrapper (:func:`fmu_core_source`: the instance, the sample,
the samples of a communication step, the timing), with the FMI 3.0 functions around it.
Value references are unique across types: the Float64 ones as in FMI 2.0 (inputs,
outputs, parameters, initial state), then ``time`` (the independent variable), then the
Int32 ``diagnosis_code`` and the Boolean alarms (``<r>_alarm`` …, ``alarm``). Every
function of the FMI 3.0 API is defined (FMPy loads them all); those of model exchange,
scheduled execution, clocks, FMU states and derivatives return ``fmi3Error``. Compiled
with ``-DOBSERVER_CAD_FMI3_HEADERS`` it includes the standard's ``fmi3Functions.h``.
"""
from __future__ import annotations

import re

from ._fmu_c import fmu_core_source

__all__ = ["fmu3_wrapper_source", "FMI3_DECLARATIONS"]

FMI3_DECLARATIONS = r"""#include <stdbool.h>
#include <stdint.h>
#ifdef OBSERVER_CAD_FMI3_HEADERS
#include "fmi3Functions.h"
#else
typedef void* fmi3Instance;
typedef void* fmi3InstanceEnvironment;
typedef void* fmi3FMUState;
typedef uint32_t fmi3ValueReference;
typedef float fmi3Float32;
typedef double fmi3Float64;
typedef int8_t fmi3Int8;
typedef uint8_t fmi3UInt8;
typedef int16_t fmi3Int16;
typedef uint16_t fmi3UInt16;
typedef int32_t fmi3Int32;
typedef uint32_t fmi3UInt32;
typedef int64_t fmi3Int64;
typedef uint64_t fmi3UInt64;
typedef bool fmi3Boolean;
typedef char fmi3Char;
typedef const fmi3Char* fmi3String;
typedef uint8_t fmi3Byte;
typedef const fmi3Byte* fmi3Binary;
typedef bool fmi3Clock;
typedef enum { fmi3OK, fmi3Warning, fmi3Discard, fmi3Error, fmi3Fatal } fmi3Status;
typedef enum { fmi3Independent, fmi3Constant, fmi3Fixed, fmi3Tunable, fmi3Discrete,
               fmi3Dependent } fmi3DependencyKind;
typedef enum { fmi3IntervalNotYetKnown, fmi3IntervalUnchanged,
               fmi3IntervalChanged } fmi3IntervalQualifier;
typedef void (*fmi3LogMessageCallback)(fmi3InstanceEnvironment, fmi3Status, fmi3String,
                                       fmi3String);
typedef void (*fmi3ClockUpdateCallback)(fmi3InstanceEnvironment);
typedef void (*fmi3IntermediateUpdateCallback)(fmi3InstanceEnvironment, fmi3Float64,
    fmi3Boolean, fmi3Boolean, fmi3Boolean, fmi3Boolean, fmi3Boolean*, fmi3Float64*);
typedef void (*fmi3LockPreemptionCallback)(void);
typedef void (*fmi3UnlockPreemptionCallback)(void);
#endif
#if defined(__GNUC__)
#define FMI3_EXPORT __attribute__((visibility("default")))
#else
#define FMI3_EXPORT
#endif
"""

_VR = "const fmi3ValueReference valueReferences[], size_t nValueReferences"

#: the functions this wrapper does not support: (name, parameters after the instance)
_UNSUPPORTED = [
    ("fmi3InstantiateModelExchange", None),
    ("fmi3InstantiateScheduledExecution", None),
    ("fmi3EnterEventMode", ""),
    ("fmi3GetFloat32", f"{_VR}, fmi3Float32 values[], size_t nValues"),
    *[(f"fmi3Get{t}", f"{_VR}, fmi3{t} values[], size_t nValues")
      for t in ("Int8", "UInt8", "Int16", "UInt16", "UInt32", "Int64", "UInt64")],
    ("fmi3GetString", f"{_VR}, fmi3String values[], size_t nValues"),
    ("fmi3GetBinary", f"{_VR}, size_t valueSizes[], fmi3Binary values[], size_t nValues"),
    ("fmi3GetClock", f"{_VR}, fmi3Clock values[]"),
    ("fmi3SetFloat32", f"{_VR}, const fmi3Float32 values[], size_t nValues"),
    *[(f"fmi3Set{t}", f"{_VR}, const fmi3{t} values[], size_t nValues")
      for t in ("Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64",
                "Boolean")],
    ("fmi3SetString", f"{_VR}, const fmi3String values[], size_t nValues"),
    ("fmi3SetBinary", f"{_VR}, const size_t valueSizes[], const fmi3Binary values[],"
                      " size_t nValues"),
    ("fmi3SetClock", f"{_VR}, const fmi3Clock values[]"),
    ("fmi3GetNumberOfVariableDependencies",
     "fmi3ValueReference valueReference, size_t* nDependencies"),
    ("fmi3GetVariableDependencies",
     "fmi3ValueReference dependent, size_t elementIndicesOfDependent[],"
     " fmi3ValueReference independents[], size_t elementIndicesOfIndependents[],"
     " fmi3DependencyKind dependencyKinds[], size_t nDependencies"),
    ("fmi3GetFMUState", "fmi3FMUState* FMUState"),
    ("fmi3SetFMUState", "fmi3FMUState FMUState"),
    ("fmi3FreeFMUState", "fmi3FMUState* FMUState"),
    ("fmi3SerializedFMUStateSize", "fmi3FMUState FMUState, size_t* size"),
    ("fmi3SerializeFMUState", "fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size"),
    ("fmi3DeserializeFMUState",
     "const fmi3Byte serializedState[], size_t size, fmi3FMUState* FMUState"),
    *[(f"fmi3Get{k}Derivative",
       "const fmi3ValueReference unknowns[], size_t nUnknowns,"
       " const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],"
       " size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity")
      for k in ("Directional", "Adjoint")],
    ("fmi3EnterConfigurationMode", ""),
    ("fmi3ExitConfigurationMode", ""),
    ("fmi3GetIntervalDecimal", f"{_VR}, fmi3Float64 intervals[],"
                               " fmi3IntervalQualifier qualifiers[]"),
    ("fmi3GetIntervalFraction", f"{_VR}, fmi3UInt64 counters[], fmi3UInt64 resolutions[],"
                                " fmi3IntervalQualifier qualifiers[]"),
    ("fmi3GetShiftDecimal", f"{_VR}, fmi3Float64 shifts[]"),
    ("fmi3GetShiftFraction", f"{_VR}, fmi3UInt64 counters[], fmi3UInt64 resolutions[]"),
    ("fmi3SetIntervalDecimal", f"{_VR}, const fmi3Float64 intervals[]"),
    ("fmi3SetIntervalFraction", f"{_VR}, const fmi3UInt64 counters[],"
                                " const fmi3UInt64 resolutions[]"),
    ("fmi3SetShiftDecimal", f"{_VR}, const fmi3Float64 shifts[]"),
    ("fmi3SetShiftFraction", f"{_VR}, const fmi3UInt64 counters[],"
                             " const fmi3UInt64 resolutions[]"),
    ("fmi3EvaluateDiscreteStates", ""),
    ("fmi3UpdateDiscreteStates",
     "fmi3Boolean* discreteStatesNeedUpdate, fmi3Boolean* terminateSimulation,"
     " fmi3Boolean* nominalsOfContinuousStatesChanged,"
     " fmi3Boolean* valuesOfContinuousStatesChanged, fmi3Boolean* nextEventTimeDefined,"
     " fmi3Float64* nextEventTime"),
    ("fmi3EnterContinuousTimeMode", ""),
    ("fmi3CompletedIntegratorStep", "fmi3Boolean noSetFMUStatePriorToCurrentPoint,"
                                    " fmi3Boolean* enterEventMode,"
                                    " fmi3Boolean* terminateSimulation"),
    ("fmi3SetTime", "fmi3Float64 time"),
    ("fmi3SetContinuousStates", "const fmi3Float64 continuousStates[],"
                                " size_t nContinuousStates"),
    ("fmi3GetContinuousStateDerivatives", "fmi3Float64 derivatives[], size_t nContinuousStates"),
    ("fmi3GetEventIndicators", "fmi3Float64 eventIndicators[], size_t nEventIndicators"),
    ("fmi3GetContinuousStates", "fmi3Float64 continuousStates[], size_t nContinuousStates"),
    ("fmi3GetNominalsOfContinuousStates", "fmi3Float64 nominals[], size_t nContinuousStates"),
    ("fmi3GetNumberOfEventIndicators", "size_t* nEventIndicators"),
    ("fmi3GetNumberOfContinuousStates", "size_t* nContinuousStates"),
    ("fmi3EnterStepMode", ""),
    ("fmi3GetOutputDerivatives", f"{_VR}, const fmi3Int32 orders[], fmi3Float64 values[],"
                                 " size_t nValues"),
    ("fmi3ActivateModelPartition", "fmi3ValueReference clockReference,"
                                   " fmi3Float64 activationTime"),
]

_INSTANTIATE_OTHER = {
    "fmi3InstantiateModelExchange": (
        "fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,"
        " fmi3Boolean visible, fmi3Boolean loggingOn,"
        " fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage"),
    "fmi3InstantiateScheduledExecution": (
        "fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,"
        " fmi3Boolean visible, fmi3Boolean loggingOn,"
        " fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage,"
        " fmi3ClockUpdateCallback clockUpdate, fmi3LockPreemptionCallback lockPreemption,"
        " fmi3UnlockPreemptionCallback unlockPreemption"),
}


def _param_names(params: str) -> list:
    out = []
    for p in params.split(","):
        m = re.search(r"([A-Za-z_]\w*)\s*(\[\s*\])?\s*$", p.strip())
        if m:
            out.append(m.group(1))
    return out


def _unsupported_functions() -> str:
    parts = []
    for name, params in _UNSUPPORTED:
        if params is None:   # another interface type: no instance
            params = _INSTANTIATE_OTHER[name]
            voids = " ".join(f"(void){n};" for n in _param_names(params))
            parts.append(f"FMI3_EXPORT fmi3Instance {name}({params}) {{\n  {voids}\n"
                         "  return NULL;   /* co-simulation only */\n}\n")
            continue
        full = "fmi3Instance instance" + (f", {params}" if params else "")
        voids = " ".join(f"(void){n};" for n in _param_names(params)) if params else ""
        parts.append(f"FMI3_EXPORT fmi3Status {name}({full}) {{\n"
                     + (f"  {voids}\n" if voids else "")
                     + f'  return (fmi3Status)fail((Inst*)instance, 3, "{name}: not supported");\n'
                     "}\n")
    return "\n".join(parts)


def fmu3_wrapper_source(name: str, token: str, *, nthr_in: int, dec, sample_time: str,
                        n_real: dict) -> str:
    """The text of ``NAME_fmu.c`` (FMI 3.0); arguments as for
    :func:`fmu_wrapper_source` (``token``: the instantiation token)."""
    core = fmu_core_source(name, token, nthr_in=nthr_in, dec=dec, sample_time=sample_time,
                           n_real=n_real, version="3.0", declarations=FMI3_DECLARATIONS,
                           logger_fields="fmi3LogMessageCallback log_cb;"
                                         " fmi3InstanceEnvironment env;",
                           log_call="if (c->log_cb != NULL) c->log_cb(c->env, (fmi3Status)st,"
                                    ' "logError", msg);')
    return core + _common() + _values() + _unsupported_functions()


def _common() -> str:
    return """#define VR_TIME_ NREAL_
#define VR_CODE_ (NREAL_ + 1)
#define VR_ALARM_ (NREAL_ + 2)

FMI3_EXPORT const char* fmi3GetVersion(void) { return "3.0"; }

FMI3_EXPORT fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn,
                                           size_t nCategories, const fmi3String categories[]) {
  (void)nCategories; (void)categories;
  if (instance == NULL) return fmi3Error;
  ((Inst*)instance)->logging = loggingOn;
  return fmi3OK;
}

FMI3_EXPORT fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName,
    fmi3String instantiationToken, fmi3String resourcePath, fmi3Boolean visible,
    fmi3Boolean loggingOn, fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
    const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate) {
  Inst* c;
  (void)resourcePath; (void)visible; (void)earlyReturnAllowed;
  (void)requiredIntermediateVariables; (void)nRequiredIntermediateVariables;
  (void)intermediateUpdate;
  if (eventModeUsed || instantiationToken == NULL || strcmp(instantiationToken, GUID_) != 0)
    return NULL;   /* hasEventMode is false */
  c = (Inst*)calloc(1, sizeof(Inst));
  if (c == NULL) return NULL;
  c->log_cb = logMessage;
  c->env = instanceEnvironment;
  if (instanceName != NULL) strncpy(c->instance, instanceName, sizeof c->instance - 1);
  c->logging = loggingOn;
  defaults(c);
  return c;
}

FMI3_EXPORT void fmi3FreeInstance(fmi3Instance instance) { free(instance); }

FMI3_EXPORT fmi3Status fmi3EnterInitializationMode(fmi3Instance instance,
    fmi3Boolean toleranceDefined, fmi3Float64 tolerance, fmi3Float64 startTime,
    fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
  Inst* c = (Inst*)instance;
  (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
  if (c == NULL) return fmi3Error;
  if (c->phase != 0)
    return (fmi3Status)fail(c, 3, "fmi3EnterInitializationMode: not instantiated");
  c->t_start = c->time = startTime;
  c->phase = 1;
  return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
  Inst* c = (Inst*)instance;
  if (c == NULL) return fmi3Error;
  if (c->phase != 1)
    return (fmi3Status)fail(c, 3, "fmi3ExitInitializationMode: not initializing");
  if (preview(c) != 0) return fmi3Error;
  c->phase = 2;
  return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3Terminate(fmi3Instance instance) {
  if (instance == NULL) return fmi3Error;
  ((Inst*)instance)->phase = 3;
  return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3Reset(fmi3Instance instance) {
  if (instance == NULL) return fmi3Error;
  defaults((Inst*)instance);
  return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
    fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
    fmi3Boolean* eventHandlingNeeded, fmi3Boolean* terminateSimulation,
    fmi3Boolean* earlyReturn, fmi3Float64* lastSuccessfulTime) {
  Inst* c = (Inst*)instance;
  (void)noSetFMUStatePriorToCurrentPoint;
  if (c == NULL) return fmi3Error;
  if (eventHandlingNeeded != NULL) *eventHandlingNeeded = false;
  if (terminateSimulation != NULL) *terminateSimulation = false;
  if (earlyReturn != NULL) *earlyReturn = false;
  if (do_samples(c, currentCommunicationPoint, communicationStepSize) != 0) return fmi3Error;
  if (lastSuccessfulTime != NULL) *lastSuccessfulTime = c->time;
  return fmi3OK;
}

"""


def _values() -> str:
    return """static int in_init(Inst* c) { return c->phase == 1; }

FMI3_EXPORT fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference vr[],
                                      size_t nvr, fmi3Float64 values[], size_t nValues) {
  Inst* c = (Inst*)instance;
  size_t i;
  if (c == NULL) return fmi3Error;
  if (nValues != nvr) return (fmi3Status)fail(c, 3, "fmi3GetFloat64: nValues != nValueReferences");
  if (in_init(c) && preview(c) != 0) return fmi3Error;
  for (i = 0; i < nvr; ++i) {
    if (vr[i] == VR_TIME_) values[i] = c->time;
    else if (get_real(c, vr[i], &values[i]) != 0) return fmi3Error;
  }
  return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference vr[],
                                      size_t nvr, const fmi3Float64 values[], size_t nValues) {
  Inst* c = (Inst*)instance;
  size_t i;
  if (c == NULL) return fmi3Error;
  if (nValues != nvr) return (fmi3Status)fail(c, 3, "fmi3SetFloat64: nValues != nValueReferences");
  for (i = 0; i < nvr; ++i)
    if (set_real(c, vr[i], values[i]) != 0) return fmi3Error;
  return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference vr[],
                                    size_t nvr, fmi3Int32 values[], size_t nValues) {
  Inst* c = (Inst*)instance;
  size_t i;
  if (c == NULL) return fmi3Error;
  if (nValues != nvr) return (fmi3Status)fail(c, 3, "fmi3GetInt32: nValues != nValueReferences");
  if (in_init(c) && preview(c) != 0) return fmi3Error;
  for (i = 0; i < nvr; ++i) {
    if (vr[i] != VR_CODE_ || NRES_ == 0)
      return (fmi3Status)fail(c, 3, "fmi3GetInt32: unknown value reference");
    values[i] = (fmi3Int32)c->code;
  }
  return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference vr[],
                                      size_t nvr, fmi3Boolean values[], size_t nValues) {
  Inst* c = (Inst*)instance;
  size_t i;
  int a;
  if (c == NULL) return fmi3Error;
  if (nValues != nvr) return (fmi3Status)fail(c, 3, "fmi3GetBoolean: nValues != nValueReferences");
  if (in_init(c) && preview(c) != 0) return fmi3Error;
  for (i = 0; i < nvr; ++i) {
    if (vr[i] < VR_ALARM_ || get_alarm(c, vr[i] - VR_ALARM_, &a) != 0)
      return (fmi3Status)fail(c, 3, "fmi3GetBoolean: unknown value reference");
    values[i] = a != 0;
  }
  return fmi3OK;
}

"""

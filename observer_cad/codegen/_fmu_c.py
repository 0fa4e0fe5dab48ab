"""C text of the FMI 2.0 co-simulation wrapper of an exported observer: ``NAME_fmu.c``.

The wrapper implements every function of the FMI 2.0 co-simulation interface around the
exported step function ``NAME`` (``NAME.c``/``NAME.h``, :func:`export_sources`) and, with
a decision rule, ``NAME_decide``. It declares the FMI 2.0 types and functions it needs
itself (the declarations of the standard's ``fmi2Functions.h``, same names and types),
so it builds with nothing but a C99 compiler; compiled with ``-DOBSERVER_CAD_FMI2_HEADERS``
it includes the standard's headers instead, and the compiler checks every definition
against the standard prototypes (tests/codegen/test_fmu.py does, with FMPy's copies).

Timing (one sample of latency, as the monitor runs on a controller): the samples are
at ``t_start + k·Ts``. ``fmi2DoStep(t, h)`` takes every sample due in ``[t, t + h)``
with the inputs as set: it evaluates the outputs at the current state and inputs,
applies the decision logic (committing the persistence counters) and advances the state
(``NAME``: one sample in discrete time, one RK4 / exact ZOH step of ``Ts`` in
continuous time). The outputs read after the step are those of the last sample taken
and stay until the next sample (zero-order hold), so they never depend directly on
inputs set after it: no algebraic loop in a closed-loop bench. In initialization mode
the outputs preview sample 0 (initial state, current inputs) without counting it.
"""
from __future__ import annotations

__all__ = ["fmu_wrapper_source", "FMI2_DECLARATIONS"]

#: The FMI 2.0 declarations the wrapper needs (types, enums, callbacks), as in the
#: standard's fmi2TypesPlatform.h / fmi2FunctionTypes.h.
FMI2_DECLARATIONS = r"""#ifdef OBSERVER_CAD_FMI2_HEADERS
#include "fmi2Functions.h"
#else
typedef void* fmi2Component;
typedef void* fmi2ComponentEnvironment;
typedef void* fmi2FMUstate;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef char fmi2Char;
typedef const fmi2Char* fmi2String;
typedef char fmi2Byte;
#define fmi2True 1
#define fmi2False 0
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2ModelExchange, fmi2CoSimulation } fmi2Type;
typedef enum { fmi2DoStepStatus, fmi2PendingStatus, fmi2LastSuccessfulTime,
               fmi2Terminated } fmi2StatusKind;
typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment, fmi2String, fmi2Status,
                                   fmi2String, fmi2String, ...);
typedef void* (*fmi2CallbackAllocateMemory)(size_t, size_t);
typedef void (*fmi2CallbackFreeMemory)(void*);
typedef void (*fmi2StepFinished)(fmi2ComponentEnvironment, fmi2Status);
typedef struct {
  const fmi2CallbackLogger logger;
  const fmi2CallbackAllocateMemory allocateMemory;
  const fmi2CallbackFreeMemory freeMemory;
  const fmi2StepFinished stepFinished;
  const fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;
#endif
#if defined(__GNUC__)
#define FMI2_EXPORT __attribute__((visibility("default")))
#else
#define FMI2_EXPORT
#endif
"""


def fmu_wrapper_source(name: str, guid: str, *, nthr_in: int, dec, sample_time: str,
                       n_real: dict) -> str:
    """The text of ``NAME_fmu.c`` (FMI 2.0).

    ``nthr_in``: threshold inputs read after the signals (rule thresholds that are not
    observer outputs); ``dec``: the :class:`~observer_cad.codegen.DecisionSources` or
    None; ``sample_time``: Ts (repr); ``n_real``: offsets of the Real value references
    (``inputs``, ``outputs``, ``params``, ``starts``, ``total``).
    """
    N = name
    core = fmu_core_source(N, guid, nthr_in=nthr_in, dec=dec, sample_time=sample_time,
                           n_real=n_real, version="2.0", declarations=FMI2_DECLARATIONS,
                           logger_fields="fmi2CallbackFunctions cb;",
                           log_call="if (c->cb.logger != NULL) c->cb.logger("
                                    "c->cb.componentEnvironment, c->instance,"
                                    " (fmi2Status)st, \"logError\", msg);")
    return (core + _lifecycle(N) + _getset(N, n_real, dec is not None)
            + _cosim() + _unsupported())


def fmu_core_source(N: str, guid: str, *, nthr_in: int, dec, sample_time: str, n_real: dict,
                    version: str, declarations: str, logger_fields: str, log_call: str) -> str:
    """The part of ``NAME_fmu.c`` every FMI version shares: the instance, the sample
    (step function and decisions), the samples of a communication step, value
    references of the Real variables. Statuses are the FMI numbers (0 OK, 3 error)."""
    nres = f"{N}_NRES" if dec is not None else "0"
    dec_eval = ""
    if dec is not None:
        lines = []
        for i, (ri, (lo, hi)) in enumerate(zip(dec.residual_index, dec.thresholds)):
            src = [f"c->out[{v}]" if k == "out" else
                   f"c->v[NSIG + {dec.input_columns.index(v)}]" for k, v in (lo, hi)]
            lines.append(f"  rr[{i}] = c->out[{ri}]; lo[{i}] = {src[0]}; hi[{i}] = {src[1]};")
        dec_eval = ("  {\n    double rr[NRES_], lo[NRES_], hi[NRES_];\n"
                    + "\n".join("  " + ln for ln in lines) + "\n"
                    f"    for (i = 0; i < NRES_; ++i) cnt[i] = c->counters[i];\n"
                    f"    c->code = {N}_decide(rr, lo, hi, cnt, c->alarms);\n  }}\n")
    return (_head(N, guid, nthr_in, nres, sample_time, n_real, version, declarations,
                  logger_fields, log_call)
            + _sample(N, dec_eval) + _core_functions(N))


def _head(N, guid, nthr_in, nres, sample_time, n_real, version, declarations, logger_fields,
          log_call) -> str:
    v = version[0]
    return f"""/* {N}_fmu.c: FMI {version} co-simulation interface of the observer {N} (see {N}.h),
 * generated by observer_cad. Build (this platform's binary in the FMU was built so):
 *   cc -std=c99 -O2 -fPIC -shared {N}.c {N}_fmu.c -lm -o {N}.so
 * Timing: samples at t_start + k*Ts (Ts = {sample_time}); fmi{v}DoStep(t, h) takes every
 * sample due in [t, t + h) with the inputs as set; outputs read after it are those of the
 * last sample (held; one sample of latency, no direct feedthrough). Initialization mode:
 * outputs preview sample 0 without counting it. */
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "{N}.h"

{declarations}
#define GUID_ "{guid}"
#define TS_ {sample_time}
#define NSIG ({N}_NY + {N}_NU)
#define NIN_ (NSIG + {nthr_in})           /* Real inputs: y, u, threshold inputs */
#define NRES_ {nres}
#define VR_OUT_ {n_real['outputs']}
#define VR_PAR_ {n_real['params']}
#define VR_X0_ {n_real['starts']}
#define NREAL_ {n_real['total']}
#define AS_(n) ((n) > 0 ? (n) : 1)

typedef struct {{
  {logger_fields}
  char instance[128];
  int logging, phase;   /* phase: 0 instantiated, 1 initialization, 2 step, 3 terminated, 4 error */
  double v[AS_(NIN_)], out[AS_({N}_NOUT)], p[AS_({N}_NP)], x0[AS_({N}_NX)];
  double x[AS_({N}_NX)], xn[AS_({N}_NX)];
  int counters[AS_(NRES_)], alarms[AS_(NRES_)], code;
  double t_start, time;
  long k;               /* samples taken */
}} Inst;

/* log msg (no '%' in it) with status st; an error puts the instance in the error state */
static int fail(Inst* c, int st, const char* msg) {{
  if (c == NULL) return st;
  {log_call}
  if (st >= 3) c->phase = 4;
  return st;
}}

"""


def _sample(N, dec_eval) -> str:
    return f"""/* Evaluate the outputs (and decisions) at the current state and inputs; commit: take the
   sample (persistence counters kept, state advanced). 0 on success. */
static int sample(Inst* c, int commit) {{
  const casadi_real* arg[AS_({N}_SZ_ARG)];
  casadi_real* res[AS_({N}_SZ_RES)];
  casadi_int iw[AS_({N}_SZ_IW)];
  casadi_real w[AS_({N}_SZ_W)];
  int i, mem, flag, cnt[AS_(NRES_)];
  for (i = 0; i < AS_({N}_SZ_ARG); ++i) arg[i] = 0;
  for (i = 0; i < AS_({N}_SZ_RES); ++i) res[i] = 0;
  arg[0] = c->x; arg[1] = c->v; arg[2] = c->v + {N}_NY; arg[3] = c->p;
  res[0] = c->xn; res[1] = c->out;
  mem = {N}_checkout();
  flag = {N}(arg, res, iw, w, mem);
  {N}_release(mem);
  if (flag != 0) return flag;
  (void)cnt;
{dec_eval}  if (commit) {{
    for (i = 0; i < NRES_; ++i) c->counters[i] = cnt[i];
    for (i = 0; i < {N}_NX; ++i) c->x[i] = c->xn[i];
    ++c->k;
  }}
  return 0;
}}

"""


def _core_functions(N) -> str:
    return f"""static void defaults(Inst* c) {{
  int i;
  memset(c->v, 0, sizeof c->v);
  memset(c->out, 0, sizeof c->out);
  for (i = 0; i < {N}_NP; ++i) c->p[i] = {N}_p_default[i];
  for (i = 0; i < {N}_NX; ++i) c->x0[i] = c->x[i] = {N}_x0[i];
  for (i = NSIG; i < NIN_; ++i) c->v[i] = NAN;   /* a threshold not set: not out */
  memset(c->counters, 0, sizeof c->counters);
  memset(c->alarms, 0, sizeof c->alarms);
  c->code = 0;
  c->t_start = c->time = 0.0;
  c->k = 0;
  c->phase = 0;
}}

/* the outputs of sample 0 (initial state, current inputs), not counted */
static int preview(Inst* c) {{
  int i;
  for (i = 0; i < {N}_NX; ++i) c->x[i] = c->x0[i];
  return sample(c, 0) != 0 ? fail(c, 3, "the step function failed") : 0;
}}

/* Real value references: [0, NIN_) inputs; [VR_OUT_, VR_PAR_) outputs; [VR_PAR_, VR_X0_)
   parameters (tunable); [VR_X0_, NREAL_) initial state (fixed). */
static double* real_slot(Inst* c, unsigned vr) {{
  long r = (long)vr;   /* signed: no always-true comparison when a range is empty */
  if (r < NIN_) return &c->v[r];
  if (r >= VR_OUT_ && r < VR_PAR_) return &c->out[r - VR_OUT_];
  if (r >= VR_PAR_ && r < VR_X0_) return &c->p[r - VR_PAR_];
  if (r >= VR_X0_ && r < NREAL_) return &c->x0[r - VR_X0_];
  return NULL;
}}

static int get_real(Inst* c, unsigned r, double* value) {{
  double* s = real_slot(c, r);
  if (s == NULL) return fail(c, 3, "get: unknown value reference");
  *value = *s;
  return 0;
}}

static int set_real(Inst* c, unsigned vr, double value) {{
  long r = (long)vr;
  double* s = real_slot(c, vr);
  if (s == NULL || (r >= VR_OUT_ && r < VR_PAR_))
    return fail(c, 3, "set: not an input or parameter");
  if (r >= VR_X0_ && c->phase >= 2)
    return fail(c, 3, "set: the initial state is fixed after initialization");
  *s = value;
  return 0;
}}

/* alarm i (i < NRES_) or any alarm (i == NRES_) */
static int get_alarm(Inst* c, unsigned vr, int* value) {{
  long i = (long)vr;
  if (i < NRES_) *value = c->alarms[i] != 0;
  else if (i == NRES_ && NRES_ > 0) *value = c->code != 0;
  else return fail(c, 3, "get: unknown Boolean value reference");
  return 0;
}}

/* every sample t_start + k*Ts in [t, t + h), with a tolerance of 1e-9 Ts */
static int do_samples(Inst* c, double t, double h) {{
  double end = t + h;
  if (c->phase != 2) return fail(c, 3, "doStep: not in step mode");
  if (!(h > 0.0)) return fail(c, 3, "doStep: the communication step size must be positive");
  while (c->t_start + (double)c->k * TS_ < end - 1e-9 * TS_) {{
    if (sample(c, 1) != 0) return fail(c, 3, "the step function failed");
  }}
  c->time = end;
  return 0;
}}

"""


def _lifecycle(N) -> str:
    return f"""FMI2_EXPORT const char* fmi2GetTypesPlatform(void) {{ return "default"; }}
FMI2_EXPORT const char* fmi2GetVersion(void) {{ return "2.0"; }}

FMI2_EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component comp, fmi2Boolean loggingOn,
                                           size_t nCategories, const fmi2String categories[]) {{
  (void)nCategories; (void)categories;
  if (comp == NULL) return fmi2Error;
  ((Inst*)comp)->logging = loggingOn;
  return fmi2OK;
}}

FMI2_EXPORT fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType,
                                          fmi2String fmuGUID, fmi2String fmuResourceLocation,
                                          const fmi2CallbackFunctions* functions,
                                          fmi2Boolean visible, fmi2Boolean loggingOn) {{
  Inst* c;
  (void)fmuResourceLocation; (void)visible;
  if (fmuType != fmi2CoSimulation || fmuGUID == NULL || strcmp(fmuGUID, GUID_) != 0)
    return NULL;
  c = (Inst*)calloc(1, sizeof(Inst));
  if (c == NULL) return NULL;
  if (functions != NULL) memcpy(&c->cb, functions, sizeof c->cb);
  if (instanceName != NULL) strncpy(c->instance, instanceName, sizeof c->instance - 1);
  c->logging = loggingOn;
  defaults(c);
  return c;
}}

FMI2_EXPORT void fmi2FreeInstance(fmi2Component comp) {{ free(comp); }}

FMI2_EXPORT fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean toleranceDefined,
                                           fmi2Real tolerance, fmi2Real startTime,
                                           fmi2Boolean stopTimeDefined, fmi2Real stopTime) {{
  Inst* c = (Inst*)comp;
  (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
  if (c == NULL) return fmi2Error;
  if (c->phase != 0) return fail(c, fmi2Error, "fmi2SetupExperiment: not instantiated");
  c->t_start = c->time = startTime;
  return fmi2OK;
}}

FMI2_EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component comp) {{
  Inst* c = (Inst*)comp;
  if (c == NULL) return fmi2Error;
  if (c->phase != 0) return fail(c, fmi2Error, "fmi2EnterInitializationMode: not instantiated");
  c->phase = 1;
  return fmi2OK;
}}

FMI2_EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component comp) {{
  Inst* c = (Inst*)comp;
  if (c == NULL) return fmi2Error;
  if (c->phase != 1) return fail(c, fmi2Error, "fmi2ExitInitializationMode: not initializing");
  if (preview(c) != 0) return fmi2Error;
  c->phase = 2;
  return fmi2OK;
}}

FMI2_EXPORT fmi2Status fmi2Terminate(fmi2Component comp) {{
  Inst* c = (Inst*)comp;
  if (c == NULL) return fmi2Error;
  c->phase = 3;
  return fmi2OK;
}}

FMI2_EXPORT fmi2Status fmi2Reset(fmi2Component comp) {{
  Inst* c = (Inst*)comp;
  if (c == NULL) return fmi2Error;
  defaults(c);
  return fmi2OK;
}}

"""


def _getset(N, n_real, has_dec) -> str:
    nalarm = f"({N}_NRES + 1)" if has_dec else "0"
    return f"""static int in_init(Inst* c) {{ return c->phase == 1; }}

FMI2_EXPORT fmi2Status fmi2GetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                   fmi2Real value[]) {{
  Inst* c = (Inst*)comp;
  size_t i;
  if (c == NULL) return fmi2Error;
  if (in_init(c) && preview(c) != 0) return fmi2Error;
  for (i = 0; i < nvr; ++i)
    if (get_real(c, vr[i], &value[i]) != 0) return fmi2Error;
  return fmi2OK;
}}

FMI2_EXPORT fmi2Status fmi2SetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                   const fmi2Real value[]) {{
  Inst* c = (Inst*)comp;
  size_t i;
  if (c == NULL) return fmi2Error;
  for (i = 0; i < nvr; ++i)
    if (set_real(c, vr[i], value[i]) != 0) return fmi2Error;
  return fmi2OK;
}}

/* Integer: value reference 0 = diagnosis_code; Boolean: 0 .. NRES-1 the alarms, NRES alarm */
FMI2_EXPORT fmi2Status fmi2GetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                      fmi2Integer value[]) {{
  Inst* c = (Inst*)comp;
  size_t i;
  if (c == NULL) return fmi2Error;
  if (in_init(c) && preview(c) != 0) return fmi2Error;
  for (i = 0; i < nvr; ++i) {{
    if (vr[i] != 0 || NRES_ == 0)
      return fail(c, fmi2Error, "fmi2GetInteger: unknown value reference");
    value[i] = c->code;
  }}
  return fmi2OK;
}}

FMI2_EXPORT fmi2Status fmi2GetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                      fmi2Boolean value[]) {{
  Inst* c = (Inst*)comp;
  size_t i;
  int a;
  if (c == NULL) return fmi2Error;
  if (in_init(c) && preview(c) != 0) return fmi2Error;
  for (i = 0; i < nvr; ++i) {{
    if (get_alarm(c, vr[i], &a) != 0) return fmi2Error;
    value[i] = a ? fmi2True : fmi2False;
  }}
  (void){nalarm};
  return fmi2OK;
}}

FMI2_EXPORT fmi2Status fmi2SetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                      const fmi2Integer value[]) {{
  (void)vr; (void)value;
  return nvr == 0 ? fmi2OK : fail((Inst*)comp, fmi2Error, "fmi2SetInteger: no Integer inputs");
}}

FMI2_EXPORT fmi2Status fmi2SetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                      const fmi2Boolean value[]) {{
  (void)vr; (void)value;
  return nvr == 0 ? fmi2OK : fail((Inst*)comp, fmi2Error, "fmi2SetBoolean: no Boolean inputs");
}}

FMI2_EXPORT fmi2Status fmi2GetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                     fmi2String value[]) {{
  (void)vr; (void)value;
  return nvr == 0 ? fmi2OK : fail((Inst*)comp, fmi2Error, "fmi2GetString: no String variables");
}}

FMI2_EXPORT fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                     const fmi2String value[]) {{
  (void)vr; (void)value;
  return nvr == 0 ? fmi2OK : fail((Inst*)comp, fmi2Error, "fmi2SetString: no String variables");
}}

"""


def _cosim() -> str:
    return """FMI2_EXPORT fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real currentCommunicationPoint,
                                  fmi2Real communicationStepSize,
                                  fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
  (void)noSetFMUStatePriorToCurrentPoint;
  if (comp == NULL) return fmi2Error;
  return do_samples((Inst*)comp, currentCommunicationPoint, communicationStepSize) == 0
             ? fmi2OK : fmi2Error;
}

FMI2_EXPORT fmi2Status fmi2CancelStep(fmi2Component comp) {
  return fail((Inst*)comp, fmi2Error, "fmi2CancelStep: doStep never returns fmi2Pending");
}

FMI2_EXPORT fmi2Status fmi2GetStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Status* value) {
  (void)s; (void)value;
  return fail((Inst*)comp, fmi2Discard, "fmi2GetStatus: doStep is synchronous");
}

FMI2_EXPORT fmi2Status fmi2GetRealStatus(fmi2Component comp, const fmi2StatusKind s,
                                         fmi2Real* value) {
  Inst* c = (Inst*)comp;
  if (c == NULL) return fmi2Error;
  if (s == fmi2LastSuccessfulTime) {
    *value = c->time;
    return fmi2OK;
  }
  return fmi2Discard;
}

FMI2_EXPORT fmi2Status fmi2GetIntegerStatus(fmi2Component comp, const fmi2StatusKind s,
                                            fmi2Integer* value) {
  (void)comp; (void)s; (void)value;
  return fmi2Discard;
}

FMI2_EXPORT fmi2Status fmi2GetBooleanStatus(fmi2Component comp, const fmi2StatusKind s,
                                            fmi2Boolean* value) {
  (void)comp;
  if (s == fmi2Terminated) {
    *value = fmi2False;
    return fmi2OK;
  }
  return fmi2Discard;
}

FMI2_EXPORT fmi2Status fmi2GetStringStatus(fmi2Component comp, const fmi2StatusKind s,
                                           fmi2String* value) {
  (void)comp; (void)s; (void)value;
  return fmi2Discard;
}

"""


def _unsupported() -> str:
    return """/* not supported (canGetAndSetFMUstate, providesDirectionalDerivative,
   canInterpolateInputs and MaxOutputDerivativeOrder are false/0) */
FMI2_EXPORT fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate* s) {
  (void)s;
  return fail((Inst*)comp, fmi2Error, "FMU states are not supported");
}

FMI2_EXPORT fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate s) {
  (void)s;
  return fail((Inst*)comp, fmi2Error, "FMU states are not supported");
}

FMI2_EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component comp, fmi2FMUstate* s) {
  (void)s;
  return fail((Inst*)comp, fmi2Error, "FMU states are not supported");
}

FMI2_EXPORT fmi2Status fmi2SerializedFMUstateSize(fmi2Component comp, fmi2FMUstate s, size_t* n) {
  (void)s; (void)n;
  return fail((Inst*)comp, fmi2Error, "FMU states are not supported");
}

FMI2_EXPORT fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate s,
                                             fmi2Byte serializedState[], size_t n) {
  (void)s; (void)serializedState; (void)n;
  return fail((Inst*)comp, fmi2Error, "FMU states are not supported");
}

FMI2_EXPORT fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp, const fmi2Byte serializedState[],
                                               size_t n, fmi2FMUstate* s) {
  (void)s; (void)serializedState; (void)n;
  return fail((Inst*)comp, fmi2Error, "FMU states are not supported");
}

FMI2_EXPORT fmi2Status fmi2GetDirectionalDerivative(fmi2Component comp,
    const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
    const fmi2ValueReference vKnown_ref[], size_t nKnown,
    const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
  (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown;
  (void)dvUnknown;
  return fail((Inst*)comp, fmi2Error, "directional derivatives are not provided");
}

FMI2_EXPORT fmi2Status fmi2SetRealInputDerivatives(fmi2Component comp,
    const fmi2ValueReference vr[], size_t nvr, const fmi2Integer order[],
    const fmi2Real value[]) {
  (void)vr; (void)nvr; (void)order; (void)value;
  return fail((Inst*)comp, fmi2Error, "canInterpolateInputs is false");
}

FMI2_EXPORT fmi2Status fmi2GetRealOutputDerivatives(fmi2Component comp,
    const fmi2ValueReference vr[], size_t nvr, const fmi2Integer order[],
    fmi2Real value[]) {
  (void)vr; (void)nvr; (void)order; (void)value;
  return fail((Inst*)comp, fmi2Error, "MaxOutputDerivativeOrder is 0");
}
"""

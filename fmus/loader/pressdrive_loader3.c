/* pressdrive host loader for FMI 3.0: the binary an FMI 3.0 host loads for a toolkit FMU (x86_64-linux).
 *
 * pythonfmu3's wrapper, like pythonfmu's, needs the symbols of libpython but does not link it (and, in a
 * process without Python, would initialise the interpreter of libpython's own prefix, which has neither the
 * toolkit's environment nor numpy).  This file is the FMI 2.0 loader (pressdrive_loader.c, included below
 * with PRESSDRIVE_FMI3 defined) with FMI 3.0's function list: the same recorded environment
 * (resources/pressdrive_python.txt, PRESSDRIVE_LIBPYTHON/_PYTHONHOME/_PYTHONPATH), the same one error line
 * when it is gone, then pythonfmu3's wrapper <modelIdentifier>_pythonfmu3.so loaded next to it and every
 * fmi3* call forwarded.  Python, once initialised here, is never finalised; the wrapper finds it initialised
 * and leaves it alone.
 *
 * The prototypes come from the FMI 3.0 headers (fmi3Functions.h, shipped with pythonfmu3; fmus/build.py puts
 * their folder on the include path), so the compiler checks every forwarder against the standard.
 */
#define _GNU_SOURCE
#include "fmi3Functions.h"

#define PRESSDRIVE_FMI3
#define PRESSDRIVE_EXPORTER "pythonfmu3"

/* every function of the wrapper but fmi3GetVersion (answered here, before anything is loaded) */
#define FMI_FUNCTIONS(X) \
    X(fmi3SetDebugLogging) X(fmi3InstantiateModelExchange) X(fmi3InstantiateCoSimulation) \
    X(fmi3InstantiateScheduledExecution) X(fmi3FreeInstance) X(fmi3EnterInitializationMode) \
    X(fmi3ExitInitializationMode) X(fmi3EnterEventMode) X(fmi3Terminate) X(fmi3Reset) \
    X(fmi3GetFloat32) X(fmi3GetFloat64) X(fmi3GetInt8) X(fmi3GetUInt8) X(fmi3GetInt16) X(fmi3GetUInt16) \
    X(fmi3GetInt32) X(fmi3GetUInt32) X(fmi3GetInt64) X(fmi3GetUInt64) X(fmi3GetBoolean) X(fmi3GetString) \
    X(fmi3GetBinary) X(fmi3GetClock) X(fmi3SetFloat32) X(fmi3SetFloat64) X(fmi3SetInt8) X(fmi3SetUInt8) \
    X(fmi3SetInt16) X(fmi3SetUInt16) X(fmi3SetInt32) X(fmi3SetUInt32) X(fmi3SetInt64) X(fmi3SetUInt64) \
    X(fmi3SetBoolean) X(fmi3SetString) X(fmi3SetBinary) X(fmi3SetClock) \
    X(fmi3GetNumberOfVariableDependencies) X(fmi3GetVariableDependencies) X(fmi3GetFMUState) \
    X(fmi3SetFMUState) X(fmi3FreeFMUState) X(fmi3SerializedFMUStateSize) X(fmi3SerializeFMUState) \
    X(fmi3DeserializeFMUState) X(fmi3GetDirectionalDerivative) X(fmi3GetAdjointDerivative) \
    X(fmi3EnterConfigurationMode) X(fmi3ExitConfigurationMode) X(fmi3GetIntervalDecimal) \
    X(fmi3GetIntervalFraction) X(fmi3GetShiftDecimal) X(fmi3GetShiftFraction) X(fmi3SetIntervalDecimal) \
    X(fmi3SetIntervalFraction) X(fmi3SetShiftDecimal) X(fmi3SetShiftFraction) X(fmi3EvaluateDiscreteStates) \
    X(fmi3UpdateDiscreteStates) X(fmi3EnterContinuousTimeMode) X(fmi3CompletedIntegratorStep) \
    X(fmi3SetTime) X(fmi3SetContinuousStates) X(fmi3GetContinuousStateDerivatives) \
    X(fmi3GetEventIndicators) X(fmi3GetContinuousStates) X(fmi3GetNominalsOfContinuousStates) \
    X(fmi3GetNumberOfEventIndicators) X(fmi3GetNumberOfContinuousStates) X(fmi3EnterStepMode) \
    X(fmi3GetOutputDerivatives) X(fmi3DoStep) X(fmi3ActivateModelPartition)

#include "pressdrive_loader.c"

/* ------------------------------------------------------------------------------------------ FMI 3.0 API */
/* Python and the wrapper ready (once per process); else the one error line through the host's logger */
static int ready3(fmi3String instance, fmi3InstanceEnvironment env, fmi3LogMessageCallback log) {
    char err[2 * PATH_MAX + 512];
    if (ensure_ready(err, sizeof err, &p_fmi3DoStep) != 0) {
        if (log) log(env, fmi3Error, "logStatusError", err);
        else fprintf(stderr, "%s: %s\n", instance ? instance : "pressdrive FMU", err);
        return 0;
    }
    return 1;
}

const char *fmi3GetVersion(void) { return fmi3Version; }

/* the host's logger and intermediate update behind this loader's (pressdrive_loader.c: "the logger between the
 * wrapper and the host"): no NULL string reaches the host */
static void shim_logger3(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    Shim *s = env;
    char text[8192];
    snprintf(text, sizeof text, "%s", message ? message : "");
    if (!shim_text(s, status, text)) return;
    fmi3LogMessageCallback log = s ? (fmi3LogMessageCallback)s->log3 : NULL;
    if (log) log(s->env3, status, category ? category : status_category(status), text);
    else fprintf(stderr, "pressdrive FMU: %s\n", text);
}

static void shim_update3(fmi3InstanceEnvironment env, fmi3Float64 t, fmi3Boolean set, fmi3Boolean get,
                         fmi3Boolean finished, fmi3Boolean early, fmi3Boolean *requested, fmi3Float64 *when) {
    Shim *s = env;
    ((fmi3IntermediateUpdateCallback)s->update3)(s->env3, t, set, get, finished, early, requested, when);
}

static Shim *shim3(fmi3InstanceEnvironment env, fmi3LogMessageCallback log, fmi3IntermediateUpdateCallback update,
                   int logging) {
    Shim *s = new_shim();
    if (!s) return NULL;
    s->host_logging = logging;
    s->env3 = env, s->log3 = (void *)log, s->update3 = (void *)update;
    return s;
}

/* the instance the wrapper made with ``shim`` (its callbacks'), or NULL and the shim gone */
static fmi3Instance made(Shim *shim, fmi3Instance c) {
    bind_shim(shim, c);
    if (!c) drop_shim(NULL);
    return c;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String name, fmi3String token, fmi3String resources,
                                          fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment env, fmi3LogMessageCallback log) {
    if (!ready3(name, env, log)) return NULL;
    Shim *shim = shim3(env, log, NULL, loggingOn);
    return made(shim, ((fmi3InstantiateModelExchangeTYPE *)p_fmi3InstantiateModelExchange)(
        name, token, resources, visible, shim ? fmi3True : loggingOn, shim ? shim : env, shim ? shim_logger3 : log));
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String resources,
                                         fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
                                         fmi3Boolean earlyReturnAllowed, const fmi3ValueReference required[],
                                         size_t nRequired, fmi3InstanceEnvironment env,
                                         fmi3LogMessageCallback log, fmi3IntermediateUpdateCallback update) {
    if (!ready3(name, env, log)) return NULL;
    clear_offer();   /* directional derivatives: pressdrive_loader.c */
    Shim *shim = shim3(env, log, update, loggingOn);
    fmi3Instance c = made(shim, ((fmi3InstantiateCoSimulationTYPE *)p_fmi3InstantiateCoSimulation)(
        name, token, resources, visible, shim ? fmi3True : loggingOn, eventModeUsed, earlyReturnAllowed, required, nRequired,
        shim ? shim : env, shim ? shim_logger3 : log, shim && update ? shim_update3 : update));
    keep_offer(c, name, NULL, env, (void *)log);
    return c;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String name, fmi3String token, fmi3String resources,
                                               fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment env, fmi3LogMessageCallback log,
                                               fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
    if (!ready3(name, env, log)) return NULL;
    return ((fmi3InstantiateScheduledExecutionTYPE *)p_fmi3InstantiateScheduledExecution)(
        name, token, resources, visible, loggingOn, env, log, clockUpdate, lockPreemption, unlockPreemption);
}

void fmi3FreeInstance(fmi3Instance c) {
    if (!c || !p_fmi3FreeInstance) return;
    drop_offer(c);
    ((fmi3FreeInstanceTYPE *)p_fmi3FreeInstance)(c);
    drop_shim(c);
}

/* any other call needs an instance, so the wrapper is loaded by then */
#define FWD3(name, params, args) \
    fmi3Status name params { return ((name##TYPE *)p_##name) args; }

#define VR const fmi3ValueReference vr[], size_t nvr
#define GETTER(name, type) FWD3(name, (fmi3Instance c, VR, type v[], size_t n), (c, vr, nvr, v, n))
#define SETTER(name, type) FWD3(name, (fmi3Instance c, VR, const type v[], size_t n), (c, vr, nvr, v, n))

/* recorded for the loader's logger; the wrapper keeps logging every category (pressdrive_loader.c) */
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cats[]) {
    host_logging(c, on);
    return ((fmi3SetDebugLoggingTYPE *)p_fmi3SetDebugLogging)(c, fmi3True, on ? n : 0, on ? cats : NULL);
}
FWD3(fmi3EnterInitializationMode, (fmi3Instance c, fmi3Boolean tolDef, fmi3Float64 tol, fmi3Float64 t0,
                                   fmi3Boolean stopDef, fmi3Float64 t1), (c, tolDef, tol, t0, stopDef, t1))
FWD3(fmi3ExitInitializationMode, (fmi3Instance c), (c))
FWD3(fmi3EnterEventMode, (fmi3Instance c), (c))
FWD3(fmi3Terminate, (fmi3Instance c), (c))
fmi3Status fmi3Reset(fmi3Instance c) {
    clear_offer();
    fmi3Status status = ((fmi3ResetTYPE *)p_fmi3Reset)(c);
    renew_offer(c);   /* the wrapper made a new slave (pressdrive_loader.c) */
    return status;
}
GETTER(fmi3GetFloat32, fmi3Float32) GETTER(fmi3GetFloat64, fmi3Float64)
GETTER(fmi3GetInt8, fmi3Int8) GETTER(fmi3GetUInt8, fmi3UInt8) GETTER(fmi3GetInt16, fmi3Int16)
GETTER(fmi3GetUInt16, fmi3UInt16) GETTER(fmi3GetInt32, fmi3Int32) GETTER(fmi3GetUInt32, fmi3UInt32)
GETTER(fmi3GetInt64, fmi3Int64) GETTER(fmi3GetUInt64, fmi3UInt64) GETTER(fmi3GetBoolean, fmi3Boolean)
GETTER(fmi3GetString, fmi3String)
FWD3(fmi3GetBinary, (fmi3Instance c, VR, size_t sizes[], fmi3Binary v[], size_t n), (c, vr, nvr, sizes, v, n))
FWD3(fmi3GetClock, (fmi3Instance c, VR, fmi3Clock v[]), (c, vr, nvr, v))
SETTER(fmi3SetFloat32, fmi3Float32) SETTER(fmi3SetFloat64, fmi3Float64)
SETTER(fmi3SetInt8, fmi3Int8) SETTER(fmi3SetUInt8, fmi3UInt8) SETTER(fmi3SetInt16, fmi3Int16)
SETTER(fmi3SetUInt16, fmi3UInt16) SETTER(fmi3SetInt32, fmi3Int32) SETTER(fmi3SetUInt32, fmi3UInt32)
SETTER(fmi3SetInt64, fmi3Int64) SETTER(fmi3SetUInt64, fmi3UInt64) SETTER(fmi3SetBoolean, fmi3Boolean)
SETTER(fmi3SetString, fmi3String)
FWD3(fmi3SetBinary, (fmi3Instance c, VR, const size_t sizes[], const fmi3Binary v[], size_t n),
     (c, vr, nvr, sizes, v, n))
FWD3(fmi3SetClock, (fmi3Instance c, VR, const fmi3Clock v[]), (c, vr, nvr, v))
FWD3(fmi3GetNumberOfVariableDependencies, (fmi3Instance c, fmi3ValueReference r, size_t *n), (c, r, n))
FWD3(fmi3GetVariableDependencies, (fmi3Instance c, fmi3ValueReference dep, size_t iDep[], fmi3ValueReference ind[],
                                   size_t iInd[], fmi3DependencyKind kinds[], size_t n),
     (c, dep, iDep, ind, iInd, kinds, n))
FWD3(fmi3GetFMUState, (fmi3Instance c, fmi3FMUState *s), (c, s))
FWD3(fmi3SetFMUState, (fmi3Instance c, fmi3FMUState s), (c, s))
FWD3(fmi3FreeFMUState, (fmi3Instance c, fmi3FMUState *s), (c, s))
FWD3(fmi3SerializedFMUStateSize, (fmi3Instance c, fmi3FMUState s, size_t *size), (c, s, size))
FWD3(fmi3SerializeFMUState, (fmi3Instance c, fmi3FMUState s, fmi3Byte b[], size_t size), (c, s, b, size))
FWD3(fmi3DeserializeFMUState, (fmi3Instance c, const fmi3Byte b[], size_t size, fmi3FMUState *s), (c, b, size, s))
/* the slave's answer (pressdrive_loader.c, "Directional derivatives"); the wrapper's for a slave that offered none.
 * The toolkit's variables are scalars, so there is one seed per known and one sensitivity per unknown. */
fmi3Status fmi3GetDirectionalDerivative(fmi3Instance c, const fmi3ValueReference unknowns[], size_t nu,
                                        const fmi3ValueReference knowns[], size_t nk, const fmi3Float64 seed[],
                                        size_t ns, fmi3Float64 sens[], size_t nsens) {
    Derivatives d;
    char err[1024];
    if (!find_offer(c, &d))
        return ((fmi3GetDirectionalDerivativeTYPE *)p_fmi3GetDirectionalDerivative)(
            c, unknowns, nu, knowns, nk, seed, ns, sens, nsens);
    if (ns != nk || nsens != nu)
        snprintf(err, sizeof err, "fmi3GetDirectionalDerivative: %zu seed values for %zu knowns and %zu sensitivities "
                 "for %zu unknowns (every variable is a scalar)", ns, nk, nsens, nu);
    else if (directional_derivative(d.call, unknowns, nu, knowns, nk, seed, sens, err, sizeof err) == 0)
        return fmi3OK;
    fmi3LogMessageCallback log = (fmi3LogMessageCallback)d.log3;
    if (log) log(d.env3, fmi3Error, "logStatusError", err);
    else fprintf(stderr, "%s: %s\n", d.name, err);
    return fmi3Error;
}
FWD3(fmi3GetAdjointDerivative, (fmi3Instance c, const fmi3ValueReference unknowns[], size_t nu,
                                const fmi3ValueReference knowns[], size_t nk, const fmi3Float64 seed[], size_t ns,
                                fmi3Float64 sens[], size_t nsens),
     (c, unknowns, nu, knowns, nk, seed, ns, sens, nsens))
FWD3(fmi3EnterConfigurationMode, (fmi3Instance c), (c))
FWD3(fmi3ExitConfigurationMode, (fmi3Instance c), (c))
FWD3(fmi3GetIntervalDecimal, (fmi3Instance c, VR, fmi3Float64 intervals[], fmi3IntervalQualifier q[]),
     (c, vr, nvr, intervals, q))
FWD3(fmi3GetIntervalFraction, (fmi3Instance c, VR, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                               fmi3IntervalQualifier q[]), (c, vr, nvr, counters, resolutions, q))
FWD3(fmi3GetShiftDecimal, (fmi3Instance c, VR, fmi3Float64 shifts[]), (c, vr, nvr, shifts))
FWD3(fmi3GetShiftFraction, (fmi3Instance c, VR, fmi3UInt64 counters[], fmi3UInt64 resolutions[]),
     (c, vr, nvr, counters, resolutions))
FWD3(fmi3SetIntervalDecimal, (fmi3Instance c, VR, const fmi3Float64 intervals[]), (c, vr, nvr, intervals))
FWD3(fmi3SetIntervalFraction, (fmi3Instance c, VR, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]),
     (c, vr, nvr, counters, resolutions))
FWD3(fmi3SetShiftDecimal, (fmi3Instance c, VR, const fmi3Float64 shifts[]), (c, vr, nvr, shifts))
FWD3(fmi3SetShiftFraction, (fmi3Instance c, VR, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]),
     (c, vr, nvr, counters, resolutions))
FWD3(fmi3EvaluateDiscreteStates, (fmi3Instance c), (c))
FWD3(fmi3UpdateDiscreteStates, (fmi3Instance c, fmi3Boolean *needUpdate, fmi3Boolean *terminate,
                                fmi3Boolean *nominalsChanged, fmi3Boolean *valuesChanged, fmi3Boolean *nextDefined,
                                fmi3Float64 *next), (c, needUpdate, terminate, nominalsChanged, valuesChanged,
                                                     nextDefined, next))
FWD3(fmi3EnterContinuousTimeMode, (fmi3Instance c), (c))
FWD3(fmi3CompletedIntegratorStep, (fmi3Instance c, fmi3Boolean noPrior, fmi3Boolean *enterEventMode,
                                   fmi3Boolean *terminate), (c, noPrior, enterEventMode, terminate))
FWD3(fmi3SetTime, (fmi3Instance c, fmi3Float64 t), (c, t))
FWD3(fmi3SetContinuousStates, (fmi3Instance c, const fmi3Float64 x[], size_t n), (c, x, n))
FWD3(fmi3GetContinuousStateDerivatives, (fmi3Instance c, fmi3Float64 dx[], size_t n), (c, dx, n))
FWD3(fmi3GetEventIndicators, (fmi3Instance c, fmi3Float64 z[], size_t n), (c, z, n))
FWD3(fmi3GetContinuousStates, (fmi3Instance c, fmi3Float64 x[], size_t n), (c, x, n))
FWD3(fmi3GetNominalsOfContinuousStates, (fmi3Instance c, fmi3Float64 nominals[], size_t n), (c, nominals, n))
FWD3(fmi3GetNumberOfEventIndicators, (fmi3Instance c, size_t *n), (c, n))
FWD3(fmi3GetNumberOfContinuousStates, (fmi3Instance c, size_t *n), (c, n))
FWD3(fmi3EnterStepMode, (fmi3Instance c), (c))
FWD3(fmi3GetOutputDerivatives, (fmi3Instance c, VR, const fmi3Int32 orders[], fmi3Float64 v[], size_t n),
     (c, vr, nvr, orders, v, n))
FWD3(fmi3DoStep, (fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean noPrior, fmi3Boolean *eventNeeded,
                  fmi3Boolean *terminate, fmi3Boolean *earlyReturn, fmi3Float64 *lastTime),
     (c, t, h, noPrior, eventNeeded, terminate, earlyReturn, lastTime))
FWD3(fmi3ActivateModelPartition, (fmi3Instance c, fmi3ValueReference clock, fmi3Float64 t), (c, clock, t))

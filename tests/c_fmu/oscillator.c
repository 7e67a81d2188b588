/*
 * Damped mass-spring oscillator: a small, self-contained FMI 2.0 co-simulation FMU written in plain C.
 *
 * It exists to test that the toolkit's master (harness/) runs ANY FMI 2.0 co-simulation FMU, not only the
 * pythonfmu FMUs the toolkit builds (tests/test_c_fmu.py compiles it with gcc and zips it into an .fmu).
 *
 *     m * x'' = F - k * x - d * x'          x(0) = x0, x'(0) = v0
 *
 * Variables (value references, see modelDescription.xml):
 *     0 m     [kg]     parameter, > 0          4 v0    [m/s]  parameter (start speed)
 *     1 k     [N/m]    parameter, >= 0         5 h_max [s]    parameter, > 0: largest internal step
 *     2 d     [N.s/m]  parameter, >= 0         6 F     [N]    input
 *     3 x0    [m]      parameter (start pos.)  7 x     [m]    output      8 v [m/s] output
 * The outputs are the state: they depend on no input directly (ModelStructure dependencies="").
 *
 * Two builds of this one source (tests/test_c_fmu.py makes both):
 *  - "oscillator" (default): canInterpolateInputs="false"; F is held constant over a communication step and
 *    fmi2SetRealInputDerivatives is an error.
 *  - "oscillator_interp" (-DINTERPOLATE_INPUTS; its own GUID): canInterpolateInputs="true".  The master may
 *    set dF/dt (order 1) and d2F/dt2 (order 2) of F with fmi2SetRealInputDerivatives; any other order or
 *    variable is an error.  Over the next step from t0 the force is the polynomial
 *        F(t0 + tau) = F + dF * tau + ddF * tau^2 / 2,
 *    evaluated at the stage times of every RK4 sub-step.  Derivatives apply to the NEXT fmi2DoStep only
 *    (FMI 2.0: inputs and their derivatives are set with respect to the beginning of a communication step):
 *    a successful step resets them to 0, so a master that stops sending them gets a held input, never a
 *    stale slope; F keeps the value the master set.  They are part of the FMU state (rollback).  With
 *    logging on, every derivative received is logged (category logInputDerivatives, fmi2OK) as
 *        "fmi2SetRealInputDerivatives: t = <FMU time>, F order <k> = <value>"   (%.17g: exact in decimal).
 *
 * fmi2DoStep integrates with classical RK4 on n = ceil(h / h_max) EQUAL sub-steps, so the step lands exactly
 * on t + h; the time after the step is t + h as given by the master (never accumulated sub-step by sub-step).
 * fmi2GetFMUstate / fmi2SetFMUstate copy the evolving part of the instance (time, state, parameters, input and
 * its derivatives, mode) so that a master can roll a step back and repeat it; serialization is not supported.
 * Functions this FMU does not support (Integer/Boolean/String variables, input derivatives in the default
 * build, directional derivatives, asynchronous steps, serialization) return fmi2Error with a log message
 * (fmi2OK when called with zero value references).
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#ifdef INTERPOLATE_INPUTS
#define MODEL_GUID "{b2d7e9c4-58a1-4f63-9e0d-7c3a1f5b8e26}"
#define CAN_INTERPOLATE_INPUTS 1
#else
#define MODEL_GUID "{6f1c3a52-9d0e-4b7a-8c21-0b5e3f7d9a41}"
#define CAN_INTERPOLATE_INPUTS 0
#endif

enum { VR_M, VR_K, VR_D, VR_X0, VR_V0, VR_HMAX, VR_F, VR_X, VR_V, N_REAL };

typedef enum { MODE_INSTANTIATED, MODE_INIT, MODE_STEP, MODE_TERMINATED, MODE_ERROR } Mode;

/* Everything that a rollback must restore. */
typedef struct {
    Mode mode;
    double time;
    double r[N_REAL];       /* indexed by value reference */
    double dF[2];           /* dF/dt, d2F/dt2 at the step start for the next step (0 unless interpolating) */
} State;

typedef struct {
    State s;
    char *name;
    int logging;
    fmi2CallbackFunctions cb;
} Instance;

static const double DEFAULTS[N_REAL] = {1.0, 100.0, 0.5, 0.1, 0.0, 1e-4, 1.0, 0.1, 0.0};
static const char *NAMES[N_REAL] = {"m", "k", "d", "x0", "v0", "h_max", "F", "x", "v"};

static void logmsg(Instance *inst, fmi2Status status, const char *category, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

static void logmsg(Instance *inst, fmi2Status status, const char *category, const char *fmt, ...) {
    char buf[512];
    va_list ap;
    if (!inst || !inst->cb.logger) return;
    if (status == fmi2OK && !inst->logging) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    /* pass the text through "%s": the logger formats its message like printf */
    inst->cb.logger(inst->cb.componentEnvironment, inst->name, status, category, "%s", buf);
}

static fmi2Status fail(Instance *inst, const char *function, const char *detail) {
    logmsg(inst, fmi2Error, "logStatusError", "%s: %s", function, detail);
    return fmi2Error;
}

/* Checks a new value of variable vr; returns NULL if admissible, else the requirement text. */
static const char *requirement(unsigned vr, double value) {
    if (!isfinite(value)) return "must be a finite number";
    switch (vr) {
        case VR_M: return value > 0 ? NULL : "must be > 0";
        case VR_K: return value >= 0 ? NULL : "must be >= 0";
        case VR_D: return value >= 0 ? NULL : "must be >= 0";
        case VR_HMAX: return value > 0 ? NULL : "must be > 0";
        default: return NULL;
    }
}

static void initial_state(State *s) {
    memset(s, 0, sizeof *s);
    s->mode = MODE_INSTANTIATED;
    memcpy(s->r, DEFAULTS, sizeof DEFAULTS);
}

/* The force tau seconds after the step start. */
static double force(const State *s, double tau) {
#ifdef INTERPOLATE_INPUTS
    return s->r[VR_F] + (s->dF[0] + 0.5 * s->dF[1] * tau) * tau;
#else
    (void)tau;
    return s->r[VR_F];
#endif
}

static void rhs(const double *r, double F, double x, double v, double *dx, double *dv) {
    *dx = v;
    *dv = (F - r[VR_K] * x - r[VR_D] * v) / r[VR_M];
}

static void advance(State *s, double h) {
    double q = h / s->r[VR_HMAX];
    int n = (int)ceil(q - 1e-9 * q);   /* 1e-3 / 1e-4 is 10.000000000000002: that is 10 sub-steps */
    double dt, x = s->r[VR_X], v = s->r[VR_V];
    int i;
    if (n < 1) n = 1;
    dt = h / n;
    for (i = 0; i < n; i++) {
        double k1x, k1v, k2x, k2v, k3x, k3v, k4x, k4v, tau = i * dt;
        double F0 = force(s, tau), Fm = force(s, tau + 0.5 * dt), F1 = force(s, tau + dt);
        rhs(s->r, F0, x, v, &k1x, &k1v);
        rhs(s->r, Fm, x + 0.5 * dt * k1x, v + 0.5 * dt * k1v, &k2x, &k2v);
        rhs(s->r, Fm, x + 0.5 * dt * k2x, v + 0.5 * dt * k2v, &k3x, &k3v);
        rhs(s->r, F1, x + dt * k3x, v + dt * k3v, &k4x, &k4v);
        x += dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
        v += dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
    }
    s->r[VR_X] = x;
    s->r[VR_V] = v;
}

/* ---------------------------------------------------------------------------------------------------------- */
const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    (void)nCategories; (void)categories;
    if (!c) return fmi2Error;
    ((Instance *)c)->logging = loggingOn ? 1 : 0;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    Instance *inst;
    (void)fmuResourceLocation; (void)visible;
    if (!functions || !functions->allocateMemory || !functions->freeMemory) return NULL;
    if (!instanceName || !instanceName[0]) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, "?", fmi2Error, "logStatusError",
                              "fmi2Instantiate: missing instance name");
        return NULL;
    }
    if (fmuType != fmi2CoSimulation || !fmuGUID || strcmp(fmuGUID, MODEL_GUID) != 0) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError",
                              "fmi2Instantiate: %s",
                              fmuType != fmi2CoSimulation ? "only fmi2CoSimulation is supported"
                                                          : "GUID does not match the model description");
        return NULL;
    }
    inst = (Instance *)functions->allocateMemory(1, sizeof(Instance));
    if (!inst) return NULL;
    inst->name = (char *)functions->allocateMemory(strlen(instanceName) + 1, 1);
    if (!inst->name) {
        functions->freeMemory(inst);
        return NULL;
    }
    strcpy(inst->name, instanceName);
    inst->cb = *functions;
    inst->logging = loggingOn ? 1 : 0;
    initial_state(&inst->s);
    return inst;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (!inst) return;
    inst->cb.freeMemory(inst->name);
    inst->cb.freeMemory(inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    Instance *inst = (Instance *)c;
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    if (!inst) return fmi2Error;
    if (inst->s.mode != MODE_INSTANTIATED) return fail(inst, "fmi2SetupExperiment", "only allowed after fmi2Instantiate");
    inst->s.time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (!inst) return fmi2Error;
    if (inst->s.mode != MODE_INSTANTIATED) return fail(inst, "fmi2EnterInitializationMode", "wrong state");
    inst->s.mode = MODE_INIT;
    inst->s.r[VR_X] = inst->s.r[VR_X0];
    inst->s.r[VR_V] = inst->s.r[VR_V0];
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (!inst) return fmi2Error;
    if (inst->s.mode != MODE_INIT) return fail(inst, "fmi2ExitInitializationMode", "not in initialization mode");
    inst->s.r[VR_X] = inst->s.r[VR_X0];
    inst->s.r[VR_V] = inst->s.r[VR_V0];
    inst->s.mode = MODE_STEP;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (!inst) return fmi2Error;
    if (inst->s.mode != MODE_STEP && inst->s.mode != MODE_INIT)
        return fail(inst, "fmi2Terminate", "not initialized");
    inst->s.mode = MODE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (!inst) return fmi2Error;
    initial_state(&inst->s);
    return fmi2OK;
}

/* ---------------------------------------------------------------------------------------------------------- */
fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    Instance *inst = (Instance *)c;
    size_t i;
    if (!inst) return fmi2Error;
    if (nvr > 0 && (!vr || !value)) return fail(inst, "fmi2GetReal", "NULL argument");
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= N_REAL) {
            logmsg(inst, fmi2Error, "logStatusError", "fmi2GetReal: unknown value reference %u", vr[i]);
            return fmi2Error;
        }
        value[i] = inst->s.r[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    Instance *inst = (Instance *)c;
    size_t i;
    if (!inst) return fmi2Error;
    if (nvr > 0 && (!vr || !value)) return fail(inst, "fmi2SetReal", "NULL argument");
    for (i = 0; i < nvr; i++) {
        const char *req;
        if (vr[i] >= N_REAL) {
            logmsg(inst, fmi2Error, "logStatusError", "fmi2SetReal: unknown value reference %u", vr[i]);
            return fmi2Error;
        }
        if (vr[i] == VR_X || vr[i] == VR_V) {
            logmsg(inst, fmi2Error, "logStatusError", "fmi2SetReal: %s is an output and cannot be set",
                   NAMES[vr[i]]);
            return fmi2Error;
        }
        if (vr[i] != VR_F && inst->s.mode != MODE_INSTANTIATED && inst->s.mode != MODE_INIT) {
            logmsg(inst, fmi2Error, "logStatusError",
                   "fmi2SetReal: parameter %s is fixed and can only be set before initialization ends",
                   NAMES[vr[i]]);
            return fmi2Error;
        }
        if (inst->s.mode == MODE_TERMINATED || inst->s.mode == MODE_ERROR) {
            return fail(inst, "fmi2SetReal", "instance is terminated or failed");
        }
        req = requirement(vr[i], value[i]);
        if (req) {
            logmsg(inst, fmi2Error, "logStatusError", "parameter %s = %g is not admissible: %s",
                   NAMES[vr[i]], value[i], req);
            return fmi2Error;
        }
        inst->s.r[vr[i]] = value[i];
        if (inst->s.mode == MODE_INIT && (vr[i] == VR_X0 || vr[i] == VR_V0))
            inst->s.r[vr[i] == VR_X0 ? VR_X : VR_V] = value[i];
    }
    return fmi2OK;
}

/* No Integer, Boolean or String variables: zero references are fine, anything else is an error. */
#define NO_VARIABLES(fname, type)                                                                          \
    fmi2Status fname(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, type value[]) {           \
        (void)vr; (void)value;                                                                             \
        if (!c) return fmi2Error;                                                                          \
        if (nvr == 0) return fmi2OK;                                                                       \
        return fail((Instance *)c, #fname, "this FMU has no variables of this type");                      \
    }
NO_VARIABLES(fmi2GetInteger, fmi2Integer)
NO_VARIABLES(fmi2GetBoolean, fmi2Boolean)
NO_VARIABLES(fmi2GetString, fmi2String)
NO_VARIABLES(fmi2SetInteger, const fmi2Integer)
NO_VARIABLES(fmi2SetBoolean, const fmi2Boolean)
NO_VARIABLES(fmi2SetString, const fmi2String)

/* ---------------------------------------------------------------------------------------------------------- */
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    Instance *inst = (Instance *)c;
    State *s;
    if (!inst) return fmi2Error;
    if (!FMUstate) return fail(inst, "fmi2GetFMUstate", "NULL argument");
    s = (State *)*FMUstate;
    if (!s) {
        s = (State *)inst->cb.allocateMemory(1, sizeof(State));
        if (!s) return fail(inst, "fmi2GetFMUstate", "out of memory");
        *FMUstate = s;
    }
    *s = inst->s;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    Instance *inst = (Instance *)c;
    if (!inst) return fmi2Error;
    if (!FMUstate) return fail(inst, "fmi2SetFMUstate", "NULL state");
    inst->s = *(const State *)FMUstate;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    Instance *inst = (Instance *)c;
    if (!inst) return fmi2Error;
    if (FMUstate && *FMUstate) {
        inst->cb.freeMemory(*FMUstate);
        *FMUstate = NULL;
    }
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    (void)FMUstate; (void)size;
    return c ? fail((Instance *)c, "fmi2SerializedFMUstateSize", "serialization is not supported") : fmi2Error;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
    (void)FMUstate; (void)serializedState; (void)size;
    return c ? fail((Instance *)c, "fmi2SerializeFMUstate", "serialization is not supported") : fmi2Error;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    (void)serializedState; (void)size; (void)FMUstate;
    return c ? fail((Instance *)c, "fmi2DeSerializeFMUstate", "serialization is not supported") : fmi2Error;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    return c ? fail((Instance *)c, "fmi2GetDirectionalDerivative", "not provided") : fmi2Error;
}

/* ---------------------------------------------------------------------------------------------------------- */
/* Orders 1 and 2 of F (see the top of the file); every entry is checked before any is stored. */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    Instance *inst = (Instance *)c;
    size_t i;
    if (!inst) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    if (!CAN_INTERPOLATE_INPUTS) return fail(inst, "fmi2SetRealInputDerivatives", "canInterpolateInputs is false");
    if (!vr || !order || !value) return fail(inst, "fmi2SetRealInputDerivatives", "NULL argument");
    if (inst->s.mode == MODE_TERMINATED || inst->s.mode == MODE_ERROR)
        return fail(inst, "fmi2SetRealInputDerivatives", "instance is terminated or failed");
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= N_REAL) {
            logmsg(inst, fmi2Error, "logStatusError",
                   "fmi2SetRealInputDerivatives: unknown value reference %u", vr[i]);
            return fmi2Error;
        }
        if (vr[i] != VR_F) {
            logmsg(inst, fmi2Error, "logStatusError",
                   "fmi2SetRealInputDerivatives: %s is not an input (only F has derivatives)", NAMES[vr[i]]);
            return fmi2Error;
        }
        if (order[i] < 1 || order[i] > 2) {
            logmsg(inst, fmi2Error, "logStatusError",
                   "fmi2SetRealInputDerivatives: order %d of F is not supported: must be 1 or 2", (int)order[i]);
            return fmi2Error;
        }
        if (!isfinite(value[i])) {
            logmsg(inst, fmi2Error, "logStatusError",
                   "fmi2SetRealInputDerivatives: F order %d = %g must be a finite number", (int)order[i], value[i]);
            return fmi2Error;
        }
    }
    for (i = 0; i < nvr; i++) {
        inst->s.dF[order[i] - 1] = value[i];
        logmsg(inst, fmi2OK, "logInputDerivatives", "fmi2SetRealInputDerivatives: t = %.17g, F order %d = %.17g",
               inst->s.time, (int)order[i], value[i]);
    }
    return fmi2OK;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr; (void)order; (void)value;
    if (!c) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    return fail((Instance *)c, "fmi2GetRealOutputDerivatives", "maxOutputDerivativeOrder is 0");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    Instance *inst = (Instance *)c;
    double t = currentCommunicationPoint, h = communicationStepSize;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!inst) return fmi2Error;
    if (inst->s.mode != MODE_STEP) return fail(inst, "fmi2DoStep", "not in step mode");
    if (!(h > 0) || !isfinite(h)) {
        logmsg(inst, fmi2Error, "logStatusError", "fmi2DoStep: communicationStepSize = %g must be > 0", h);
        return fmi2Error;
    }
    if (fabs(t - inst->s.time) > 1e-9 * (1.0 + fabs(t))) {
        logmsg(inst, fmi2Error, "logStatusError",
               "fmi2DoStep: currentCommunicationPoint = %.17g differs from the FMU time %.17g", t, inst->s.time);
        return fmi2Error;
    }
#ifdef FAIL_AT  /* tests/test_isolation.py: a broken FMU that crashes, aborts or hangs in doStep at t >= FAIL_AT */
#ifdef FAIL_ONLY_IF_X0_POSITIVE  /* only the instances started at x0 > 0 fail (one FMU, two instances) */
    if (t >= FAIL_AT - 1e-12 && inst->s.r[VR_X0] > 0) {
#else
    if (t >= FAIL_AT - 1e-12) {
#endif
#if FAIL_HOW == 1
        volatile int *nowhere = (volatile int *)0;
        *nowhere = 1;                       /* SIGSEGV */
#elif FAIL_HOW == 2
        abort();                            /* SIGABRT */
#else
        for (volatile unsigned long spin = 0;; spin++) { }   /* never returns */
#endif
    }
#endif
    advance(&inst->s, h);
    if (!isfinite(inst->s.r[VR_X]) || !isfinite(inst->s.r[VR_V])) {
        inst->s.mode = MODE_ERROR;
        return fail(inst, "fmi2DoStep", "the state is no longer finite");
    }
    inst->s.time = t + h;
    inst->s.dF[0] = inst->s.dF[1] = 0.0;  /* input derivatives apply to one step only */
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    return c ? fail((Instance *)c, "fmi2CancelStep", "steps are never asynchronous") : fmi2Error;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    if (!c) return fmi2Error;
    if (s == fmi2DoStepStatus && value) {
        *value = fmi2OK;  /* steps complete synchronously */
        return fmi2OK;
    }
    return fail((Instance *)c, "fmi2GetStatus", "status kind not supported");
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    if (!c) return fmi2Error;
    if (s == fmi2LastSuccessfulTime && value) {
        *value = ((Instance *)c)->s.time;
        return fmi2OK;
    }
    return fail((Instance *)c, "fmi2GetRealStatus", "status kind not supported");
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s; (void)value;
    return c ? fail((Instance *)c, "fmi2GetIntegerStatus", "status kind not supported") : fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    if (!c) return fmi2Error;
    if (s == fmi2Terminated && value) {
        *value = fmi2False;  /* the FMU never asks to end the simulation */
        return fmi2OK;
    }
    return fail((Instance *)c, "fmi2GetBooleanStatus", "status kind not supported");
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s; (void)value;
    return c ? fail((Instance *)c, "fmi2GetStringStatus", "status kind not supported") : fmi2Error;
}

/* A minimal FMI 1.0 co-simulation FMU written for the tests (tests/test_fmi_content.py): one String input
   "u" and one String output "y" that is u (direct feed-through), and a Real output "t", the time.  Its own
   FMI 1.0 types, so it needs no header; only what fmpy's FMU1Slave binds is exported. */
#include <stdlib.h>
#include <string.h>

typedef void *fmiComponent;
typedef unsigned int fmiValueReference;
typedef double fmiReal;
typedef int fmiInteger;
typedef char fmiBoolean;
typedef const char *fmiString;
typedef int fmiStatus;
enum { fmiOK, fmiWarning, fmiDiscard, fmiError, fmiFatal };
typedef struct { void *logger, *allocateMemory, *freeMemory, *stepFinished; } fmiCallbackFunctions;

typedef struct { char *u; double t; } Instance;

#define F(name) Identity1_##name
#define EXPORT __attribute__((visibility("default")))

EXPORT const char *F(fmiGetTypesPlatform)(void) { return "standard32"; }
EXPORT const char *F(fmiGetVersion)(void) { return "1.0"; }
EXPORT fmiStatus F(fmiSetDebugLogging)(fmiComponent c, fmiBoolean on) { (void)c; (void)on; return fmiOK; }

EXPORT fmiComponent F(fmiInstantiateSlave)(fmiString name, fmiString guid, fmiString location, fmiString mime,
                                           fmiReal timeout, fmiBoolean visible, fmiBoolean interactive,
                                           fmiCallbackFunctions functions, fmiBoolean loggingOn) {
    (void)name; (void)guid; (void)location; (void)mime; (void)timeout; (void)visible; (void)interactive;
    (void)functions; (void)loggingOn;
    Instance *i = calloc(1, sizeof(Instance));
    i->u = strdup("");
    return i;
}
EXPORT fmiStatus F(fmiInitializeSlave)(fmiComponent c, fmiReal t0, fmiBoolean stopDefined, fmiReal tStop) {
    (void)stopDefined; (void)tStop; ((Instance *)c)->t = t0; return fmiOK;
}
EXPORT fmiStatus F(fmiTerminateSlave)(fmiComponent c) { (void)c; return fmiOK; }
EXPORT fmiStatus F(fmiResetSlave)(fmiComponent c) { (void)c; return fmiOK; }
EXPORT void F(fmiFreeSlaveInstance)(fmiComponent c) { free(((Instance *)c)->u); free(c); }

EXPORT fmiStatus F(fmiGetReal)(fmiComponent c, const fmiValueReference vr[], size_t n, fmiReal v[]) {
    for (size_t k = 0; k < n; k++) { if (vr[k] != 2) return fmiError; v[k] = ((Instance *)c)->t; }
    return fmiOK;
}
EXPORT fmiStatus F(fmiGetString)(fmiComponent c, const fmiValueReference vr[], size_t n, fmiString v[]) {
    for (size_t k = 0; k < n; k++) { if (vr[k] > 1) return fmiError; v[k] = ((Instance *)c)->u; }
    return fmiOK;
}
EXPORT fmiStatus F(fmiSetString)(fmiComponent c, const fmiValueReference vr[], size_t n, const fmiString v[]) {
    Instance *i = c;
    for (size_t k = 0; k < n; k++) { if (vr[k] != 0) return fmiError; free(i->u); i->u = strdup(v[k]); }
    return fmiOK;
}
#define UNSUPPORTED(name, T) \
    EXPORT fmiStatus F(name)(fmiComponent c, const fmiValueReference vr[], size_t n, T v) { \
        (void)c; (void)vr; (void)n; (void)v; return fmiError; }
UNSUPPORTED(fmiSetReal, const fmiReal *)
UNSUPPORTED(fmiSetInteger, const fmiInteger *)
UNSUPPORTED(fmiSetBoolean, const fmiBoolean *)
UNSUPPORTED(fmiGetInteger, fmiInteger *)
UNSUPPORTED(fmiGetBoolean, fmiBoolean *)
EXPORT fmiStatus F(fmiSetRealInputDerivatives)(fmiComponent c, const fmiValueReference vr[], size_t n,
                                                const fmiInteger o[], const fmiReal v[]) {
    (void)c; (void)vr; (void)n; (void)o; (void)v; return fmiError;
}
EXPORT fmiStatus F(fmiGetRealOutputDerivatives)(fmiComponent c, const fmiValueReference vr[], size_t n,
                                                 const fmiInteger o[], fmiReal v[]) {
    (void)c; (void)vr; (void)n; (void)o; (void)v; return fmiError;
}
EXPORT fmiStatus F(fmiDoStep)(fmiComponent c, fmiReal t, fmiReal h, fmiBoolean newStep) {
    (void)newStep; ((Instance *)c)->t = t + h; return fmiOK;
}
EXPORT fmiStatus F(fmiCancelStep)(fmiComponent c) { (void)c; return fmiError; }
#define STATUS(name, T) EXPORT fmiStatus F(name)(fmiComponent c, int s, T *v) { (void)c; (void)s; (void)v; return fmiDiscard; }
STATUS(fmiGetStatus, fmiStatus)
STATUS(fmiGetRealStatus, fmiReal)
STATUS(fmiGetIntegerStatus, fmiInteger)
STATUS(fmiGetBooleanStatus, fmiBoolean)
STATUS(fmiGetStringStatus, fmiString)

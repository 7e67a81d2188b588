/* pressdrive host loader: the binary an FMI host loads for a toolkit FMU (linux64).
 *
 * pythonfmu's stock wrapper needs the symbols of libpython but does not link it, so it loads only into a
 * process that already runs Python.  This small library stands in front of it (built by fmus/build.py):
 *
 *   - on the first fmi2Instantiate it makes sure a Python of an allowed version is there and started
 *     (pressdrive_python.c: the host's own; a standalone FMU's own interpreter; PRESSDRIVE_LIBPYTHON; the
 *     builder's libpython where it still is; any libpython3.x the dynamic linker finds), then checks in it what
 *     the FMU's code needs (resources/pressdrive_check.py, fmus/hostcheck.py: requirements.txt and the FMU's own
 *     module) before any model code runs;
 *   - it then loads pythonfmu's wrapper, shipped next to it as <modelIdentifier>_pythonfmu.so, with
 *     RTLD_LOCAL and forwards every fmi2* call to it, with its own logger between the wrapper and the host
 *     ("the logger between the wrapper and the host" below: no NULL string reaches the host, warnings and
 *     errors pass with debug logging off);
 *   - when a piece is missing it logs one fmi2Error line through the host's FMI logger (whether or not debug
 *     logging is on), naming what is missing and how to supply it, and fmi2Instantiate returns NULL.
 *
 * A host that already runs Python (FMPy, libcosimpy, ecospy, the harness) keeps its Python: the loader only
 * checks its version and the FMU's needs in it, then forwards.
 *
 * Directional derivatives: pythonfmu's wrappers answer fmi2GetDirectionalDerivative (fmi3...) "not supported".
 * The loader answers them itself from the slave: a toolkit slave, while the wrapper constructs it, offers its
 * directional_derivative(unknowns, knowns, seed) in the module _pressdrive_directional_derivatives (see
 * fmus/wrapper_glue.py: LOADER_BRIDGE); right after the wrapper's fmi2Instantiate returns, on the same thread, the
 * loader takes that callable (the slot was emptied just before the call, and the offer must carry the instance's
 * name, so it is this instance's) and keeps it by instance.  fmi2GetDirectionalDerivative then takes the GIL
 * (PyGILState_Ensure, as the wrapper does on every call), calls it with lists of the value references and the
 * seed, and writes the returned floats; a Python exception is one fmi2Error line through the host's logger.  An
 * FMU whose slave offers nothing (a model without output Jacobian) keeps the wrapper's answer.  The Python C API
 * is looked up with dlsym like the rest, so the loader still links no libpython.  Python is never finalised (numpy cannot be
 * re-initialised in one process).
 *
 * The FMI 3.0 loader (pressdrive_loader3.c) is this file compiled with PRESSDRIVE_FMI3 defined: the same
 * environment handling in front of pythonfmu3's wrapper, with its own function list and fmi3* API.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <libgen.h>
#include <limits.h>
#include <pthread.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <wchar.h>

typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef void *fmi2FMUstate;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef char fmi2Char;
typedef const fmi2Char *fmi2String;
typedef char fmi2Byte;
typedef int fmi2Status;   /* fmi2OK 0, fmi2Warning 1, fmi2Discard 2, fmi2Error 3, fmi2Fatal 4, fmi2Pending 5 */
typedef int fmi2Type;
typedef int fmi2StatusKind;

typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
typedef struct {
    fmi2CallbackLogger logger;
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(fmi2ComponentEnvironment, fmi2Status);
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

#define EXPORT __attribute__((visibility("default")))

#ifndef PRESSDRIVE_EXPORTER          /* the Python package whose wrapper this loader stands in front of */
#define PRESSDRIVE_EXPORTER "pythonfmu"
#endif

#include "pressdrive_python.c"        /* the Python the FMU runs on: found, started, checked */

/* ------------------------------------------------------------------------------------------ the wrapper */
#ifndef PRESSDRIVE_FMI3
#define FMI_FUNCTIONS(X) \
    X(fmi2SetDebugLogging) X(fmi2Instantiate) X(fmi2FreeInstance) X(fmi2SetupExperiment) \
    X(fmi2EnterInitializationMode) X(fmi2ExitInitializationMode) X(fmi2Terminate) X(fmi2Reset) \
    X(fmi2GetReal) X(fmi2GetInteger) X(fmi2GetBoolean) X(fmi2GetString) X(fmi2SetReal) X(fmi2SetInteger) \
    X(fmi2SetBoolean) X(fmi2SetString) X(fmi2GetFMUstate) X(fmi2SetFMUstate) X(fmi2FreeFMUstate) \
    X(fmi2SerializedFMUstateSize) X(fmi2SerializeFMUstate) X(fmi2DeSerializeFMUstate) \
    X(fmi2GetDirectionalDerivative) X(fmi2SetRealInputDerivatives) X(fmi2GetRealOutputDerivatives) \
    X(fmi2DoStep) X(fmi2CancelStep) X(fmi2GetStatus) X(fmi2GetRealStatus) X(fmi2GetIntegerStatus) \
    X(fmi2GetBooleanStatus) X(fmi2GetStringStatus)
#endif

#define DECLARE(name) static void *p_##name;
FMI_FUNCTIONS(DECLARE)

static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static int ready = 0;
static void *python = NULL;   /* where the Python C API is looked up (prepare) */

/* ------------------------------------------------------------------------ directional derivatives (header) */
typedef struct PyObject PyObject;   /* opaque: only pointers pass through here */
#define BRIDGE_MODULE "_pressdrive_directional_derivatives"   /* fmus/wrapper_glue.py: LOADER_BRIDGE */

static struct {
    int (*gil_ensure)(void);
    void (*gil_release)(int);
    PyObject *(*import)(const char *);
    PyObject *(*call_method)(PyObject *, const char *, const char *, ...);
    PyObject *(*call_args)(PyObject *, ...);
    PyObject *(*list_new)(ssize_t);
    int (*list_set)(PyObject *, ssize_t, PyObject *);
    PyObject *(*from_ulong)(unsigned long);
    PyObject *(*from_double)(double);
    ssize_t (*size)(PyObject *);
    PyObject *(*item)(PyObject *, ssize_t);
    double (*as_double)(PyObject *);
    PyObject *(*occurred)(void);
    void (*fetch)(PyObject **, PyObject **, PyObject **);
    void (*clear)(void);
    PyObject *(*str)(PyObject *);
    const char *(*utf8)(PyObject *);
    void (*decref)(PyObject *);
    int (*callable)(PyObject *);
    PyObject *(*dict_item)(PyObject *, const char *);
    PyObject *(*call_function)(PyObject *, const char *, ...);
    int bound;
} api;

typedef struct {
    void *instance;               /* the wrapper's instance */
    PyObject *call;               /* the slave's directional_derivative (a reference we own) */
    char name[256];               /* instance name, for messages */
    fmi2CallbackFunctions cb2;    /* FMI 2.0: the host's logger (copied) */
    void *env3, *log3;            /* FMI 3.0: instance environment and fmi3LogMessageCallback */
} Derivatives;

static Derivatives *derivatives = NULL;
static size_t n_derivatives = 0, cap_derivatives = 0;

#ifndef PRESSDRIVE_FMI3
static void log_error(const fmi2CallbackFunctions *cb, fmi2String instance, const char *msg) {
    if (cb && cb->logger) cb->logger(cb->componentEnvironment, instance, 3, "logStatusError", "%s", msg);
    else fprintf(stderr, "%s: %s\n", instance ? instance : "pressdrive FMU", msg);
}
#endif

/* -------------------------------------------------------------- the logger between the wrapper and the host */
/* pythonfmu's wrappers report a Python exception through the host's logger with a NULL category (cppfmu's
 * PyLogger): a host that makes a string of it dies there (OMSimulator 3.0: "terminate called after throwing an
 * instance of 'std::logic_error': basic_string: construction from null", measured on a drive FMU whose
 * initialisation raised).  And with the host's debug logging off they pass nothing on, errors included (FMPy's
 * simulate_fmu then says "fmi2ExitInitializationMode failed" and no more).  So the wrapper gets this loader's
 * logger, always with logging on, and the loader hands the host one "%s" line per message, with the instance
 * name, the category (the status's own where the wrapper gave none) and the text never NULL and on one line:
 * every warning and error, and the rest only while the host asked for debug logging.  One Shim per instance holds
 * the host's callbacks, from instantiation to fmi*FreeInstance. */
typedef struct Shim {
    void *instance;                               /* the wrapper's instance (NULL while it is being made) */
    int host_logging;                             /* the host's debug logging (fmi*Instantiate, fmi*SetDebugLogging) */
    struct Shim *next;
    fmi2CallbackFunctions host2, mine2;           /* FMI 2.0: the host's callbacks, and the wrapper's copy */
    void *env3, *log3, *update3;                  /* FMI 3.0: the host's environment, logger, intermediate update */
} Shim;

static Shim *shims = NULL;

static const char *status_category(int status) {
    static const char *names[] = {"logAll", "logStatusWarning", "logStatusDiscard", "logStatusError",
                                  "logStatusFatal", "logStatusPending"};
    return status >= 0 && status <= 5 ? names[status] : "logAll";
}

static Shim *new_shim(void) {
    Shim *s = calloc(1, sizeof *s);
    if (!s) return NULL;
    pthread_mutex_lock(&lock);
    s->next = shims, shims = s;
    pthread_mutex_unlock(&lock);
    return s;
}

/* the instance the wrapper made with this shim (NULL: it made none, the shim goes) */
static void bind_shim(Shim *s, void *instance) {
    if (!s) return;
    pthread_mutex_lock(&lock);
    s->instance = instance;
    pthread_mutex_unlock(&lock);
}

/* the host's debug logging of ``instance``, recorded (the wrapper keeps logging everything) */
static void host_logging(void *instance, int on) {
    pthread_mutex_lock(&lock);
    for (Shim *p = shims; p; p = p->next)
        if (p->instance == instance) p->host_logging = on;
    pthread_mutex_unlock(&lock);
}

/* the message as one line of text; 0 when the host does not want it (a debug message with its logging off) */
static int shim_text(const Shim *s, int status, char *text) {
    for (char *c = text; *c; c++)
        if (*c == '\n' || *c == '\r') *c = ' ';
    return status > 0 || !s || s->host_logging;
}

static void drop_shim(void *instance) {
    Shim *gone = NULL;
    pthread_mutex_lock(&lock);
    for (Shim **p = &shims; *p; p = &(*p)->next)
        if ((*p)->instance == instance) { gone = *p; *p = gone->next; break; }
    pthread_mutex_unlock(&lock);
    free(gone);
}

#ifndef PRESSDRIVE_FMI3
static void shim_logger2(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                         fmi2String message, ...) {
    Shim *s = env;
    char text[8192];
    va_list ap;
    va_start(ap, message);
    vsnprintf(text, sizeof text, message ? message : "", ap);
    va_end(ap);
    if (!shim_text(s, status, text)) return;
    if (s && s->host2.logger)
        s->host2.logger(s->host2.componentEnvironment, name ? name : "", status,
                        category ? category : status_category(status), "%s", text);
    else
        fprintf(stderr, "%s: %s\n", name ? name : "pressdrive FMU", text);
}

/* the callbacks the wrapper gets for an instance: the host's, with this loader's logger (NULL: out of memory) */
static Shim *shim2(const fmi2CallbackFunctions *host, int logging) {
    Shim *s = host ? new_shim() : NULL;
    if (!s) return NULL;
    s->host_logging = logging;
    s->host2 = *host;
    s->mine2 = *host;
    s->mine2.logger = shim_logger2;
    s->mine2.componentEnvironment = s;
    return s;
}
#endif

/* pythonfmu's wrappers (0.7 for FMI 2.0, pythonfmu3 0.3.4 for FMI 3.0) keep their interpreter handle in a
 * namespace-scope std::shared_ptr and clear it again from an __attribute__((destructor)) function,
 * finalizePythonInterpreter: at exit the C++ destructor of the shared_ptr runs first (an exit handler), then
 * the library's destructor assigns to the destroyed object and releases its control block a second time
 * (valgrind: invalid read in finalizePythonInterpreter).  The corrupted heap then aborts the host at exit,
 * "corrupted double-linked list" or "free(): corrupted unsorted chunks", depending on the heap's layout (a
 * Python host whose FMU failed, a C host).  Registering that same function as an exit handler AFTER the wrapper
 * is loaded makes it run first, while the object is alive; the two later calls then find it empty.  ``symbol``:
 * any function of the loaded wrapper. */
static void clear_wrapper_state_first_at_exit(void *symbol) {
    Dl_info info;
    if (!symbol || !dladdr(symbol, &info) || !info.dli_fname) return;
    void *w = dlopen(info.dli_fname, RTLD_NOW | RTLD_NOLOAD);
    void (*clear)(void) = w ? (void (*)(void))dlsym(w, "finalizePythonInterpreter") : NULL;
    if (clear) atexit(clear);
}

/* the FMU's root folder (<root>/binaries/<platform>/X.so) and this binary's folder */
static char self[PATH_MAX], root[PATH_MAX], bindir[PATH_MAX];

static int locate(char *err, size_t n) {
    Dl_info info;
    if (!dladdr((void *)&locate, &info) || !info.dli_fname || !realpath(info.dli_fname, self)) {
        snprintf(err, n, "pressdrive loader: cannot find its own file");
        return -1;
    }
    snprintf(root, sizeof root, "%s", self);
    for (int i = 0; i < 3; i++) {
        char *d = dirname(root);
        memmove(root, d, strlen(d) + 1);
        if (i == 0) snprintf(bindir, sizeof bindir, "%s", root);
    }
    return 0;
}

/* Python present, of an allowed version and initialised (pressdrive_python.c); 0, else err holds one line. */
static int prepare(char *err, size_t n) {
    char config[PATH_MAX + 64], chosen[2 * PATH_MAX + 64];
    enum origin origin;
    if (locate(err, n) != 0) return -1;
    snprintf(config, sizeof config, "%s/resources/pressdrive_python.txt", root);
    read_config(config);
    if (!cfg.minimum[0]) snprintf(cfg.minimum, sizeof cfg.minimum, "%s", cfg.version);
    void *py = find_python(bindir, chosen, sizeof chosen, &origin, err, n);
    if (!py) return -1;
    python = py;
    const char *(*get_version)(void) = (const char *(*)(void))dlsym(py, "Py_GetVersion");
    int (*is_initialized)(void) = (int (*)(void))dlsym(py, "Py_IsInitialized");
    if (!get_version || !is_initialized) {
        snprintf(err, n, "%s is not a libpython (no Py_GetVersion)", chosen);
        return -1;
    }
    char version[32];
    snprintf(version, sizeof version, "%s", get_version());
    version[strcspn(version, " ")] = 0;
    if (version_number(version) < version_number(cfg.minimum)) {
        snprintf(err, n, "this FMU needs Python %s or newer; the Python of %s is %s: %s", cfg.minimum, chosen,
                 version, origin == FROM_HOST ? "run it from a newer Python (e.g. a virtualenv of Python 3.12 with "
                 "fmpy)" : "set PRESSDRIVE_LIBPYTHON to the libpython of a newer Python");
        return -1;
    }
    if (!is_initialized() && start_python(py, origin, bindir, chosen, err, n) != 0) return -1;
    return 0;
}

/* the exporter's wrapper, shipped next to this binary as <modelIdentifier>_<exporter>.so, loaded and resolved */
static int load_wrapper(char *err, size_t n) {
    char wrapper[PATH_MAX + 32];
    snprintf(wrapper, sizeof wrapper, "%s", self);
    size_t k = strlen(wrapper);
    if (k > 3 && !strcmp(wrapper + k - 3, ".so")) wrapper[k - 3] = 0;
    strncat(wrapper, "_" PRESSDRIVE_EXPORTER ".so", sizeof wrapper - strlen(wrapper) - 1);
    void *w = dlopen(wrapper, RTLD_NOW | RTLD_LOCAL);
    if (!w) {
        snprintf(err, n, "cannot load " PRESSDRIVE_EXPORTER "'s wrapper '%s' (%s)", wrapper, dlerror());
        return -1;
    }
#define RESOLVE(name) \
    if (!(p_##name = dlsym(w, #name))) { snprintf(err, n, "%s lacks %s", wrapper, #name); return -1; }
    FMI_FUNCTIONS(RESOLVE)
    return 0;
}

/* ------------------------------------------------------------------------------- directional derivatives */
/* the Python C API functions the bridge calls; 0 if one is missing (then the wrapper keeps answering) */
static int bind_api(void) {
    if (api.bound) return api.bound > 0;
#define BIND(field, symbol) if (!(*(void **)&api.field = dlsym(python ? python : RTLD_DEFAULT, symbol))) { api.bound = -1; return 0; }
    BIND(gil_ensure, "PyGILState_Ensure") BIND(gil_release, "PyGILState_Release")
    BIND(import, "PyImport_ImportModule") BIND(call_method, "PyObject_CallMethod")
    BIND(call_args, "PyObject_CallFunctionObjArgs") BIND(list_new, "PyList_New") BIND(list_set, "PyList_SetItem")
    BIND(from_ulong, "PyLong_FromUnsignedLong") BIND(from_double, "PyFloat_FromDouble")
    BIND(size, "PySequence_Size") BIND(item, "PySequence_GetItem") BIND(as_double, "PyFloat_AsDouble")
    BIND(occurred, "PyErr_Occurred") BIND(fetch, "PyErr_Fetch") BIND(clear, "PyErr_Clear")
    BIND(str, "PyObject_Str") BIND(utf8, "PyUnicode_AsUTF8") BIND(decref, "Py_DecRef")
    BIND(callable, "PyCallable_Check") BIND(dict_item, "PyDict_GetItemString")
    BIND(call_function, "PyObject_CallFunction")
#undef BIND
    api.bound = 1;
    return 1;
}

static void decref(PyObject *o) { if (o) api.decref(o); }

/* the pending Python error as one line in err (and cleared) */
static void python_error(char *err, size_t n) {
    PyObject *type = NULL, *value = NULL, *tb = NULL;
    api.fetch(&type, &value, &tb);
    PyObject *text = value ? api.str(value) : NULL;
    const char *s = text ? api.utf8(text) : NULL;
    snprintf(err, n, "%s", s ? s : "Python error without a message");
    if (!s) api.clear();
    decref(text); decref(type); decref(value); decref(tb);
}

/* The slave's offer under this thread's id (a new reference) if it is instance ``name``'s, else NULL.  With the
 * GIL held.  take() pops the slot, so calling it before the wrapper's instantiate empties it of any stale offer
 * (a slave constructed in this thread outside this loader, e.g. in process). */
static PyObject *take_offer(const char *name) {
    PyObject *bridge = api.import(BRIDGE_MODULE);
    if (!bridge) { api.clear(); return NULL; }   /* no toolkit slave has offered anything in this process */
    PyObject *offer = api.call_method(bridge, "take", NULL);
    decref(bridge);
    if (!offer) { api.clear(); return NULL; }
    PyObject *call = NULL;
    if (api.size(offer) == 2) {     /* (instance name, directional_derivative) */
        PyObject *who = api.item(offer, 0), *fn = api.item(offer, 1);
        const char *s = who ? api.utf8(who) : NULL;
        if (s && name && !strcmp(s, name) && fn && api.callable(fn)) { call = fn; fn = NULL; }
        decref(who); decref(fn);
    }
    if (api.occurred()) api.clear();   /* None has no length: nothing offered */
    decref(offer);
    return call;
}

static void clear_offer(void) {
    if (!bind_api()) return;
    int g = api.gil_ensure();
    decref(take_offer(NULL));
    api.gil_release(g);
}

/* after the wrapper made ``instance``: keep the slave's directional derivative, if it offered one */
static void keep_offer(void *instance, const char *name, const fmi2CallbackFunctions *cb2, void *env3, void *log3) {
    if (!instance || !bind_api()) return;
    int g = api.gil_ensure();
    PyObject *call = take_offer(name);
    api.gil_release(g);
    if (!call) return;
    pthread_mutex_lock(&lock);
    if (n_derivatives == cap_derivatives) {
        size_t cap = cap_derivatives ? 2 * cap_derivatives : 16;
        Derivatives *d = realloc(derivatives, cap * sizeof *d);
        if (!d) { pthread_mutex_unlock(&lock); g = api.gil_ensure(); decref(call); api.gil_release(g); return; }
        derivatives = d, cap_derivatives = cap;
    }
    Derivatives *e = &derivatives[n_derivatives++];
    memset(e, 0, sizeof *e);
    e->instance = instance, e->call = call, e->env3 = env3, e->log3 = log3;
    snprintf(e->name, sizeof e->name, "%s", name ? name : "");
    if (cb2) e->cb2 = *cb2;
    pthread_mutex_unlock(&lock);
}

/* copy of the entry of ``instance`` (0 if it has none) */
static int find_offer(void *instance, Derivatives *out) {
    int found = 0;
    pthread_mutex_lock(&lock);
    for (size_t i = 0; i < n_derivatives; i++)
        if (derivatives[i].instance == instance) { *out = derivatives[i]; found = 1; break; }
    pthread_mutex_unlock(&lock);
    return found;
}

/* after the wrapper's Reset, which constructs a new slave for the instance (pythonfmu's and pythonfmu3's
 * PySlaveInstance::Reset call initialize() again): keep the new slave's offer, or none (never the old slave's) */
static void renew_offer(void *instance) {
    Derivatives d;
    if (!find_offer(instance, &d)) return;
    int g = api.gil_ensure();
    PyObject *call = take_offer(d.name), *old = NULL;
    api.gil_release(g);
    pthread_mutex_lock(&lock);
    for (size_t i = 0; i < n_derivatives; i++)
        if (derivatives[i].instance == instance) {
            old = derivatives[i].call;
            if (call) derivatives[i].call = call;
            else derivatives[i] = derivatives[--n_derivatives];
            break;
        }
    pthread_mutex_unlock(&lock);
    if (old) { g = api.gil_ensure(); decref(old); api.gil_release(g); }
}

static void drop_offer(void *instance) {
    PyObject *call = NULL;
    pthread_mutex_lock(&lock);
    for (size_t i = 0; i < n_derivatives; i++)
        if (derivatives[i].instance == instance) {
            call = derivatives[i].call;
            derivatives[i] = derivatives[--n_derivatives];
            break;
        }
    pthread_mutex_unlock(&lock);
    if (call) { int g = api.gil_ensure(); decref(call); api.gil_release(g); }
}

/* sensitivity[i] = sum_j d unknowns[i] / d knowns[j] * seed[j] from the slave; 0, else err holds one line */
static int directional_derivative(PyObject *call, const unsigned int unknowns[], size_t nu, const unsigned int knowns[],
                                  size_t nk, const double seed[], double sensitivity[], char *err, size_t n) {
    int rc = -1, g = api.gil_ensure();
    PyObject *lu = api.list_new((ssize_t)nu), *lk = api.list_new((ssize_t)nk), *ls = api.list_new((ssize_t)nk);
    PyObject *result = NULL;
    if (!lu || !lk || !ls) goto python_failed;
    for (size_t i = 0; i < nu; i++) api.list_set(lu, (ssize_t)i, api.from_ulong(unknowns[i]));
    for (size_t j = 0; j < nk; j++) {
        api.list_set(lk, (ssize_t)j, api.from_ulong(knowns[j]));
        api.list_set(ls, (ssize_t)j, api.from_double(seed[j]));
    }
    if (api.occurred()) goto python_failed;
    result = api.call_args(call, lu, lk, ls, NULL);
    if (!result) goto python_failed;
    if (api.size(result) != (ssize_t)nu) {
        if (api.occurred()) api.clear();
        snprintf(err, n, "directional_derivative returned no sequence of %zu values", nu);
        goto done;
    }
    for (size_t i = 0; i < nu; i++) {
        PyObject *v = api.item(result, (ssize_t)i);
        sensitivity[i] = v ? api.as_double(v) : 0.0;
        decref(v);
        if (api.occurred()) goto python_failed;
    }
    rc = 0;
    goto done;
python_failed:
    python_error(err, n);
done:
    decref(result); decref(lu); decref(lk); decref(ls);
    api.gil_release(g);
    return rc;
}

/* resources/pressdrive_check.py (fmus/hostcheck.py): what the FMU's code needs, checked in the Python found by
 * prepare() before the wrapper runs any of it: "" when everything is there, else one line for err.  The script runs
 * in a namespace of its own (runpy.run_path), so nothing of it stays in the host's modules. */
static int run_check(char *err, size_t n) {
    char script[PATH_MAX + 64], resources[PATH_MAX + 16];
    snprintf(script, sizeof script, "%s/resources/pressdrive_check.py", root);
    snprintf(resources, sizeof resources, "%s/resources", root);
    if (!file_exists(script)) return 0;   /* an FMU without its check (not built by this toolkit's build) */
    if (!bind_api()) {
        snprintf(err, n, "the Python of this process lacks a function of its C API the loader calls");
        return -1;
    }
    int rc = -1, g = api.gil_ensure();
    PyObject *runpy = api.import("runpy"), *ns = NULL, *answer = NULL;
    if (runpy) ns = api.call_method(runpy, "run_path", "s", script);
    PyObject *check = ns ? api.dict_item(ns, "check") : NULL;   /* borrowed */
    if (check) answer = api.call_function(check, "s", resources);
    const char *text = answer ? api.utf8(answer) : NULL;
    if (!text) {
        char why[512];
        python_error(why, sizeof why);
        snprintf(err, n, "this FMU's check of its Python (resources/pressdrive_check.py) failed: %s", why);
    } else if (*text) {
        snprintf(err, n, "%s", text);
    } else {
        rc = 0;
    }
    decref(answer); decref(ns); decref(runpy);
    api.gil_release(g);
    return rc;
}

/* Python and the wrapper ready, once per process (either FMI version's instantiation calls it): 0 when ready,
 * else -1 with the reason in err; ``step``: where prepare() puts the wrapper's doStep symbol (read after it,
 * for clear_wrapper_state_first_at_exit) */
static int ensure_ready(char *err, size_t n, void *const *step) {
    int rc = 0;
    pthread_mutex_lock(&lock);
    if (!ready) {
        err[0] = 0;
        if (prepare(err, n) != 0 || run_check(err, n) != 0 || load_wrapper(err, n) != 0) {
            rc = -1;
        } else {
            clear_wrapper_state_first_at_exit(*step);
            ready = 1;
        }
    }
    pthread_mutex_unlock(&lock);
    return rc;
}

/* ------------------------------------------------------------------------------------------ FMI 2.0 API */
#ifndef PRESSDRIVE_FMI3
EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
EXPORT const char *fmi2GetVersion(void) { return "2.0"; }

EXPORT fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String guid,
                                     fmi2String resourceLocation, const fmi2CallbackFunctions *functions,
                                     fmi2Boolean visible, fmi2Boolean loggingOn) {
    char err[2 * PATH_MAX + 512];
    if (ensure_ready(err, sizeof err, &p_fmi2DoStep) != 0) {
        log_error(functions, instanceName, err);
        return NULL;
    }
    clear_offer();
    Shim *shim = shim2(functions, loggingOn);
    fmi2Component c = ((fmi2Component (*)(fmi2String, fmi2Type, fmi2String, fmi2String, const fmi2CallbackFunctions *,
                                          fmi2Boolean, fmi2Boolean))p_fmi2Instantiate)(
        instanceName, fmuType, guid, resourceLocation, shim ? &shim->mine2 : functions, visible, shim ? 1 : loggingOn);
    bind_shim(shim, c);
    if (!c) drop_shim(NULL);
    keep_offer(c, instanceName, functions, NULL, NULL);
    return c;
}

#define FWD(name, params, args) \
    EXPORT fmi2Status name params { return ((fmi2Status (*) params)p_##name) args; }

/* recorded for the loader's logger; the wrapper keeps logging every category (see "the logger between ...") */
EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cats[]) {
    host_logging(c, on);
    return ((fmi2Status (*)(fmi2Component, fmi2Boolean, size_t, const fmi2String *))p_fmi2SetDebugLogging)(
        c, 1, on ? n : 0, on ? cats : NULL);
}
EXPORT void fmi2FreeInstance(fmi2Component c) {
    if (!c || !p_fmi2FreeInstance) return;
    drop_offer(c);
    ((void (*)(fmi2Component))p_fmi2FreeInstance)(c);
    drop_shim(c);
}
FWD(fmi2SetupExperiment, (fmi2Component c, fmi2Boolean tolDef, fmi2Real tol, fmi2Real t0, fmi2Boolean stopDef, fmi2Real t1),
    (c, tolDef, tol, t0, stopDef, t1))
FWD(fmi2EnterInitializationMode, (fmi2Component c), (c))
FWD(fmi2ExitInitializationMode, (fmi2Component c), (c))
FWD(fmi2Terminate, (fmi2Component c), (c))
EXPORT fmi2Status fmi2Reset(fmi2Component c) {
    clear_offer();
    fmi2Status status = ((fmi2Status (*)(fmi2Component))p_fmi2Reset)(c);
    renew_offer(c);   /* the wrapper made a new slave */
    return status;
}
FWD(fmi2GetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]), (c, vr, n, v))
FWD(fmi2GetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]), (c, vr, n, v))
FWD(fmi2GetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]), (c, vr, n, v))
FWD(fmi2GetString, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]), (c, vr, n, v))
FWD(fmi2SetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]), (c, vr, n, v))
FWD(fmi2SetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]), (c, vr, n, v))
FWD(fmi2SetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]), (c, vr, n, v))
FWD(fmi2SetString, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]), (c, vr, n, v))
FWD(fmi2GetFMUstate, (fmi2Component c, fmi2FMUstate *s), (c, s))
FWD(fmi2SetFMUstate, (fmi2Component c, fmi2FMUstate s), (c, s))
FWD(fmi2FreeFMUstate, (fmi2Component c, fmi2FMUstate *s), (c, s))
FWD(fmi2SerializedFMUstateSize, (fmi2Component c, fmi2FMUstate s, size_t *size), (c, s, size))
FWD(fmi2SerializeFMUstate, (fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t size), (c, s, b, size))
FWD(fmi2DeSerializeFMUstate, (fmi2Component c, const fmi2Byte b[], size_t size, fmi2FMUstate *s), (c, b, size, s))
/* the slave's answer (see "Directional derivatives" at the top); the wrapper's for a slave that offered none */
EXPORT fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference unknowns[], size_t nu,
                                               const fmi2ValueReference knowns[], size_t nk, const fmi2Real seed[],
                                               fmi2Real sensitivity[]) {
    Derivatives d;
    char err[1024];
    if (!find_offer(c, &d))
        return ((fmi2Status (*)(fmi2Component, const fmi2ValueReference *, size_t, const fmi2ValueReference *, size_t,
                                const fmi2Real *, fmi2Real *))p_fmi2GetDirectionalDerivative)(
            c, unknowns, nu, knowns, nk, seed, sensitivity);
    if (directional_derivative(d.call, unknowns, nu, knowns, nk, seed, sensitivity, err, sizeof err) == 0) return 0;
    log_error(d.cb2.logger ? &d.cb2 : NULL, d.name, err);
    return 3;  /* fmi2Error */
}
FWD(fmi2SetRealInputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[],
                                  const fmi2Real v[]), (c, vr, n, o, v))
FWD(fmi2GetRealOutputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[],
                                   fmi2Real v[]), (c, vr, n, o, v))
FWD(fmi2DoStep, (fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noPrior), (c, t, h, noPrior))
FWD(fmi2CancelStep, (fmi2Component c), (c))
FWD(fmi2GetStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Status *v), (c, k, v))
FWD(fmi2GetRealStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Real *v), (c, k, v))
FWD(fmi2GetIntegerStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Integer *v), (c, k, v))
FWD(fmi2GetBooleanStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Boolean *v), (c, k, v))
FWD(fmi2GetStringStatus, (fmi2Component c, const fmi2StatusKind k, fmi2String *v), (c, k, v))
#endif /* PRESSDRIVE_FMI3 */

/* pressdrive host loader, part 1: the Python an FMU runs on, found, started and checked (included by
 * pressdrive_loader.c, so by pressdrive_loader3.c too).
 *
 * resources/pressdrive_python.txt (written by fmus/build.py) says, one key=value a line:
 *   version    the builder's Python (major.minor, for messages)
 *   minimum    the oldest Python the FMU's code runs on (major.minor)
 *   libpython, home, path   the builder's libpython, its home and its site folders (':'-separated)
 *   standalone the folder, beside this binary, of the interpreter the FMU carries (a --standalone export); with
 *   soname     its libpython's file name (in <standalone>/lib) and
 *   preload    the libraries in <standalone>/lib that its extension modules need, in load order (' '-separated)
 *
 * Which Python: the host's own when it runs one (FMPy, libcosimpy, ...: Python's symbols are in the process);
 * else a standalone FMU's own interpreter, started isolated with its own home (pressdrive_pyconfig.c: no
 * PYTHON* variable and no user site folder of the machine reaches it); else PRESSDRIVE_LIBPYTHON, else the
 * builder's libpython where it still is (the same machine), else any libpython3.<minor>.so.1.0 of an allowed
 * version the dynamic linker finds.  Python's version must be at least ``minimum`` (pythonfmu's wrappers use
 * Python's stable ABI: nothing binds the FMU to the builder's minor version).
 *
 * Then, before any model code runs, resources/pressdrive_check.py (fmus/hostcheck.py) checks what the FMU's code
 * needs in that Python: the modules of resources/requirements.txt at their versions, then the FMU's own module.
 * Anything missing is one line, returned to the caller, which logs it through the host's FMI logger. */

static struct {
    char version[32], minimum[32], libpython[PATH_MAX], home[PATH_MAX], path[8 * PATH_MAX];
    char standalone[PATH_MAX], soname[128], preload[4 * PATH_MAX];
} cfg;

/* the bundled interpreter's start (pressdrive_pyconfig.c, linked into a standalone FMU's loader only) */
extern int pressdrive_start_isolated(void *libpython, const char *home, char *err, size_t n) __attribute__((weak));

static void strip(char *s) {
    size_t n = strlen(s);
    while (n && (s[n - 1] == '\n' || s[n - 1] == '\r' || s[n - 1] == ' ')) s[--n] = 0;
}

static void read_config(const char *file) {
    FILE *f = fopen(file, "r");
    char line[8 * PATH_MAX + 32];
    if (!f) return;
    while (fgets(line, sizeof line, f)) {
        char *eq = strchr(line, '=');
        if (!eq) continue;
        *eq = 0;
        strip(eq + 1);
#define KEY(name) if (!strcmp(line, #name)) snprintf(cfg.name, sizeof cfg.name, "%s", eq + 1);
        KEY(version) KEY(minimum) KEY(libpython) KEY(home) KEY(path) KEY(standalone) KEY(soname) KEY(preload)
#undef KEY
    }
    fclose(f);
}

static const char *env_setting(const char *name) {
    const char *v = getenv(name);
    return (v && *v) ? v : NULL;
}

static int file_exists(const char *p) {
    struct stat st;
    return p && *p && stat(p, &st) == 0;
}

/* "3.12.1 (main, ...)" or "3.10" -> 0x030c; 0 if unreadable */
static int version_number(const char *s) {
    int major = 0, minor = 0;
    if (!s || sscanf(s, "%d.%d", &major, &minor) != 2) return 0;
    return major * 256 + minor;
}

/* append s to a Python single-quoted literal in out */
static void py_literal(char *out, size_t n, const char *s) {
    size_t k = strlen(out);
    if (k + 2 >= n) return;
    out[k++] = '\'';
    for (; *s && k + 4 < n; s++) {
        if (*s == '\'' || *s == '\\') out[k++] = '\\';
        out[k++] = *s;
    }
    out[k++] = '\'';
    out[k] = 0;
}

enum origin { FROM_HOST, FROM_BUNDLE, FROM_VARIABLE, FROM_BUILDER, FROM_SEARCH };

/* the libraries a standalone FMU's extension modules need, loaded first from its own lib folder (their sonames
 * then satisfy the modules' needs whatever the machine has) */
static int preload_bundled(const char *lib, char *err, size_t n) {
    char list[sizeof cfg.preload], file[2 * PATH_MAX], *save = NULL;
    snprintf(list, sizeof list, "%s", cfg.preload);
    for (char *name = strtok_r(list, " ", &save); name; name = strtok_r(NULL, " ", &save)) {
        snprintf(file, sizeof file, "%s/%s", lib, name);
        if (!dlopen(file, RTLD_NOW | RTLD_GLOBAL)) {
            snprintf(err, n, "this FMU's own Python is incomplete: '%s' does not load (%s)", file, dlerror());
            return -1;
        }
    }
    return 0;
}

/* Python's library handle (the process's global scope when the host runs Python), where it came from and its file in `chosen`;
 * NULL with one line in err when there is none. */
static void *find_python(const char *bindir, char *chosen, size_t nc, enum origin *origin, char *err, size_t n) {
    const char *variable = env_setting("PRESSDRIVE_LIBPYTHON");
    char bundled[2 * PATH_MAX];
    void *py;
    chosen[0] = 0;
    if (dlsym(RTLD_DEFAULT, "Py_IsInitialized")) {
        *origin = FROM_HOST;
        snprintf(chosen, nc, "the host process");
        return dlopen(NULL, RTLD_NOW);   /* the process's global scope (RTLD_DEFAULT is NULL: no handle) */
    }
    if (cfg.standalone[0]) {
        char lib[PATH_MAX + 64];
        snprintf(lib, sizeof lib, "%s/%s/lib", bindir, cfg.standalone);
        snprintf(bundled, sizeof bundled, "%s/%s", lib, cfg.soname);
        *origin = FROM_BUNDLE;
        snprintf(chosen, nc, "%s", bundled);
        if (preload_bundled(lib, err, n) != 0) return NULL;
        if (!(py = dlopen(bundled, RTLD_NOW | RTLD_GLOBAL)))
            snprintf(err, n, "this FMU's own Python '%s' does not load (%s)", bundled, dlerror());
        return py;
    }
    if (variable) {
        *origin = FROM_VARIABLE;
        snprintf(chosen, nc, "PRESSDRIVE_LIBPYTHON='%s'", variable);
        if (!(py = dlopen(variable, RTLD_NOW | RTLD_GLOBAL)))
            snprintf(err, n, "PRESSDRIVE_LIBPYTHON='%s' does not load (%s): set it to the libpython3.x.so.1.0 of "
                     "a Python %s or newer that has numpy", variable, dlerror(), cfg.minimum);
        return py;
    }
    if (file_exists(cfg.libpython) && (py = dlopen(cfg.libpython, RTLD_NOW | RTLD_GLOBAL))) {
        *origin = FROM_BUILDER;
        snprintf(chosen, nc, "%s", cfg.libpython);
        return py;
    }
    int lowest = version_number(cfg.minimum) & 0xff;
    for (int minor = 20; minor >= lowest && minor > 0; minor--) {   /* the newest allowed Python first */
        char name[64];
        snprintf(name, sizeof name, "libpython3.%d.so.1.0", minor);
        if ((py = dlopen(name, RTLD_NOW | RTLD_GLOBAL))) {
            *origin = FROM_SEARCH;
            Dl_info info;
            snprintf(chosen, nc, "%s", (dladdr(dlsym(py, "Py_GetVersion"), &info) && info.dli_fname) ?
                     info.dli_fname : name);
            return py;
        }
    }
    snprintf(err, n, "no Python for this FMU: it runs Python code (pythonfmu) and this host has no Python in it; "
             "PRESSDRIVE_LIBPYTHON is not set, the builder's '%s' is not on this machine and the dynamic linker "
             "finds no libpython3.x.so.1.0 of Python %s or newer. Install a Python %s or newer with numpy and set "
             "PRESSDRIVE_LIBPYTHON to its libpython (PRESSDRIVE_PYTHONPATH to the site-packages folder that has "
             "numpy), or use this FMU exported with --standalone (it carries its own Python)",
             cfg.libpython[0] ? cfg.libpython : "(none recorded)", cfg.minimum, cfg.minimum);
    return NULL;
}

/* a mark in the interpreter that a loader started it (the host runs no Python of its own): what the check
 * (fmus/hostcheck.py) tells a user to do then differs */
#define STARTED_HERE "import sys, types\nsys.modules.setdefault('_pressdrive_embedded', types.ModuleType(" \
    "'_pressdrive_embedded', 'Python started by a pressdrive FMU loader (fmus/loader)'))\n"

/* Start the interpreter of `py` (not yet initialised): a standalone FMU's own isolated, any other with the home
 * and site folders that belong to it; the GIL released after.  0, else err holds one line. */
static int start_python(void *py, enum origin origin, const char *bindir, const char *chosen, char *err, size_t n) {
    void *(*save_thread)(void) = (void *(*)(void))dlsym(py, "PyEval_SaveThread");
    if (origin == FROM_BUNDLE) {
        char home[PATH_MAX + 64];
        snprintf(home, sizeof home, "%s/%s", bindir, cfg.standalone);
        if (!pressdrive_start_isolated) {
            snprintf(err, n, "this FMU's loader cannot start its own Python (built without pressdrive_pyconfig.c)");
            return -1;
        }
        if (pressdrive_start_isolated(py, home, err, n) != 0) return -1;
        int (*run)(const char *) = (int (*)(const char *))dlsym(py, "PyRun_SimpleString");
        if (run) run(STARTED_HERE);
        save_thread();
        return 0;
    }
    /* the builder's home and site folders belong to the builder's libpython only */
    const char *home = env_setting("PRESSDRIVE_PYTHONHOME"), *path = env_setting("PRESSDRIVE_PYTHONPATH");
    if (origin == FROM_BUILDER) {
        if (!home && file_exists(cfg.home)) home = cfg.home;
        if (!path) path = cfg.path;
    }
    wchar_t *(*decode)(const char *, size_t *) = (wchar_t *(*)(const char *, size_t *))dlsym(py, "Py_DecodeLocale");
    void (*set_home)(const wchar_t *) = (void (*)(const wchar_t *))dlsym(py, "Py_SetPythonHome");
    void (*init)(int) = (void (*)(int))dlsym(py, "Py_InitializeEx");
    int (*run)(const char *) = (int (*)(const char *))dlsym(py, "PyRun_SimpleString");
    if (!decode || !init || !run || !save_thread || (home && !set_home)) {
        snprintf(err, n, "the Python at %s lacks the embedding API this loader calls (Py_InitializeEx, "
                 "Py_SetPythonHome)", chosen);
        return -1;
    }
    if (home) {
        static wchar_t *whome; /* must outlive the interpreter */
        whome = decode(home, NULL);
        set_home(whome);
    }
    init(0);   /* no signal handlers: the host's stay */
    run(STARTED_HERE);
    int rc = 0;
    if (path) {
        static char script[16 * PATH_MAX];
        snprintf(script, sizeof script, "import site\nfor _p in ");
        py_literal(script, sizeof script, path);
        strncat(script, ".split(':'):\n    if _p: site.addsitedir(_p)\n", sizeof script - strlen(script) - 1);
        rc = run(script);
    }
    save_thread();
    if (rc != 0) {
        snprintf(err, n, "the Python at %s cannot add the site folders '%s' (traceback on stderr; check "
                 "PRESSDRIVE_PYTHONPATH)", chosen, path);
        return -1;
    }
    return 0;
}

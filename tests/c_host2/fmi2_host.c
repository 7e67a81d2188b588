/* A minimal FMI 2.0 co-simulation host in C, without Python (tests/test_handoff.py; its FMI 3.0 sibling is
 * tests/c_host3/fmi3_host.c, with the same arguments and output).
 *
 *   fmi2_host <binary.so> <resourcePath> <guid> <steps> <h> <inputs> <outputs>
 *
 * <inputs> is "vr=value,vr=value" (set once, before initialisation, and held), <outputs> "vr,vr".  It
 * instantiates the FMU (resources as a file:// URI, debug logging off), initialises it at t = 0, takes <steps>
 * steps of <h> and prints the outputs after the last one, one "vr value" line each (%.17g); every message the
 * FMU logs is printed as "LOG <status> <category> <message>".
 * Exit status: 0 done, 2 the library did not load, 3 the instance was not made, 4 a call failed.
 */
#include <dlfcn.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef void *Component;
typedef void (*Logger)(void *env, const char *instance, int status, const char *category, const char *message, ...);
typedef struct {
    Logger logger;
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(void *, int);
    void *componentEnvironment;
} Callbacks;
typedef Component (*Instantiate)(const char *, int, const char *, const char *, const Callbacks *, int, int);
typedef int (*Setup)(Component, int, double, double, int, double);
typedef int (*Plain)(Component);
typedef int (*Reals)(Component, const unsigned int *, size_t, double *);
typedef int (*Step)(Component, double, double, int);
typedef void (*Free)(Component);

static void logger(void *env, const char *instance, int status, const char *category, const char *message, ...) {
    char text[8192];
    va_list ap;
    (void)env;
    (void)instance;
    va_start(ap, message);
    vsnprintf(text, sizeof text, message ? message : "", ap);
    va_end(ap);
    printf("LOG %d %s %s\n", status, category ? category : "", text);
}

static size_t parse(const char *text, unsigned int *vrs, double *values) {
    size_t n = 0;
    char *copy = strdup(text), *save = NULL;
    for (char *item = strtok_r(copy, ",", &save); item && n < 256; item = strtok_r(NULL, ",", &save)) {
        char *eq = strchr(item, '=');
        vrs[n] = (unsigned int)strtoul(item, NULL, 10);
        if (values) values[n] = eq ? strtod(eq + 1, NULL) : 0.0;
        n++;
    }
    free(copy);
    return n;
}

int main(int argc, char **argv) {
    if (argc != 8) {
        fprintf(stderr, "usage: fmi2_host binary.so resources guid steps h inputs outputs\n");
        return 1;
    }
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        printf("DLOPEN %s\n", dlerror());
        return 2;
    }
    Instantiate instantiate = (Instantiate)dlsym(lib, "fmi2Instantiate");
    Setup setup = (Setup)dlsym(lib, "fmi2SetupExperiment");
    Plain enter = (Plain)dlsym(lib, "fmi2EnterInitializationMode");
    Plain exit_init = (Plain)dlsym(lib, "fmi2ExitInitializationMode");
    Plain terminate = (Plain)dlsym(lib, "fmi2Terminate");
    Reals set = (Reals)dlsym(lib, "fmi2SetReal");
    Reals get = (Reals)dlsym(lib, "fmi2GetReal");
    Step step = (Step)dlsym(lib, "fmi2DoStep");
    Free release = (Free)dlsym(lib, "fmi2FreeInstance");
    unsigned int in_vr[256], out_vr[256];
    double in_v[256], out_v[256];
    size_t n_in = parse(argv[6], in_vr, in_v), n_out = parse(argv[7], out_vr, NULL);
    int steps = atoi(argv[4]);
    double h = strtod(argv[5], NULL);
    char uri[8192];
    snprintf(uri, sizeof uri, "file://%s", argv[2]);
    Callbacks cb = {logger, calloc, free, NULL, NULL};

    Component c = instantiate("host", 1, argv[3], uri, &cb, 0, 0);
    if (!c) {
        printf("NOINSTANCE\n");
        return 3;
    }
    if ((n_in && set(c, in_vr, n_in, in_v)) || setup(c, 0, 0.0, 0.0, 0, 0.0) || enter(c) || exit_init(c)) return 4;
    for (int k = 0; k < steps; k++)
        if (step(c, k * h, h, 1)) return 4;
    if (get(c, out_vr, n_out, out_v)) return 4;
    for (size_t i = 0; i < n_out; i++) printf("%u %.17g\n", out_vr[i], out_v[i]);
    terminate(c);
    release(c);
    return 0;
}

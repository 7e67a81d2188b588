/* A minimal FMI 2.0 co-simulation host in C, without Python (tests/test_handoff.py; its FMI 3.0 sibling is
 * tests/c_hosts/fmi3_host.c, with the same arguments and output).
 *
 *   fmi2_host <binary.so> <resourcePath> <guid> <steps> <h> <inputs> <outputs>     (host.h)
 *
 * It instantiates the FMU (resources as a file:// URI, debug logging off), initialises it at t = 0, takes <steps>
 * steps of <h> and prints the outputs after the last one, one "vr value" line each (%.17g); every message the
 * FMU logs is printed as "LOG <status> <category> <message>".
 * Exit status: 0 done, 2 the library did not load, 3 the instance was not made, 4 a call failed.
 */
#include <stdarg.h>
#include <stddef.h>

#include "host.h"

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

int main(int argc, char **argv) {
    Run r;
    struct {
        Instantiate instantiate; Setup setup; Plain enter, exit_init, terminate; Reals set, get; Step step; Free release;
    } f;
    int status = open_fmu(argc, argv, 0, "fmi2_host", "fmi2Instantiate fmi2SetupExperiment fmi2EnterInitializationMode "
                          "fmi2ExitInitializationMode fmi2Terminate fmi2SetReal fmi2GetReal fmi2DoStep "
                          "fmi2FreeInstance", (void **)&f, &r);
    if (status) return status;
    char uri[8192];
    snprintf(uri, sizeof uri, "file://%s", r.resources);
    Callbacks cb = {logger, calloc, free, NULL, NULL};

    Component c = f.instantiate("host", 1, r.token, uri, &cb, 0, 0);
    if (!c) {
        printf("NOINSTANCE\n");
        return 3;
    }
    if ((r.n_in && f.set(c, r.in_vr, r.n_in, r.in_v)) || f.setup(c, 0, 0.0, 0.0, 0, 0.0) || f.enter(c) ||
        f.exit_init(c))
        return 4;
    for (int k = 0; k < r.steps; k++)
        if (f.step(c, k * r.h, r.h, 1)) return 4;
    if (f.get(c, r.out_vr, r.n_out, r.out_v)) return 4;
    print_outputs(&r);
    f.terminate(c);
    f.release(c);
    return 0;
}

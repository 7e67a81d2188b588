/* A minimal FMI 3.0 host in C, without Python (tests/test_fmi3_export.py, tests/test_handoff.py).
 *
 *   fmi3_host <binary.so> <resourcePath> <instantiationToken> <steps> <h> <inputs> <outputs> [me]
 *
 * <inputs> is "vr=value,vr=value" (set once, before initialisation, and held), <outputs> "vr,vr".  It
 * instantiates the FMU, initialises it at t = 0, takes <steps> steps of <h> and prints the outputs after
 * the last one, one "vr value" line each (%.17g); every message the FMU logs is printed as "LOG ...".
 * With "me" it runs the FMU's model exchange interface instead: forward Euler steps of <h> (FMPy's ForwardEuler
 * order of calls: states and derivatives read, x += h dx, time and states set, completed integrator step).
 * Exit status: 0 done, 2 the library did not load, 3 the instance was not made, 4 a call failed.
 */
#include <dlfcn.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef void *Instance;
typedef void (*Logger)(void *env, int status, const char *category, const char *message);
typedef Instance (*Instantiate)(const char *, const char *, const char *, bool, bool, bool, bool,
                                const unsigned int *, size_t, void *, Logger, void *);
typedef int (*Init)(Instance, bool, double, double, bool, double);
typedef int (*Plain)(Instance);
typedef int (*Floats)(Instance, const unsigned int *, size_t, double *, size_t);
typedef int (*Step)(Instance, double, double, bool, bool *, bool *, bool *, double *);
typedef void (*Free)(Instance);
typedef Instance (*InstantiateME)(const char *, const char *, const char *, bool, bool, void *, Logger);
typedef int (*Count)(Instance, size_t *);
typedef int (*Vector)(Instance, double *, size_t);
typedef int (*SetVector)(Instance, const double *, size_t);
typedef int (*SetTime)(Instance, double);
typedef int (*Update)(Instance, bool *, bool *, bool *, bool *, bool *, double *);
typedef int (*Completed)(Instance, bool, bool *, bool *);

static void logger(void *env, int status, const char *category, const char *message) {
    (void)env;
    printf("LOG %d %s %s\n", status, category ? category : "", message ? message : "");
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

/* model exchange by forward Euler (FMPy's ForwardEuler order of calls); the instance, or NULL with *status set */
static Instance run_me(void *lib, const char *resources, const char *token, int steps, double h,
                       const unsigned int *in_vr, double *in_v, size_t n_in, int *status) {
    InstantiateME instantiate = (InstantiateME)dlsym(lib, "fmi3InstantiateModelExchange");
    Init enter = (Init)dlsym(lib, "fmi3EnterInitializationMode");
    Plain exit_init = (Plain)dlsym(lib, "fmi3ExitInitializationMode");
    Floats set = (Floats)dlsym(lib, "fmi3SetFloat64");
    Update update = (Update)dlsym(lib, "fmi3UpdateDiscreteStates");
    Plain continuous = (Plain)dlsym(lib, "fmi3EnterContinuousTimeMode");
    Count nx = (Count)dlsym(lib, "fmi3GetNumberOfContinuousStates");
    Vector get_x = (Vector)dlsym(lib, "fmi3GetContinuousStates");
    Vector get_dx = (Vector)dlsym(lib, "fmi3GetContinuousStateDerivatives");
    SetVector set_x = (SetVector)dlsym(lib, "fmi3SetContinuousStates");
    SetTime set_time = (SetTime)dlsym(lib, "fmi3SetTime");
    Completed completed = (Completed)dlsym(lib, "fmi3CompletedIntegratorStep");
    Instance c = instantiate("host", token, resources, false, false, NULL, logger);
    bool need = false, stop = false, nominals = false, values = false, next = false;
    double tnext = 0.0, x[256], dx[256];
    size_t n = 0;
    *status = 3;
    if (!c) return NULL;
    *status = 4;
    if ((n_in && set(c, in_vr, n_in, in_v, n_in)) || enter(c, false, 0.0, 0.0, false, 0.0) || exit_init(c) ||
        update(c, &need, &stop, &nominals, &values, &next, &tnext) || continuous(c) || nx(c, &n) || n > 256)
        return NULL;
    for (int k = 0; k < steps; k++) {
        bool event = false, terminate = false;
        if (get_x(c, x, n) || get_dx(c, dx, n)) return NULL;
        for (size_t i = 0; i < n; i++) x[i] += h * dx[i];
        if (set_time(c, (k + 1) * h) || set_x(c, x, n) || completed(c, true, &event, &terminate)) return NULL;
    }
    *status = 0;
    return c;
}

int main(int argc, char **argv) {
    if (argc != 8 && !(argc == 9 && !strcmp(argv[8], "me"))) {
        fprintf(stderr, "usage: fmi3_host binary.so resources token steps h inputs outputs [me]\n");
        return 1;
    }
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        printf("DLOPEN %s\n", dlerror());
        return 2;
    }
    Instantiate instantiate = (Instantiate)dlsym(lib, "fmi3InstantiateCoSimulation");
    Init enter = (Init)dlsym(lib, "fmi3EnterInitializationMode");
    Plain exit_init = (Plain)dlsym(lib, "fmi3ExitInitializationMode");
    Plain terminate = (Plain)dlsym(lib, "fmi3Terminate");
    Floats set = (Floats)dlsym(lib, "fmi3SetFloat64");
    Floats get = (Floats)dlsym(lib, "fmi3GetFloat64");
    Step step = (Step)dlsym(lib, "fmi3DoStep");
    Free release = (Free)dlsym(lib, "fmi3FreeInstance");
    unsigned int in_vr[256], out_vr[256];
    double in_v[256], out_v[256];
    size_t n_in = parse(argv[6], in_vr, in_v), n_out = parse(argv[7], out_vr, NULL);
    int steps = atoi(argv[4]);
    double h = strtod(argv[5], NULL);

    Instance c;
    if (argc == 9) {   /* model exchange */
        int status = 0;
        c = run_me(lib, argv[2], argv[3], steps, h, in_vr, in_v, n_in, &status);
        if (!c) {
            if (status == 3) printf("NOINSTANCE\n");
            return status;
        }
    } else {
        c = instantiate("host", argv[3], argv[2], false, true, false, false, NULL, 0, NULL, logger, NULL);
        if (!c) {
            printf("NOINSTANCE\n");
            return 3;
        }
        if ((n_in && set(c, in_vr, n_in, in_v, n_in)) || enter(c, false, 0.0, 0.0, false, 0.0) || exit_init(c))
            return 4;
        for (int k = 0; k < steps; k++) {
            bool event = false, stop = false, early = false;
            double last = 0.0;
            if (step(c, k * h, h, true, &event, &stop, &early, &last)) return 4;
        }
    }
    if (get(c, out_vr, n_out, out_v, n_out)) return 4;
    for (size_t i = 0; i < n_out; i++) printf("%u %.17g\n", out_vr[i], out_v[i]);
    terminate(c);
    release(c);
    return 0;
}

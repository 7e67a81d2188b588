/* A minimal FMI 3.0 host in C, without Python (tests/test_fmi3_export.py, tests/test_handoff.py).
 *
 *   fmi3_host <binary.so> <resourcePath> <instantiationToken> <steps> <h> <inputs> <outputs> [me]    (host.h)
 *
 * It instantiates the FMU, initialises it at t = 0, takes <steps> steps of <h> and prints the outputs after
 * the last one, one "vr value" line each (%.17g); every message the FMU logs is printed as "LOG ...".
 * With "me" it runs the FMU's model exchange interface instead: forward Euler steps of <h> (FMPy's ForwardEuler
 * order of calls: states and derivatives read, x += h dx, time and states set, completed integrator step).
 * Exit status: 0 done, 2 the library did not load, 3 the instance was not made, 4 a call failed.
 */
#include <stdbool.h>
#include <stddef.h>

#include "host.h"

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

static Instance run_me(Run *r, int *status) {
    struct {
        InstantiateME instantiate; Init enter; Plain exit_init; Floats set; Update update; Plain continuous;
        Count nx; Vector get_x, get_dx; SetVector set_x; SetTime set_time; Completed completed;
    } f;
    if ((*status = bind(r->lib, "fmi3InstantiateModelExchange fmi3EnterInitializationMode fmi3ExitInitializationMode "
                        "fmi3SetFloat64 fmi3UpdateDiscreteStates fmi3EnterContinuousTimeMode "
                        "fmi3GetNumberOfContinuousStates fmi3GetContinuousStates fmi3GetContinuousStateDerivatives "
                        "fmi3SetContinuousStates fmi3SetTime fmi3CompletedIntegratorStep", (void **)&f)))
        return NULL;
    Instance c = f.instantiate("host", r->token, r->resources, false, false, NULL, logger);
    bool need = false, stop = false, nominals = false, values = false, next = false;
    double tnext = 0.0, x[256], dx[256];
    size_t n = 0;
    *status = 3;
    if (!c) return NULL;
    *status = 4;
    if ((r->n_in && f.set(c, r->in_vr, r->n_in, r->in_v, r->n_in)) || f.enter(c, false, 0.0, 0.0, false, 0.0) ||
        f.exit_init(c) || f.update(c, &need, &stop, &nominals, &values, &next, &tnext) || f.continuous(c) ||
        f.nx(c, &n) || n > 256)
        return NULL;
    for (int k = 0; k < r->steps; k++) {
        bool event = false, terminate = false;
        if (f.get_x(c, x, n) || f.get_dx(c, dx, n)) return NULL;
        for (size_t i = 0; i < n; i++) x[i] += r->h * dx[i];
        if (f.set_time(c, (k + 1) * r->h) || f.set_x(c, x, n) || f.completed(c, true, &event, &terminate)) return NULL;
    }
    *status = 0;
    return c;
}

int main(int argc, char **argv) {
    Run r;
    struct {
        Instantiate instantiate; Init enter; Plain exit_init, terminate; Floats set, get; Step step; Free release;
    } f;
    int status = open_fmu(argc, argv, 1, "fmi3_host", "fmi3InstantiateCoSimulation fmi3EnterInitializationMode "
                          "fmi3ExitInitializationMode fmi3Terminate fmi3SetFloat64 fmi3GetFloat64 fmi3DoStep "
                          "fmi3FreeInstance", (void **)&f, &r);
    if (status) return status;

    Instance c;
    if (r.me) {
        c = run_me(&r, &status);
        if (!c) {
            if (status == 3) printf("NOINSTANCE\n");
            return status;
        }
    } else {
        c = f.instantiate("host", r.token, r.resources, false, true, false, false, NULL, 0, NULL, logger, NULL);
        if (!c) {
            printf("NOINSTANCE\n");
            return 3;
        }
        if ((r.n_in && f.set(c, r.in_vr, r.n_in, r.in_v, r.n_in)) || f.enter(c, false, 0.0, 0.0, false, 0.0) ||
            f.exit_init(c))
            return 4;
        for (int k = 0; k < r.steps; k++) {
            bool event = false, stop = false, early = false;
            double last = 0.0;
            if (f.step(c, k * r.h, r.h, true, &event, &stop, &early, &last)) return 4;
        }
    }
    if (f.get(c, r.out_vr, r.n_out, r.out_v, r.n_out)) return 4;
    print_outputs(&r);
    f.terminate(c);
    f.release(c);
    return 0;
}

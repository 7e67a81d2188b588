/* What the toolkit's C hosts share (fmi2_host.c, fmi3_host.c): their arguments and the FMU's library.
 *
 *   fmi<N>_host <binary.so> <resourcePath> <token> <steps> <h> <inputs> <outputs> [me]
 *
 * <inputs> "vr=value,vr=value" (set once, before initialisation, and held), <outputs> "vr,vr".
 */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    void *lib;                       /* the FMU's binary */
    const char *resources, *token;
    unsigned int in_vr[256], out_vr[256];
    double in_v[256], out_v[256];
    size_t n_in, n_out;
    int steps;
    double h;
    int me;                          /* "me": model exchange (FMI 3.0 host only) */
} Run;

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

/* the arguments read and the library loaded: 0, else the exit status (1 usage, 2 the library did not load) */
static int start(int argc, char **argv, int me_allowed, const char *name, Run *r) {
    memset(r, 0, sizeof *r);
    r->me = argc == 9 && me_allowed && !strcmp(argv[8], "me");
    if (argc != 8 && !r->me) {
        fprintf(stderr, "usage: %s binary.so resources token steps h inputs outputs%s\n", name,
                me_allowed ? " [me]" : "");
        return 1;
    }
    if (!(r->lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL))) {
        printf("DLOPEN %s\n", dlerror());
        return 2;
    }
    r->resources = argv[2], r->token = argv[3];
    r->steps = atoi(argv[4]);
    r->h = strtod(argv[5], NULL);
    r->n_in = parse(argv[6], r->in_vr, r->in_v);
    r->n_out = parse(argv[7], r->out_vr, NULL);
    return 0;
}

/* the functions named in ``names`` (space-separated) looked up in the FMU's library, in order, into ``slots`` (a
 * struct of as many function pointers); 0, else 2 with the missing one named */
static int bind(void *lib, const char *names, void **slots) {
    char copy[2048], *save = NULL;
    snprintf(copy, sizeof copy, "%s", names);
    for (char *name = strtok_r(copy, " ", &save); name; name = strtok_r(NULL, " ", &save), slots++)
        if (!(*slots = dlsym(lib, name))) {
            printf("DLSYM %s\n", name);
            return 2;
        }
    return 0;
}

/* start() and bind() the host's ``functions``: 0, else the exit status */
static int open_fmu(int argc, char **argv, int me_allowed, const char *name, const char *functions, void **slots,
                    Run *r) {
    int status = start(argc, argv, me_allowed, name, r);
    return status ? status : bind(r->lib, functions, slots);
}

/* the outputs after the last step, one "vr value" line each */
static void print_outputs(const Run *r) {
    for (size_t i = 0; i < r->n_out; i++) printf("%u %.17g\n", r->out_vr[i], r->out_v[i]);
}

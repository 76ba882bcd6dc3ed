/* Minimal FMI 2.0 co-simulation master in C (tests/test_fmu_native.py): dlopen an FMU binary, run steps, print outputs.
 * Usage: master LIB GUID NSTEPS STEP NIN NOUT vr_in... vr_out...; NSTEPS rows of NIN input values on stdin.
 * Prints the outputs at t = 0, STEP, ..., NSTEPS*STEP (one line each) and "us_per_step" on stderr: process CPU time
 * of fmi2GetReal + fmi2SetReal + fmi2DoStep per step (outputs are kept in memory and printed after the timed loop).
 * Optional environment: FMI_MASTER_RESOURCES, the resources URI passed to fmi2Instantiate (default ""), and
 * FMI_MASTER_PRELOAD, a library loaded with RTLD_GLOBAL first (libpython, for a pythonfmu FMU in
 * benchmarks/bench_fmu.py; a native FMU needs neither). */
#define _POSIX_C_SOURCE 200809L
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef void *comp_t;
typedef void (*logger_t)(void *, const char *, int, const char *, const char *, ...);
typedef struct {
    logger_t logger;
    void *(*alloc)(size_t, size_t);
    void (*freemem)(void *);
    void *step_finished;
    void *env;
} callbacks_t;

static void logger(void *env, const char *name, int status, const char *cat, const char *msg, ...) {
    (void)env;
    fprintf(stderr, "[%s %d %s] %s\n", name, status, cat, msg);
}

#define LOAD(var, name)                                              \
    *(void **)(&var) = dlsym(lib, name);                             \
    if (!var) {                                                      \
        fprintf(stderr, "missing %s\n", name);                       \
        return 2;                                                    \
    }

int main(int argc, char **argv) {
    /* usage: master LIB GUID NSTEPS STEP NIN NOUT vr_in... vr_out... then per step NIN input values on stdin */
    if (argc < 7) return 2;
    const char *pre = getenv("FMI_MASTER_PRELOAD");
    if (pre && !dlopen(pre, RTLD_NOW | RTLD_GLOBAL)) {
        fprintf(stderr, "dlopen %s: %s\n", pre, dlerror());
        return 2;
    }
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "dlopen: %s\n", dlerror());
        return 2;
    }
    comp_t (*inst)(const char *, int, const char *, const char *, const callbacks_t *, int, int);
    int (*setup)(comp_t, int, double, double, int, double);
    int (*enter)(comp_t), (*exit_)(comp_t), (*term)(comp_t);
    void (*freei)(comp_t);
    int (*setr)(comp_t, const unsigned *, size_t, const double *);
    int (*getr)(comp_t, const unsigned *, size_t, double *);
    int (*dostep)(comp_t, double, double, int);
    LOAD(inst, "fmi2Instantiate");
    LOAD(setup, "fmi2SetupExperiment");
    LOAD(enter, "fmi2EnterInitializationMode");
    LOAD(exit_, "fmi2ExitInitializationMode");
    LOAD(term, "fmi2Terminate");
    LOAD(freei, "fmi2FreeInstance");
    LOAD(setr, "fmi2SetReal");
    LOAD(getr, "fmi2GetReal");
    LOAD(dostep, "fmi2DoStep");
    int nsteps = atoi(argv[3]), nin = atoi(argv[5]), nout = atoi(argv[6]);
    double h = atof(argv[4]);
    unsigned vin[256], vout[256];
    double in[256];
    for (int i = 0; i < nin; ++i) vin[i] = (unsigned)atoi(argv[7 + i]);
    for (int i = 0; i < nout; ++i) vout[i] = (unsigned)atoi(argv[7 + nin + i]);
    callbacks_t cb = {logger, calloc, free, NULL, NULL};
    const char *res_uri = getenv("FMI_MASTER_RESOURCES");
    comp_t c = inst("master", 1 /* fmi2CoSimulation */, argv[2], res_uri ? res_uri : "", &cb, 0, 0);
    if (!c) return 3;
    if (setup(c, 0, 0.0, 0.0, 0, 0.0) || enter(c)) return 4;
    double *all = malloc(sizeof(double) * (size_t)(nsteps > 0 ? nsteps : 1) * (nin > 0 ? nin : 1));
    double *res = malloc(sizeof(double) * (size_t)(nsteps + 1) * (nout > 0 ? nout : 1));
    if (!all || !res) return 11;
    for (int k = 0; k < nsteps * nin; ++k)
        if (scanf("%lf", &all[k]) != 1) return 5;
    if (nsteps > 0 && setr(c, vin, nin, all)) return 6;
    if (exit_(c)) return 7;
    struct timespec t0, t1;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t0);
    for (int k = 0; k < nsteps; ++k) {
        if (getr(c, vout, nout, res + (size_t)k * nout)) return 8;
        memcpy(in, all + (size_t)k * nin, sizeof(double) * nin);
        int st = setr(c, vin, nin, in);
        if (st) return 9;
        st = dostep(c, k * h, h, 1);
        if (st) {
            fprintf(stderr, "fmi2DoStep at t=%g returned %d\n", k * h, st);
            return 10;
        }
    }
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t1);
    if (getr(c, vout, nout, res + (size_t)nsteps * nout)) return 8;
    for (int k = 0; k <= nsteps; ++k)
        for (int i = 0; i < nout; ++i) printf("%.17g%c", res[(size_t)k * nout + i], i + 1 < nout ? ' ' : '\n');
    fprintf(stderr, "us_per_step %.3f\n", ((t1.tv_sec - t0.tv_sec) * 1e9 + (t1.tv_nsec - t0.tv_nsec)) / 1e3 / (nsteps ? nsteps : 1));
    term(c);
    freei(c);
    dlclose(lib);
    free(all);
    free(res);
    return 0;
}

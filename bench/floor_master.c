/* The C floor: the least a co-simulation of the shipped native FMI 2.0 plant and controller can cost.
 * A Gauss-Seidel master in C (the project master's order: at t_k set the controller's inputs from the
 * plant's outputs and the constant set-points, step the controller, hand its voltages to the plant,
 * step the plant), nothing recorded, no allocation in the loop.  Built by bench/bench_floor.py with the
 * host's cc (never shipped); the script reads the value references from the model descriptions.
 *
 * usage: floor_master PLANT_LIB PLANT_TOKEN CTRL_LIB CTRL_TOKEN STEPS H MODE SPEC...
 *   MODE  floor    time the loop (wall and process CPU time), print {"steps","ns_per_step",
 *                  "cpu_ns_per_step"}
 *         latency  time every doStep of each unit, print their percentiles (ns) and the same outputs
 *   SPEC  P2C:src:dst   plant output vr src -> controller input vr dst, every sample
 *         C2P:src:dst   controller output src -> plant input dst
 *         C:vr=value    a controller input (or parameter) held constant
 *         P:vr=value    a plant input (or parameter) held constant
 *         OUT:vr        a plant output printed (%.17g) at the end, to compare with the Python master
 * exit status: 0 ok, 2 usage or loading, 3 instantiation, 5 initialization, 6 step. */
#define _POSIX_C_SOURCE 200809L
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fmi2Functions.h"

#define MAX_SPEC 64

typedef void (*Symbol)(void);

typedef struct {
    fmi2InstantiateTYPE *instantiate;
    fmi2SetupExperimentTYPE *setup;
    fmi2EnterInitializationModeTYPE *enter;
    fmi2ExitInitializationModeTYPE *exit_init;
    fmi2SetRealTYPE *set_real;
    fmi2GetRealTYPE *get_real;
    fmi2DoStepTYPE *do_step;
    fmi2TerminateTYPE *terminate;
    fmi2FreeInstanceTYPE *free_instance;
    fmi2Component c;
} Unit;

typedef struct {
    fmi2ValueReference src[MAX_SPEC], dst[MAX_SPEC];
    fmi2Real values[MAX_SPEC];
    size_t n;
} Links;

typedef struct {
    fmi2ValueReference vr[MAX_SPEC];
    fmi2Real value[MAX_SPEC];
    size_t n;
} Fixed;

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...)
{
    va_list args;
    (void)env;
    (void)category;
    fprintf(stderr, "[%s] status %d: ", name, (int)status);
    va_start(args, message);
    vfprintf(stderr, message, args);
    va_end(args);
    fputc('\n', stderr);
}

static Symbol symbol(void *lib, const char *name)
{
    void *p = dlsym(lib, name);
    Symbol f;
    memcpy(&f, &p, sizeof f);
    return f;
}

static int load(Unit *u, const char *path, const char *token, const char *name, const fmi2CallbackFunctions *cb)
{
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (lib == NULL) {
        fprintf(stderr, "dlopen: %s\n", dlerror());
        return 2;
    }
    u->instantiate = (fmi2InstantiateTYPE *)symbol(lib, "fmi2Instantiate");
    u->setup = (fmi2SetupExperimentTYPE *)symbol(lib, "fmi2SetupExperiment");
    u->enter = (fmi2EnterInitializationModeTYPE *)symbol(lib, "fmi2EnterInitializationMode");
    u->exit_init = (fmi2ExitInitializationModeTYPE *)symbol(lib, "fmi2ExitInitializationMode");
    u->set_real = (fmi2SetRealTYPE *)symbol(lib, "fmi2SetReal");
    u->get_real = (fmi2GetRealTYPE *)symbol(lib, "fmi2GetReal");
    u->do_step = (fmi2DoStepTYPE *)symbol(lib, "fmi2DoStep");
    u->terminate = (fmi2TerminateTYPE *)symbol(lib, "fmi2Terminate");
    u->free_instance = (fmi2FreeInstanceTYPE *)symbol(lib, "fmi2FreeInstance");
    if (!u->instantiate || !u->setup || !u->enter || !u->exit_init || !u->set_real || !u->get_real ||
        !u->do_step || !u->terminate || !u->free_instance) {
        fprintf(stderr, "%s: an FMI 2.0 function is missing\n", path);
        return 2;
    }
    u->c = u->instantiate(name, fmi2CoSimulation, token, "", cb, fmi2False, fmi2False);
    return u->c == NULL ? 3 : 0;
}

static int init(Unit *u, const Fixed *fixed)
{
    if (fixed->n && u->set_real(u->c, fixed->vr, fixed->n, fixed->value) > fmi2Warning) {
        return 5;
    }
    if (u->setup(u->c, fmi2False, 0.0, 0.0, fmi2False, 0.0) > fmi2Warning || u->enter(u->c) > fmi2Warning ||
        u->exit_init(u->c) > fmi2Warning) {
        return 5;
    }
    return 0;
}

static double now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

static double cpu_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

static int by_value(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void percentiles(const char *name, double *ns, long n)
{
    qsort(ns, (size_t)n, sizeof *ns, by_value);
    printf("\"%s\": {\"median\": %.1f, \"p99\": %.1f, \"p9999\": %.1f, \"max\": %.1f}", name, ns[n / 2],
           ns[(long)(0.99 * (double)(n - 1))], ns[(long)(0.9999 * (double)(n - 1))], ns[n - 1]);
}

static int parse(const char *arg, Links *p2c, Links *c2p, Fixed *cfix, Fixed *pfix, Fixed *out)
{
    unsigned a, b;
    double v;
    if (sscanf(arg, "P2C:%u:%u", &a, &b) == 2 && p2c->n < MAX_SPEC) {
        p2c->src[p2c->n] = a, p2c->dst[p2c->n++] = b;
    } else if (sscanf(arg, "C2P:%u:%u", &a, &b) == 2 && c2p->n < MAX_SPEC) {
        c2p->src[c2p->n] = a, c2p->dst[c2p->n++] = b;
    } else if (sscanf(arg, "C:%u=%lf", &a, &v) == 2 && cfix->n < MAX_SPEC) {
        cfix->vr[cfix->n] = a, cfix->value[cfix->n++] = v;
    } else if (sscanf(arg, "P:%u=%lf", &a, &v) == 2 && pfix->n < MAX_SPEC) {
        pfix->vr[pfix->n] = a, pfix->value[pfix->n++] = v;
    } else if (sscanf(arg, "OUT:%u", &a) == 1 && out->n < MAX_SPEC) {
        out->vr[out->n++] = a;
    } else {
        fprintf(stderr, "bad spec: %s\n", arg);
        return 0;
    }
    return 1;
}

/* one sample at t: the master's Gauss-Seidel order; returns 0 or the failing unit's exit code */
static int sample(Unit *plant, Unit *ctrl, Links *p2c, Links *c2p, double t, double h, double *ns_c, double *ns_p)
{
    double t0 = 0.0;
    plant->get_real(plant->c, p2c->src, p2c->n, p2c->values);
    ctrl->set_real(ctrl->c, p2c->dst, p2c->n, p2c->values);
    if (ns_c) {
        t0 = now_ns();
    }
    if (ctrl->do_step(ctrl->c, t, h, fmi2True) > fmi2Warning) {
        return 6;
    }
    if (ns_c) {
        *ns_c = now_ns() - t0;
    }
    ctrl->get_real(ctrl->c, c2p->src, c2p->n, c2p->values);
    plant->set_real(plant->c, c2p->dst, c2p->n, c2p->values);
    if (ns_p) {
        t0 = now_ns();
    }
    if (plant->do_step(plant->c, t, h, fmi2True) > fmi2Warning) {
        return 6;
    }
    if (ns_p) {
        *ns_p = now_ns() - t0;
    }
    return 0;
}

int main(int argc, char **argv)
{
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    Unit plant, ctrl;
    Links p2c = {{0}, {0}, {0}, 0}, c2p = {{0}, {0}, {0}, 0};
    Fixed cfix = {{0}, {0}, 0}, pfix = {{0}, {0}, 0}, out = {{0}, {0}, 0};
    double *ns_c = NULL, *ns_p = NULL, start, cpu0, h;
    long steps, k;
    int rc, latency, i;
    if (argc < 8) {
        fprintf(stderr, "usage: %s PLANT_LIB PLANT_TOKEN CTRL_LIB CTRL_TOKEN STEPS H floor|latency SPEC...\n",
                argv[0]);
        return 2;
    }
    steps = atol(argv[5]);
    h = atof(argv[6]);
    latency = strcmp(argv[7], "latency") == 0;
    for (i = 8; i < argc; ++i) {
        if (!parse(argv[i], &p2c, &c2p, &cfix, &pfix, &out)) {
            return 2;
        }
    }
    if ((rc = load(&plant, argv[1], argv[2], "plant", &cb)) || (rc = load(&ctrl, argv[3], argv[4], "controller", &cb)) ||
        (rc = init(&plant, &pfix)) || (rc = init(&ctrl, &cfix))) {
        return rc;
    }
    if (latency) {
        ns_c = malloc((size_t)steps * sizeof *ns_c);
        ns_p = malloc((size_t)steps * sizeof *ns_p);
        if (ns_c == NULL || ns_p == NULL) {
            return 2;
        }
    }
    start = now_ns();
    cpu0 = cpu_ns();
    for (k = 0; k < steps; ++k) {
        if ((rc = sample(&plant, &ctrl, &p2c, &c2p, (double)k * h, h, latency ? ns_c + k : NULL,
                         latency ? ns_p + k : NULL))) {
            fprintf(stderr, "doStep failed at step %ld\n", k);
            return rc;
        }
    }
    printf("{\"steps\": %ld, \"ns_per_step\": %.2f, \"cpu_ns_per_step\": %.2f", steps,
           (now_ns() - start) / (double)steps, (cpu_ns() - cpu0) / (double)steps);
    if (latency) {
        printf(", ");
        percentiles("controller", ns_c, steps);
        printf(", ");
        percentiles("plant", ns_p, steps);
        free(ns_c);
        free(ns_p);
    }
    printf(", \"outputs\": [");
    for (i = 0; i < (int)out.n; ++i) {
        fmi2Real v;
        plant.get_real(plant.c, &out.vr[i], 1, &v);
        printf("%s\"%.17g\"", i ? ", " : "", v);
    }
    printf("]}\n");
    plant.terminate(plant.c);
    ctrl.terminate(ctrl.c);
    plant.free_instance(plant.c);
    ctrl.free_instance(ctrl.c);
    return 0;
}

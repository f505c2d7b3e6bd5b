/* A minimal C host of a model-exchange FMU for the tests (tests/test_native_me.py): load the binary
 * (FMI 2.0 or 3.0, told apart by its fmi3InstantiateModelExchange), instantiate for model exchange, set
 * the Real parameters and inputs given on the command line, initialize, end the event iteration, then
 * integrate with the classical RK4 at a fixed step (the arithmetic of satmotor/machine/integrate.py)
 * over the FMU's derivatives with those constant inputs, and print the outputs.  No Python anywhere.
 * dlopen on Linux/macOS; LoadLibrary under _WIN32 (zig cc -target x86_64-windows-gnu, run under wine).
 * usage: native_me_host LIB TOKEN RESOURCES STEPS H VR=VALUE... -- OUT_VR...  (Real/Float64 variables)
 * exit status: 0 ok, 2 usage or loading, 3 instantiation, 4 set, 5 initialization, 6 integration, 7 get. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <windows.h>
#else
#include <dlfcn.h>
#endif

#include "fmi2Functions.h"
#include "fmi3Functions.h"

#define NX_MAX 64
#define SYM(lib, T, name) ((T)lib_symbol(lib, name))

typedef void (*Symbol)(void);

#ifdef _WIN32
typedef HMODULE Library;
static Library lib_open(const char *path) { return LoadLibraryA(path); }
static Symbol lib_symbol(Library lib, const char *name) { return (Symbol)GetProcAddress(lib, name); }
static void lib_close(Library lib) { FreeLibrary(lib); }
#else
typedef void *Library;
static Library lib_open(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static Symbol lib_symbol(Library lib, const char *name)
{
    void *p = dlsym(lib, name);
    Symbol f;
    memcpy(&f, &p, sizeof f);
    return f;
}
static void lib_close(Library lib) { dlclose(lib); }
#endif

/* the FMU pre-formats its messages: print the format as text */
static void logger2(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                    fmi2String message, ...)
{
    (void)env;
    (void)category;
    fprintf(stderr, "[%s] status %d: %s\n", name, (int)status, message);
}

static void logger3(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message)
{
    (void)env;
    (void)category;
    fprintf(stderr, "[host] status %d: %s\n", (int)status, message);
}

static int parse_assignment(const char *arg, unsigned int *vr, double *value)
{
    const char *eq = strchr(arg, '=');
    char *end;
    if (eq == NULL) return 0;
    *vr = (unsigned int)strtoul(arg, &end, 10);
    if (end != eq) return 0;
    *value = strtod(eq + 1, &end);
    return end != eq + 1 && *end == '\0';
}

/* the model-exchange calls of either FMI version, resolved once */
typedef struct {
    int v3;
    void *c;
    fmi2SetTimeTYPE *set_time2;
    fmi2SetContinuousStatesTYPE *set_x2;
    fmi2GetContinuousStatesTYPE *get_x2;
    fmi2GetDerivativesTYPE *get_dx2;
    fmi2CompletedIntegratorStepTYPE *completed2;
    fmi3SetTimeTYPE *set_time3;
    fmi3SetContinuousStatesTYPE *set_x3;
    fmi3GetContinuousStatesTYPE *get_x3;
    fmi3GetContinuousStateDerivativesTYPE *get_dx3;
    fmi3CompletedIntegratorStepTYPE *completed3;
} me_calls;

static int resolve(me_calls *m, Library lib)
{
    if (m->v3) {
        m->set_time3 = (fmi3SetTimeTYPE *)lib_symbol(lib, "fmi3SetTime");
        m->set_x3 = (fmi3SetContinuousStatesTYPE *)lib_symbol(lib, "fmi3SetContinuousStates");
        m->get_x3 = (fmi3GetContinuousStatesTYPE *)lib_symbol(lib, "fmi3GetContinuousStates");
        m->get_dx3 = (fmi3GetContinuousStateDerivativesTYPE *)lib_symbol(lib, "fmi3GetContinuousStateDerivatives");
        m->completed3 = (fmi3CompletedIntegratorStepTYPE *)lib_symbol(lib, "fmi3CompletedIntegratorStep");
        return m->set_time3 && m->set_x3 && m->get_x3 && m->get_dx3 && m->completed3;
    }
    m->set_time2 = (fmi2SetTimeTYPE *)lib_symbol(lib, "fmi2SetTime");
    m->set_x2 = (fmi2SetContinuousStatesTYPE *)lib_symbol(lib, "fmi2SetContinuousStates");
    m->get_x2 = (fmi2GetContinuousStatesTYPE *)lib_symbol(lib, "fmi2GetContinuousStates");
    m->get_dx2 = (fmi2GetDerivativesTYPE *)lib_symbol(lib, "fmi2GetDerivatives");
    m->completed2 = (fmi2CompletedIntegratorStepTYPE *)lib_symbol(lib, "fmi2CompletedIntegratorStep");
    return m->set_time2 && m->set_x2 && m->get_x2 && m->get_dx2 && m->completed2;
}

/* each: 1 on a failed call */
static int set_time(const me_calls *m, double t)
{
    return m->v3 ? m->set_time3(m->c, t) > fmi3Warning : m->set_time2(m->c, t) > fmi2Warning;
}
static int set_x(const me_calls *m, const double *x, size_t n)
{
    return m->v3 ? m->set_x3(m->c, x, n) > fmi3Warning : m->set_x2(m->c, x, n) > fmi2Warning;
}
static int get_x(const me_calls *m, double *x, size_t n)
{
    return m->v3 ? m->get_x3(m->c, x, n) > fmi3Warning : m->get_x2(m->c, x, n) > fmi2Warning;
}
static int get_dx(const me_calls *m, double *dx, size_t n)
{
    return m->v3 ? m->get_dx3(m->c, dx, n) > fmi3Warning : m->get_dx2(m->c, dx, n) > fmi2Warning;
}
static int completed(const me_calls *m)
{
    if (m->v3) {
        fmi3Boolean event = fmi3False, terminate = fmi3False;
        return m->completed3(m->c, fmi3True, &event, &terminate) > fmi3Warning || event || terminate;
    } else {
        fmi2Boolean event = fmi2False, terminate = fmi2False;
        return m->completed2(m->c, fmi2True, &event, &terminate) > fmi2Warning || event || terminate;
    }
}

/* RK4 steps of h from t = 0 (satmotor/machine/integrate.py rk4, n_sub = 1) */
static int integrate(const me_calls *m, size_t nx, int steps, double h)
{
    double x[NX_MAX], xt[NX_MAX], k1[NX_MAX], k2[NX_MAX], k3[NX_MAX], k4[NX_MAX];
    double half = 0.5 * h, sixth = h / 6.0, t;
    size_t i;
    int k;
    if (nx > NX_MAX || get_x(m, x, nx)) return 1;
    for (k = 0; k < steps; ++k) {
        t = k * h;
        if (set_time(m, t) || set_x(m, x, nx) || get_dx(m, k1, nx)) return 1;
        for (i = 0; i < nx; ++i) xt[i] = x[i] + half * k1[i];
        if (set_time(m, t + half) || set_x(m, xt, nx) || get_dx(m, k2, nx)) return 1;
        for (i = 0; i < nx; ++i) xt[i] = x[i] + half * k2[i];
        if (set_x(m, xt, nx) || get_dx(m, k3, nx)) return 1;
        for (i = 0; i < nx; ++i) xt[i] = x[i] + h * k3[i];
        if (set_time(m, t + h) || set_x(m, xt, nx) || get_dx(m, k4, nx)) return 1;
        for (i = 0; i < nx; ++i) x[i] = x[i] + sixth * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        if (set_x(m, x, nx) || completed(m)) return 1;
    }
    return 0;
}

static int run_fmi2(Library lib, int argc, char **argv, int steps, double h, int sep, size_t nx)
{
    fmi2CallbackFunctions cb = {logger2, calloc, free, NULL, NULL};
    fmi2EventInfo ei;
    me_calls m;
    int i, rc = 0;
    fmi2InstantiateTYPE *instantiate = (fmi2InstantiateTYPE *)lib_symbol(lib, "fmi2Instantiate");
    fmi2SetRealTYPE *set_real = (fmi2SetRealTYPE *)lib_symbol(lib, "fmi2SetReal");
    fmi2GetRealTYPE *get_real = (fmi2GetRealTYPE *)lib_symbol(lib, "fmi2GetReal");
    fmi2FreeInstanceTYPE *free_instance = (fmi2FreeInstanceTYPE *)lib_symbol(lib, "fmi2FreeInstance");
    memset(&m, 0, sizeof m);
    if (!resolve(&m, lib) || !instantiate || !set_real || !get_real || !free_instance) return 2;
    m.c = instantiate("host", fmi2ModelExchange, argv[2], argv[3], &cb, fmi2False, fmi2True);
    if (m.c == NULL) return 3;
    for (i = 6; i < sep && rc == 0; ++i) {
        fmi2ValueReference vr;
        fmi2Real v;
        if (!parse_assignment(argv[i], &vr, &v) || set_real(m.c, &vr, 1, &v) > fmi2Warning) rc = 4;
    }
    if (rc == 0 &&
        (SYM(lib, fmi2SetupExperimentTYPE *, "fmi2SetupExperiment")(m.c, fmi2False, 0.0, 0.0, fmi2False, 0.0) > fmi2Warning ||
         SYM(lib, fmi2EnterInitializationModeTYPE *, "fmi2EnterInitializationMode")(m.c) > fmi2Warning ||
         SYM(lib, fmi2ExitInitializationModeTYPE *, "fmi2ExitInitializationMode")(m.c) > fmi2Warning))
        rc = 5;
    if (rc == 0) {
        do {
            if (SYM(lib, fmi2NewDiscreteStatesTYPE *, "fmi2NewDiscreteStates")(m.c, &ei) > fmi2Warning) rc = 5;
        } while (rc == 0 && ei.newDiscreteStatesNeeded);
    }
    if (rc == 0 && SYM(lib, fmi2EnterContinuousTimeModeTYPE *, "fmi2EnterContinuousTimeMode")(m.c) > fmi2Warning) rc = 5;
    if (rc == 0 && integrate(&m, nx, steps, h)) rc = 6;
    for (i = sep + 1; i < argc && rc == 0; ++i) {
        fmi2ValueReference vr = (fmi2ValueReference)strtoul(argv[i], NULL, 10);
        fmi2Real v;
        if (get_real(m.c, &vr, 1, &v) > fmi2Warning) rc = 7;
        else printf("%.17g\n", v);
    }
    if (rc == 0) SYM(lib, fmi2TerminateTYPE *, "fmi2Terminate")(m.c);
    free_instance(m.c);
    return rc;
}

static int run_fmi3(Library lib, int argc, char **argv, int steps, double h, int sep, size_t nx)
{
    me_calls m;
    int i, rc = 0;
    fmi3Boolean need = fmi3False, term, nom, val, defined;
    fmi3Float64 next;
    fmi3InstantiateModelExchangeTYPE *instantiate =
        (fmi3InstantiateModelExchangeTYPE *)lib_symbol(lib, "fmi3InstantiateModelExchange");
    fmi3SetFloat64TYPE *set_real = (fmi3SetFloat64TYPE *)lib_symbol(lib, "fmi3SetFloat64");
    fmi3GetFloat64TYPE *get_real = (fmi3GetFloat64TYPE *)lib_symbol(lib, "fmi3GetFloat64");
    fmi3FreeInstanceTYPE *free_instance = (fmi3FreeInstanceTYPE *)lib_symbol(lib, "fmi3FreeInstance");
    memset(&m, 0, sizeof m);
    m.v3 = 1;
    if (!resolve(&m, lib) || !instantiate || !set_real || !get_real || !free_instance) return 2;
    m.c = instantiate("host", argv[2], argv[3], fmi3False, fmi3True, NULL, logger3);
    if (m.c == NULL) return 3;
    for (i = 6; i < sep && rc == 0; ++i) {
        fmi3ValueReference vr;
        fmi3Float64 v;
        if (!parse_assignment(argv[i], &vr, &v) || set_real(m.c, &vr, 1, &v, 1) > fmi3Warning) rc = 4;
    }
    if (rc == 0 &&
        (SYM(lib, fmi3EnterInitializationModeTYPE *, "fmi3EnterInitializationMode")(m.c, fmi3False, 0.0, 0.0, fmi3False,
                                                                             0.0) > fmi3Warning ||
         SYM(lib, fmi3ExitInitializationModeTYPE *, "fmi3ExitInitializationMode")(m.c) > fmi3Warning))
        rc = 5;
    if (rc == 0) {
        do {
            if (SYM(lib, fmi3UpdateDiscreteStatesTYPE *, "fmi3UpdateDiscreteStates")(m.c, &need, &term, &nom, &val,
                                                                               &defined, &next) > fmi3Warning)
                rc = 5;
        } while (rc == 0 && need);
    }
    if (rc == 0 && SYM(lib, fmi3EnterContinuousTimeModeTYPE *, "fmi3EnterContinuousTimeMode")(m.c) > fmi3Warning) rc = 5;
    if (rc == 0 && integrate(&m, nx, steps, h)) rc = 6;
    for (i = sep + 1; i < argc && rc == 0; ++i) {
        fmi3ValueReference vr = (fmi3ValueReference)strtoul(argv[i], NULL, 10);
        fmi3Float64 v;
        if (get_real(m.c, &vr, 1, &v, 1) > fmi3Warning) rc = 7;
        else printf("%.17g\n", v);
    }
    if (rc == 0) SYM(lib, fmi3TerminateTYPE *, "fmi3Terminate")(m.c);
    free_instance(m.c);
    return rc;
}

int main(int argc, char **argv)
{
    Library lib;
    int steps, sep, rc;
    double h;
    size_t nx = 11; /* the plant's (STATES of orchestration/packaging/native/model_exchange.py) */
    if (argc < 7) {
        fprintf(stderr, "usage: %s LIB TOKEN RESOURCES STEPS H VR=VALUE... -- OUT_VR...\n", argv[0]);
        return 2;
    }
    for (sep = 6; sep < argc && strcmp(argv[sep], "--") != 0; ++sep) {
    }
    steps = atoi(argv[4]);
    h = atof(argv[5]);
    lib = lib_open(argv[1]);
    if (lib == NULL) {
        fprintf(stderr, "cannot load %s\n", argv[1]);
        return 2;
    }
    if (lib_symbol(lib, "fmi3InstantiateModelExchange") != NULL) {
        rc = run_fmi3(lib, argc, argv, steps, h, sep, nx);
    } else {
        rc = run_fmi2(lib, argc, argv, steps, h, sep, nx);
    }
    fflush(stdout);
    lib_close(lib);
    return rc;
}

/* A minimal C host for the tests: load a native FMU's binary (FMI 2.0 or 3.0, told apart by its
 * fmi3InstantiateCoSimulation), instantiate, set the Real parameters and inputs given on the command
 * line, step it with those constant inputs and print the outputs. No Python anywhere: this is how a
 * C/C++ tool loads our native FMUs (and, with libpython preloaded into it, the pythonfmu ones:
 * tests/test_host_pythonfmu.py). dlopen on Linux/macOS; LoadLibrary under _WIN32 (built with
 * `python -m ziglang cc -target x86_64-windows-gnu` and run under wine: tests/test_native_windows.py).
 * usage: native_c_host LIB TOKEN RESOURCES STEPS H VR=VALUE... -- OUT_VR...  (Real/Float64 variables)
 * RESOURCES: the resources URI (FMI 2.0) or the resources directory path (FMI 3.0).
 * STEPS may be @FILE, a table of inputs: "M VR_1 .. VR_M" then rows of M values, row k set before
 * the step from t_k; then the outputs are printed at every communication point, a line each. 
 * exit status: 0 ok, 2 usage or loading, 3 instantiation, 4 set, 5 initialization, 6 step, 7 get. */
#include <stdarg.h>
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

/* a function address; cast to the right type before the call (ISO C has no void * for functions) */
typedef void (*Symbol)(void);

#ifdef _WIN32
typedef HMODULE Library;

static Library lib_open(const char *path)
{
    return LoadLibraryA(path);
}

static Symbol lib_symbol(Library lib, const char *name)
{
    return (Symbol)GetProcAddress(lib, name);
}

static void lib_close(Library lib)
{
    FreeLibrary(lib);
}

static void lib_report(const char *path)
{
    fprintf(stderr, "LoadLibrary: %s: error %lu\n", path, (unsigned long)GetLastError());
}
#else
typedef void *Library;

static Library lib_open(const char *path)
{
    return dlopen(path, RTLD_NOW | RTLD_LOCAL);
}

static Symbol lib_symbol(Library lib, const char *name)
{
    void *p = dlsym(lib, name);
    Symbol f;
    memcpy(&f, &p, sizeof f); /* the POSIX way from dlsym's void * to a function address */
    return f;
}

static void lib_close(Library lib)
{
    dlclose(lib);
}

static void lib_report(const char *path)
{
    (void)path; /* dlerror names it */
    fprintf(stderr, "dlopen: %s\n", dlerror());
}
#endif

static void logger2(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
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

static void logger3(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message)
{
    (void)env;
    (void)category;
    fprintf(stderr, "[host] status %d: %s\n", (int)status, message);
}

/* VR=VALUE -> the value reference and the value; 0 if malformed */
static int parse_assignment(const char *arg, unsigned int *vr, double *value)
{
    const char *eq = strchr(arg, '=');
    char *end;
    if (eq == NULL) {
        return 0;
    }
    *vr = (unsigned int)strtoul(arg, &end, 10);
    if (end != eq) {
        return 0;
    }
    *value = strtod(eq + 1, &end);
    return end != eq + 1 && *end == '\0';
}

/* the inputs of STEPS = @FILE: n_rows rows of n_in values for the value references vr */
typedef struct {
    int n_in, n_rows;
    unsigned int vr[64];
    double *v;
} Table;

static int read_table(const char *path, Table *t)
{
    FILE *f = fopen(path, "r");
    int j, cap = 1024;
    double x;
    t->n_rows = 0;
    t->v = NULL;
    if (f == NULL || fscanf(f, "%d", &t->n_in) != 1 || t->n_in < 1 || t->n_in > 64) {
        if (f != NULL) fclose(f);
        return 0;
    }
    for (j = 0; j < t->n_in; ++j)
        if (fscanf(f, "%u", &t->vr[j]) != 1) {
            fclose(f);
            return 0;
        }
    t->v = malloc(sizeof(double) * (size_t)cap * (size_t)t->n_in);
    for (j = 0; t->v != NULL && fscanf(f, "%lf", &x) == 1; ++j) {
        if (j == cap * t->n_in) {
            double *w = realloc(t->v, sizeof(double) * (size_t)(cap *= 2) * (size_t)t->n_in);
            if (w == NULL) break;
            t->v = w;
        }
        t->v[j] = x;
    }
    fclose(f);
    t->n_rows = j / t->n_in;
    return t->v != NULL && j % t->n_in == 0;
}

#define LOAD(prefix, name) prefix##name##TYPE *name = (prefix##name##TYPE *)lib_symbol(lib, #prefix #name); \
    if (name == NULL) { fprintf(stderr, "no " #prefix #name "\n"); return 2; }

static int run_fmi2(Library lib, int argc, char **argv, int steps, double h, int sep, const Table *t)
{
    fmi2CallbackFunctions cb = {logger2, calloc, free, NULL, NULL};
    fmi2Component c;
    int k, i;
    LOAD(fmi2, Instantiate) LOAD(fmi2, SetupExperiment) LOAD(fmi2, EnterInitializationMode)
    LOAD(fmi2, ExitInitializationMode) LOAD(fmi2, SetReal) LOAD(fmi2, GetReal) LOAD(fmi2, DoStep)
    LOAD(fmi2, Terminate) LOAD(fmi2, FreeInstance)
    c = Instantiate("host", fmi2CoSimulation, argv[2], argv[3], &cb, fmi2False, fmi2True);
    if (c == NULL) {
        fprintf(stderr, "instantiate failed\n");
        return 3;
    }
    for (i = 6; i < sep; ++i) {
        fmi2ValueReference vr;
        fmi2Real v;
        if (!parse_assignment(argv[i], &vr, &v) || SetReal(c, &vr, 1, &v) > fmi2Warning) {
            FreeInstance(c);
            return 4;
        }
    }
    if (SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) > fmi2Warning ||
        EnterInitializationMode(c) > fmi2Warning || ExitInitializationMode(c) > fmi2Warning) {
        FreeInstance(c);
        return 5;
    }
    for (k = 0; k <= steps; ++k) {
        if (t != NULL || k == steps) {
            for (i = sep + 1; i < argc; ++i) {
                fmi2ValueReference vr = (fmi2ValueReference)strtoul(argv[i], NULL, 10);
                fmi2Real v;
                if (GetReal(c, &vr, 1, &v) > fmi2Warning) {
                    FreeInstance(c);
                    return 7;
                }
                printf(t != NULL ? (i + 1 < argc ? "%.17g " : "%.17g\n") : "%.17g\n", v);
            }
        }
        if (k == steps) break;
        if ((t != NULL && SetReal(c, t->vr, (size_t)t->n_in, t->v + (size_t)k * (size_t)t->n_in) > fmi2Warning)
            || DoStep(c, k * h, h, fmi2True) > fmi2Warning) {
            FreeInstance(c);
            return 6;
        }
    }
    Terminate(c);
    FreeInstance(c);
    return 0;
}

static int run_fmi3(Library lib, int argc, char **argv, int steps, double h, int sep, const Table *t)
{
    fmi3Instance c;
    int k, i;
    LOAD(fmi3, InstantiateCoSimulation) LOAD(fmi3, EnterInitializationMode) LOAD(fmi3, ExitInitializationMode)
    LOAD(fmi3, SetFloat64) LOAD(fmi3, GetFloat64) LOAD(fmi3, DoStep) LOAD(fmi3, Terminate) LOAD(fmi3, FreeInstance)
    c = InstantiateCoSimulation("host", argv[2], argv[3], fmi3False, fmi3True, fmi3False, fmi3False, NULL, 0,
                                NULL, logger3, NULL);
    if (c == NULL) {
        fprintf(stderr, "instantiate failed\n");
        return 3;
    }
    for (i = 6; i < sep; ++i) {
        fmi3ValueReference vr;
        fmi3Float64 v;
        if (!parse_assignment(argv[i], &vr, &v) || SetFloat64(c, &vr, 1, &v, 1) > fmi3Warning) {
            FreeInstance(c);
            return 4;
        }
    }
    if (EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3False, 0.0) > fmi3Warning ||
        ExitInitializationMode(c) > fmi3Warning) {
        FreeInstance(c);
        return 5;
    }
    for (k = 0; k <= steps; ++k) {
        fmi3Boolean event, terminate, early;
        fmi3Float64 last;
        if (t != NULL || k == steps) {
            for (i = sep + 1; i < argc; ++i) {
                fmi3ValueReference vr = (fmi3ValueReference)strtoul(argv[i], NULL, 10);
                fmi3Float64 v;
                if (GetFloat64(c, &vr, 1, &v, 1) > fmi3Warning) {
                    FreeInstance(c);
                    return 7;
                }
                printf(t != NULL ? (i + 1 < argc ? "%.17g " : "%.17g\n") : "%.17g\n", v);
            }
        }
        if (k == steps) break;
        if ((t != NULL && SetFloat64(c, t->vr, (size_t)t->n_in, t->v + (size_t)k * (size_t)t->n_in,
                                     (size_t)t->n_in) > fmi3Warning)
            || DoStep(c, k * h, h, fmi3True, &event, &terminate, &early, &last) > fmi3Warning) {
            FreeInstance(c);
            return 6;
        }
    }
    Terminate(c);
    FreeInstance(c);
    return 0;
}

int main(int argc, char **argv)
{
    Library lib;
    int steps, sep, rc;
    double h;
    Table table, *t = NULL;
    if (argc < 7) {
        fprintf(stderr, "usage: %s LIB TOKEN RESOURCES STEPS H VR=VALUE... -- OUT_VR...\n", argv[0]);
        return 2;
    }
    sep = 6;
    while (sep < argc && strcmp(argv[sep], "--") != 0) {
        ++sep;
    }
    if (argv[4][0] == '@') {
        if (!read_table(argv[4] + 1, &table)) {
            fprintf(stderr, "cannot read the inputs table %s\n", argv[4] + 1);
            free(table.v);
            return 2;
        }
        t = &table;
        steps = table.n_rows;
    } else {
        steps = atoi(argv[4]);
    }
    h = atof(argv[5]);
    lib = lib_open(argv[1]);
    if (lib == NULL) {
        lib_report(argv[1]);
        free(t != NULL ? t->v : NULL);
        return 2;
    }
    if (lib_symbol(lib, "fmi3InstantiateCoSimulation") != NULL) {
        rc = run_fmi3(lib, argc, argv, steps, h, sep, t);
    } else {
        rc = run_fmi2(lib, argc, argv, steps, h, sep, t);
    }
    fflush(stdout);
    lib_close(lib);
    free(t != NULL ? t->v : NULL);
    return rc;
}

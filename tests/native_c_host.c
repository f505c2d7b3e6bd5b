/* A minimal C host for the tests: load a native FMU's binary (FMI 2.0 or 3.0, told apart by its
 * fmi3InstantiateCoSimulation), instantiate, set the Real parameters and inputs given on the command
 * line, step it with those constant inputs and print the outputs. No Python anywhere: this is how a
 * C/C++ tool loads our native FMUs (and, with libpython preloaded into it, the pythonfmu ones:
 * tests/test_host_pythonfmu.py). dlopen on Linux/macOS; LoadLibrary under _WIN32 (built with
 * `python -m ziglang cc -target x86_64-windows-gnu` and run under wine: tests/test_native_windows.py).
 * usage: native_c_host LIB TOKEN RESOURCES STEPS H VR=VALUE... -- OUT_VR...  (Real/Float64 variables)
 * RESOURCES: the resources URI (FMI 2.0) or the resources directory path (FMI 3.0).
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

#define LOAD(prefix, name) prefix##name##TYPE *name = (prefix##name##TYPE *)lib_symbol(lib, #prefix #name); \
    if (name == NULL) { fprintf(stderr, "no " #prefix #name "\n"); return 2; }

static int run_fmi2(Library lib, int argc, char **argv, int steps, double h, int sep)
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
    for (k = 0; k < steps; ++k) {
        if (DoStep(c, k * h, h, fmi2True) > fmi2Warning) {
            FreeInstance(c);
            return 6;
        }
    }
    for (i = sep + 1; i < argc; ++i) {
        fmi2ValueReference vr = (fmi2ValueReference)strtoul(argv[i], NULL, 10);
        fmi2Real v;
        if (GetReal(c, &vr, 1, &v) > fmi2Warning) {
            FreeInstance(c);
            return 7;
        }
        printf("%.17g\n", v);
    }
    Terminate(c);
    FreeInstance(c);
    return 0;
}

static int run_fmi3(Library lib, int argc, char **argv, int steps, double h, int sep)
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
    for (k = 0; k < steps; ++k) {
        fmi3Boolean event, terminate, early;
        fmi3Float64 last;
        if (DoStep(c, k * h, h, fmi3True, &event, &terminate, &early, &last) > fmi3Warning) {
            FreeInstance(c);
            return 6;
        }
    }
    for (i = sep + 1; i < argc; ++i) {
        fmi3ValueReference vr = (fmi3ValueReference)strtoul(argv[i], NULL, 10);
        fmi3Float64 v;
        if (GetFloat64(c, &vr, 1, &v, 1) > fmi3Warning) {
            FreeInstance(c);
            return 7;
        }
        printf("%.17g\n", v);
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
    if (argc < 7) {
        fprintf(stderr, "usage: %s LIB TOKEN RESOURCES STEPS H VR=VALUE... -- OUT_VR...\n", argv[0]);
        return 2;
    }
    sep = 6;
    while (sep < argc && strcmp(argv[sep], "--") != 0) {
        ++sep;
    }
    steps = atoi(argv[4]);
    h = atof(argv[5]);
    lib = lib_open(argv[1]);
    if (lib == NULL) {
        lib_report(argv[1]);
        return 2;
    }
    if (lib_symbol(lib, "fmi3InstantiateCoSimulation") != NULL) {
        rc = run_fmi3(lib, argc, argv, steps, h, sep);
    } else {
        rc = run_fmi2(lib, argc, argv, steps, h, sep);
    }
    fflush(stdout);
    lib_close(lib);
    return rc;
}

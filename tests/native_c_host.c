/* A minimal C host for the tests: dlopen a native FMU's binary (FMI 2.0), instantiate, set the
 * parameters given on the command line, step it with constant inputs and print the outputs.
 * No Python anywhere: this is how a C/C++ tool loads our native FMUs (and, with libpython preloaded
 * into it, the pythonfmu ones: tests/test_host_pythonfmu.py).
 * usage: native_c_host LIB GUID RESOURCE_URI STEPS H VR=VALUE... -- OUT_VR...  (Real variables) */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

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

#define LOAD(name) fmi2##name##TYPE *name = (fmi2##name##TYPE *)dlsym(lib, "fmi2" #name); \
    if (name == NULL) { fprintf(stderr, "no fmi2" #name "\n"); return 2; }

int main(int argc, char **argv)
{
    void *lib;
    fmi2Component c;
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    int steps, k, i, sep;
    double h;
    if (argc < 7) {
        fprintf(stderr, "usage: %s LIB GUID RESOURCE_URI STEPS H VR=VALUE... -- OUT_VR...\n", argv[0]);
        return 2;
    }
    lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (lib == NULL) {
        fprintf(stderr, "dlopen: %s\n", dlerror());
        return 2;
    }
    {
        LOAD(Instantiate) LOAD(SetupExperiment) LOAD(EnterInitializationMode) LOAD(ExitInitializationMode)
        LOAD(SetReal) LOAD(GetReal) LOAD(DoStep) LOAD(Terminate) LOAD(FreeInstance)
        steps = atoi(argv[4]);
        h = atof(argv[5]);
        c = Instantiate("host", fmi2CoSimulation, argv[2], argv[3], &cb, fmi2False, fmi2True);
        if (c == NULL) {
            fprintf(stderr, "instantiate failed\n");
            return 3;
        }
        for (sep = 6; sep < argc && strcmp(argv[sep], "--") != 0; ++sep) {
            fmi2ValueReference vr = (fmi2ValueReference)strtoul(argv[sep], NULL, 10);
            fmi2Real v = atof(strchr(argv[sep], '=') + 1);
            if (SetReal(c, &vr, 1, &v) > fmi2Warning) {
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
            GetReal(c, &vr, 1, &v);
            printf("%.17g\n", v);
        }
        Terminate(c);
        FreeInstance(c);
    }
    dlclose(lib);
    return 0;
}

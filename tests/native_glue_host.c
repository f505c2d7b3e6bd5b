/* tests/native_glue_host.c - a host for test_native_glue.py (sanitizer and valgrind runs): the glue and the
 * test model linked in, FMI 2 or (-DHOST_FMI3) FMI 3 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef HOST_FMI3
#include "fmi3Functions.h"
#else
#include "fmi2Functions.h"
#endif

static int n_messages;
#define CHECK(cond) do { if (!(cond)) { printf("FAIL line %d: %s\n", __LINE__, #cond); return 1; } } while (0)

static const unsigned VR_U = 1, VR_HOLD = 2, VR_TAU = 3, VR_LABEL = 5, VR_Y = 6, VR_STEPS = 7, VR_RISING = 8;

#ifdef HOST_FMI3
static void logger(fmi3InstanceEnvironment env, fmi3Status s, fmi3String cat, fmi3String msg)
{
    (void)env;
    n_messages++;
    printf("[%d %s] %s\n", (int)s, cat, msg);
}

static int run(int k)
{
    fmi3Instance c;
    fmi3Boolean ev, term, early, hold = fmi3False, rising;
    fmi3Float64 last, tau = 0.25 + 0.1 * k, u = 1.0, y, t = 0.0, nan_ = NAN;
    fmi3FMUState s = NULL, s2 = NULL;
    fmi3String lbl = "asan", got;
    fmi3Int32 steps;
    char longlabel[300];
    size_t size;
    unsigned char *buf;
    int i;
    memset(longlabel, 'x', sizeof longlabel - 1);
    longlabel[sizeof longlabel - 1] = '\0';
    CHECK(fmi3InstantiateCoSimulation("bad", "{wrong}", NULL, fmi3False, fmi3False, fmi3False, fmi3False, NULL, 0, NULL,
                                      logger, NULL) == NULL);
    CHECK(fmi3InstantiateModelExchange("me", INSTANTIATION_TOKEN, NULL, fmi3False, fmi3False, NULL, logger) == NULL);
    c = fmi3InstantiateCoSimulation("a", INSTANTIATION_TOKEN, "/tmp/res/", fmi3False, fmi3True, fmi3False,
                                    fmi3False, NULL, 0, NULL, logger, NULL);
    CHECK(c != NULL);
    CHECK(fmi3DoStep(c, 0, 0.1, fmi3True, &ev, &term, &early, &last) == fmi3Error);
    CHECK(fmi3DoStep(NULL, 0, 0.1, fmi3True, &ev, &term, &early, &last) == fmi3Error);
    CHECK(fmi3GetFloat64(c, NULL, 1, NULL, 1) == fmi3Error);
    CHECK(fmi3EnterEventMode(c) == fmi3Error);
    CHECK(fmi3SetFloat64(c, &VR_TAU, 1, &tau, 1) == fmi3OK);
    CHECK(fmi3SetString(c, &VR_LABEL, 1, &lbl, 1) == fmi3OK);
    lbl = longlabel;
    CHECK(fmi3SetString(c, &VR_LABEL, 1, &lbl, 1) == fmi3Error);
    CHECK(fmi3SetBoolean(c, &VR_HOLD, 1, &hold, 1) == fmi3OK);
    CHECK(fmi3EnterInitializationMode(c, fmi3False, 0, 0, fmi3False, 0) == fmi3OK);
    CHECK(fmi3ExitInitializationMode(c) == fmi3OK);
    CHECK(fmi3SetFloat64(c, &VR_TAU, 1, &tau, 1) == fmi3Error);
    CHECK(fmi3SetFloat64(c, &VR_U, 1, &u, 1) == fmi3OK);
    for (i = 0; i < 100; i++, t += 0.01) CHECK(fmi3DoStep(c, t, 0.01, fmi3True, &ev, &term, &early, &last) == fmi3OK);
    CHECK(fmi3GetFloat64(c, &VR_Y, 1, &y, 1) == fmi3OK);
    CHECK(fabs(y - (1 - exp(-1.0 / tau))) < 1e-12);
    CHECK(fmi3GetInt32(c, &VR_STEPS, 1, &steps, 1) == fmi3OK && steps == 100);
    CHECK(fmi3GetBoolean(c, &VR_RISING, 1, &rising, 1) == fmi3OK && rising);
    CHECK(fmi3GetString(c, &VR_LABEL, 1, &got, 1) == fmi3OK && strcmp(got, "asan") == 0);
    CHECK(fmi3GetFMUState(c, &s) == fmi3OK);
    CHECK(fmi3SerializedFMUStateSize(c, s, &size) == fmi3OK);
    buf = (unsigned char *)malloc(size);
    CHECK(fmi3SerializeFMUState(c, s, buf, size) == fmi3OK);
    CHECK(fmi3DoStep(c, t, 0.5, fmi3True, &ev, &term, &early, &last) == fmi3OK);
    CHECK(fmi3DeserializeFMUState(c, buf, size - 1, &s2) == fmi3Error && s2 == NULL);
    buf[30] ^= 1;
    CHECK(fmi3DeserializeFMUState(c, buf, size, &s2) == fmi3Error && s2 == NULL);
    buf[30] ^= 1;
    CHECK(fmi3DeserializeFMUState(c, buf, size, &s2) == fmi3OK);
    CHECK(fmi3SetFMUState(c, s2) == fmi3OK);
    CHECK(fmi3GetFMUState(c, &s2) == fmi3OK);
    CHECK(fmi3SerializeFMUState(c, s2, buf, size) == fmi3OK);
    CHECK(fmi3FreeFMUState(c, &s) == fmi3OK && fmi3FreeFMUState(c, &s2) == fmi3OK);
    free(buf);
    CHECK(fmi3SetFloat64(c, &VR_U, 1, &nan_, 1) == fmi3OK);
    CHECK(fmi3DoStep(c, t, 0.01, fmi3True, &ev, &term, &early, &last) == fmi3Discard);
    CHECK(fmi3DoStep(c, t, 0.01, fmi3True, &ev, &term, &early, &last) == fmi3Error);
    CHECK(fmi3Terminate(c) == fmi3OK);
    CHECK(fmi3Reset(c) == fmi3OK);
    fmi3FreeInstance(c);
    return 0;
}
#else
static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status s, fmi2String cat, fmi2String msg, ...)
{
    (void)env;
    n_messages++;
    printf("[%s %d %s] %s\n", name, (int)s, cat, msg);
}

static int run(int k)
{
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c;
    fmi2Real tau = 0.25 + 0.1 * k, u = 1.0, y, t = 0.0, nan_ = NAN;
    fmi2FMUstate s = NULL, s2 = NULL;
    fmi2String lbl = "asan", got;
    fmi2Integer steps;
    fmi2Boolean hold = fmi2False, rising;
    char longlabel[300];
    size_t size;
    fmi2Byte *buf;
    int i;
    memset(longlabel, 'x', sizeof longlabel - 1);
    longlabel[sizeof longlabel - 1] = '\0';
    CHECK(fmi2Instantiate("bad", fmi2CoSimulation, "{wrong}", NULL, &cb, fmi2False, fmi2False) == NULL);
    CHECK(fmi2Instantiate("me", fmi2ModelExchange, INSTANTIATION_TOKEN, NULL, &cb, fmi2False, fmi2False) == NULL);
    c = fmi2Instantiate("a", fmi2CoSimulation, INSTANTIATION_TOKEN, "file:///tmp/r%20s/", &cb, fmi2False, fmi2True);
    CHECK(c != NULL);
    CHECK(fmi2DoStep(c, 0, 0.1, fmi2True) == fmi2Error);
    CHECK(fmi2DoStep(NULL, 0, 0.1, fmi2True) == fmi2Error);
    CHECK(fmi2GetReal(c, NULL, 1, NULL) == fmi2Error);
    CHECK(fmi2GetDirectionalDerivative(c, NULL, 0, NULL, 0, NULL, NULL) == fmi2Error);
    CHECK(fmi2SetReal(c, &VR_TAU, 1, &tau) == fmi2OK);
    CHECK(fmi2SetString(c, &VR_LABEL, 1, &lbl) == fmi2OK);
    lbl = longlabel;
    CHECK(fmi2SetString(c, &VR_LABEL, 1, &lbl) == fmi2Error);
    CHECK(fmi2SetBoolean(c, &VR_HOLD, 1, &hold) == fmi2OK);
    CHECK(fmi2SetupExperiment(c, fmi2False, 0, 0, fmi2False, 0) == fmi2OK);
    CHECK(fmi2EnterInitializationMode(c) == fmi2OK);
    CHECK(fmi2ExitInitializationMode(c) == fmi2OK);
    CHECK(fmi2SetReal(c, &VR_TAU, 1, &tau) == fmi2Error);
    CHECK(fmi2SetReal(c, &VR_U, 1, &u) == fmi2OK);
    for (i = 0; i < 100; i++, t += 0.01) CHECK(fmi2DoStep(c, t, 0.01, fmi2True) == fmi2OK);
    CHECK(fmi2GetReal(c, &VR_Y, 1, &y) == fmi2OK);
    CHECK(fabs(y - (1 - exp(-1.0 / tau))) < 1e-12);
    CHECK(fmi2GetInteger(c, &VR_STEPS, 1, &steps) == fmi2OK && steps == 100);
    CHECK(fmi2GetBoolean(c, &VR_RISING, 1, &rising) == fmi2OK && rising);
    CHECK(fmi2GetString(c, &VR_LABEL, 1, &got) == fmi2OK && strcmp(got, "asan") == 0);
    CHECK(fmi2GetFMUstate(c, &s) == fmi2OK);
    CHECK(fmi2SerializedFMUstateSize(c, s, &size) == fmi2OK);
    buf = (fmi2Byte *)malloc(size);
    CHECK(fmi2SerializeFMUstate(c, s, buf, size) == fmi2OK);
    CHECK(fmi2DoStep(c, t, 0.5, fmi2True) == fmi2OK);
    CHECK(fmi2DeSerializeFMUstate(c, buf, size - 1, &s2) == fmi2Error && s2 == NULL);
    buf[30] ^= 1;
    CHECK(fmi2DeSerializeFMUstate(c, buf, size, &s2) == fmi2Error && s2 == NULL);
    buf[30] ^= 1;
    CHECK(fmi2DeSerializeFMUstate(c, buf, size, &s2) == fmi2OK);
    CHECK(fmi2SetFMUstate(c, s2) == fmi2OK);
    CHECK(fmi2GetFMUstate(c, &s2) == fmi2OK);
    CHECK(fmi2SerializeFMUstate(c, s2, buf, size) == fmi2OK);
    CHECK(fmi2FreeFMUstate(c, &s) == fmi2OK && fmi2FreeFMUstate(c, &s2) == fmi2OK);
    free(buf);
    CHECK(fmi2SetReal(c, &VR_U, 1, &nan_) == fmi2OK);
    CHECK(fmi2DoStep(c, t, 0.01, fmi2True) == fmi2Discard);
    CHECK(fmi2DoStep(c, t, 0.01, fmi2True) == fmi2Error);
    CHECK(fmi2Terminate(c) == fmi2OK);
    CHECK(fmi2Reset(c) == fmi2OK);
    fmi2FreeInstance(c);
    return 0;
}
#endif

int main(void)
{
    int k;
    setvbuf(stdout, NULL, _IONBF, 0);
    for (k = 0; k < 3; k++)
        if (run(k) != 0) return 1;
    printf("OK %d messages\n", n_messages);
    return 0;
}

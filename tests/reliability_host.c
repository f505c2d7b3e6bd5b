/* tests/reliability_host.c - a C host for tests/test_reliability_native.py: the FMI glue and one native
 * model (plant, controller or ScenarioSignals) linked in, FMI 2.0 or (-DHOST_FMI3) FMI 3.0, built under
 * -fsanitize=address,undefined.  The model's own variable table (FG_MODEL_VARIABLES, fg_model.h) tells the
 * host which variables exist.  -DHOST_ME: the model-exchange build of a model (fg_model_me.h), instantiated
 * for model exchange; initialization ends in continuous-time mode, a "step" is an explicit Euler step of
 * the FMU's own derivatives (set time, get states and derivatives, set states, completed integrator
 * step), and the fuzz also calls the model-exchange functions in any phase with any sizes.  Modes (each prints one result line; a sanitizer report ends the process):
 *   corrupt TRIALS SEED   serialized states corrupted four ways (random data region behind an intact
 *                         header, one flipped bit, truncated, wrong size), TRIALS of each
 *   leak                  FMU states left to freeInstance; foreign, freed and made-up state handles
 *   leakcontrol           leaks one block on purpose (LeakSanitizer must report it)
 *   doublefree            freeInstance twice on the same pointer
 *   misuse                wrong-phase calls, NULL and non-finite arguments, discard and recovery
 *   bench N               ns per doStep with the plant's plausibility checks on and off (build it -O2)
 *   fuzz SEQS SEED [NAME=VALUE]   random FMI call sequences (a String parameter NAME set to VALUE after
 *                         most instantiations: the profiles FMU's profiles file)
 *   file PARAM NAME=VALUE|- PATH...   each file as the String parameter PARAM (NAME=VALUE set first):
 *                         instantiate, initialize, a few steps, free */
#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fg_model.h"
#ifdef HOST_ME
#include "fg_model_me.h"
#define NX_MAX 64 /* the host's state arrays; the plant has 11 */
#endif
#ifdef HOST_FMI3
#include "fmi3Functions.h"
#else
#include "fmi2Functions.h"
#endif

static long n_messages, n_errors; /* logger calls; those of status error or worse */
static int quiet = 1;

/* ---- a PRNG of its own (xorshift64*) ---- */
static uint64_t rng = 88172645463325252ULL;
static uint64_t rnd(void)
{
    rng ^= rng >> 12;
    rng ^= rng << 25;
    rng ^= rng >> 27;
    return rng * 2685821657736338717ULL;
}
static unsigned rndn(unsigned n) { return n ? (unsigned)(rnd() % n) : 0; }

/* ---- FMI 2.0 / 3.0 behind one set of calls ---- */
#ifdef HOST_FMI3
typedef fmi3Instance inst_t;
static void logger(fmi3InstanceEnvironment env, fmi3Status s, fmi3String cat, fmi3String msg)
{
    (void)env;
    n_messages++;
    if (s >= fmi3Error) n_errors++;
    if (!quiet) printf("[%d %s] %s\n", (int)s, cat, msg);
}
#ifdef HOST_ME
static inst_t h_new(const char *name, const char *token)
{
    return fmi3InstantiateModelExchange(name, token, NULL, fmi3False, fmi3False, NULL, logger);
}
static int me_event(inst_t c, int which)
{
    fmi3Boolean a, b, d, e, f;
    fmi3Float64 next;
    if (which == 0) return fmi3EnterEventMode(c);
    if (which == 1) return fmi3UpdateDiscreteStates(c, &a, &b, &d, &e, &f, &next);
    return fmi3EnterContinuousTimeMode(c);
}
static int me_time(inst_t c, double t) { return fmi3SetTime(c, t); }
static int me_set_states(inst_t c, const double *x, size_t n) { return fmi3SetContinuousStates(c, x, n); }
static int me_get_states(inst_t c, double *x, size_t n) { return fmi3GetContinuousStates(c, x, n); }
static int me_derivatives(inst_t c, double *dx, size_t n) { return fmi3GetContinuousStateDerivatives(c, dx, n); }
static int me_nominals(inst_t c, double *x, size_t n) { return fmi3GetNominalsOfContinuousStates(c, x, n); }
static int me_indicators(inst_t c, double *z, size_t n) { return fmi3GetEventIndicators(c, z, n); }
static int me_completed(inst_t c, int null_out)
{
    fmi3Boolean ev, term;
    return null_out ? fmi3CompletedIntegratorStep(c, fmi3True, NULL, NULL)
                    : fmi3CompletedIntegratorStep(c, fmi3True, &ev, &term);
}
static int me_counts(inst_t c)
{
    size_t n = 0, z = 0;
    return fmi3GetNumberOfContinuousStates(c, &n) + fmi3GetNumberOfEventIndicators(c, &z) +
           fmi3GetNumberOfContinuousStates(c, NULL);
}
#else
static inst_t h_new(const char *name, const char *token)
{
    return fmi3InstantiateCoSimulation(name, token, NULL, fmi3False, fmi3False, fmi3False, fmi3False, NULL, 0, NULL,
                                       logger, NULL);
}
#endif
static void h_free(inst_t c) { fmi3FreeInstance(c); }
static int h_enter(inst_t c, double t0) { return fmi3EnterInitializationMode(c, fmi3False, 0, t0, fmi3False, 0); }
static int h_exit_init(inst_t c) { return fmi3ExitInitializationMode(c); }
#ifndef HOST_ME
static int h_step(inst_t c, double t, double h)
{
    fmi3Boolean ev, term, early;
    fmi3Float64 last;
    return fmi3DoStep(c, t, h, fmi3True, &ev, &term, &early, &last);
}
#endif
static int h_terminate(inst_t c) { return fmi3Terminate(c); }
static int h_reset(inst_t c) { return fmi3Reset(c); }
static int h_set_real(inst_t c, unsigned vr, double v) { return fmi3SetFloat64(c, &vr, 1, &v, 1); }
static int h_get_real(inst_t c, unsigned vr, double *v) { return fmi3GetFloat64(c, &vr, 1, v, 1); }
static int h_set_int(inst_t c, unsigned vr, int v)
{
    fmi3Int32 x = v;
    return fmi3SetInt32(c, &vr, 1, &x, 1);
}
static int h_get_int(inst_t c, unsigned vr, int *v)
{
    fmi3Int32 x = 0;
    int s = fmi3GetInt32(c, &vr, 1, &x, 1);
    *v = x;
    return s;
}
static int h_set_bool(inst_t c, unsigned vr, int v)
{
    fmi3Boolean x = v != 0;
    return fmi3SetBoolean(c, &vr, 1, &x, 1);
}
static int h_get_bool(inst_t c, unsigned vr, int *v)
{
    fmi3Boolean x = 0;
    int s = fmi3GetBoolean(c, &vr, 1, &x, 1);
    *v = x;
    return s;
}
static int h_set_string(inst_t c, unsigned vr, const char *v) { return fmi3SetString(c, &vr, 1, &v, 1); }
static int h_get_string(inst_t c, unsigned vr, const char **v) { return fmi3GetString(c, &vr, 1, v, 1); }
static int h_null_calls(inst_t c)
{
    return fmi3GetFloat64(c, NULL, 1, NULL, 1) + fmi3SetFloat64(NULL, NULL, 0, NULL, 0) +
           fmi3DoStep(NULL, 0, 1, 0, NULL, NULL, NULL, NULL);
}
static int h_get_state(inst_t c, void **s) { return fmi3GetFMUState(c, s); }
static int h_set_state(inst_t c, void *s) { return fmi3SetFMUState(c, s); }
static int h_free_state(inst_t c, void **s) { return fmi3FreeFMUState(c, s); }
static int h_state_size(inst_t c, void *s, size_t *n) { return fmi3SerializedFMUStateSize(c, s, n); }
static int h_serialize(inst_t c, void *s, unsigned char *b, size_t n) { return fmi3SerializeFMUState(c, s, b, n); }
static int h_deserialize(inst_t c, const unsigned char *b, size_t n, void **s)
{
    return fmi3DeserializeFMUState(c, b, n, s);
}
static int h_logging(inst_t c, int on) { return fmi3SetDebugLogging(c, on != 0, 0, NULL); }
#define ST_ERROR fmi3Error
#else
typedef fmi2Component inst_t;
static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status s, fmi2String cat, fmi2String msg,
                   ...)
{
    (void)env;
    (void)name;
    n_messages++;
    if (s >= fmi2Error) n_errors++;
    if (!quiet) printf("[%d %s] %s\n", (int)s, cat, msg);
}
static const fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
#ifdef HOST_ME
static inst_t h_new(const char *name, const char *token)
{
    return fmi2Instantiate(name, fmi2ModelExchange, token, NULL, &callbacks, fmi2False, fmi2False);
}
static int me_event(inst_t c, int which)
{
    fmi2EventInfo info;
    if (which == 0) return fmi2EnterEventMode(c);
    if (which == 1) return fmi2NewDiscreteStates(c, &info);
    return fmi2EnterContinuousTimeMode(c);
}
static int me_time(inst_t c, double t) { return fmi2SetTime(c, t); }
static int me_set_states(inst_t c, const double *x, size_t n) { return fmi2SetContinuousStates(c, x, n); }
static int me_get_states(inst_t c, double *x, size_t n) { return fmi2GetContinuousStates(c, x, n); }
static int me_derivatives(inst_t c, double *dx, size_t n) { return fmi2GetDerivatives(c, dx, n); }
static int me_nominals(inst_t c, double *x, size_t n) { return fmi2GetNominalsOfContinuousStates(c, x, n); }
static int me_indicators(inst_t c, double *z, size_t n) { return fmi2GetEventIndicators(c, z, n); }
static int me_completed(inst_t c, int null_out)
{
    fmi2Boolean ev, term;
    return null_out ? fmi2CompletedIntegratorStep(c, fmi2True, NULL, NULL)
                    : fmi2CompletedIntegratorStep(c, fmi2True, &ev, &term);
}
static int me_counts(inst_t c) { return fmi2NewDiscreteStates(c, NULL); }
#else
static inst_t h_new(const char *name, const char *token)
{
    return fmi2Instantiate(name, fmi2CoSimulation, token, NULL, &callbacks, fmi2False, fmi2False);
}
#endif
static void h_free(inst_t c) { fmi2FreeInstance(c); }
static int h_enter(inst_t c, double t0)
{
    int s = fmi2SetupExperiment(c, fmi2False, 0, t0, fmi2False, 0);
    return s > (int)fmi2Warning ? s : (int)fmi2EnterInitializationMode(c);
}
static int h_exit_init(inst_t c) { return fmi2ExitInitializationMode(c); }
#ifndef HOST_ME
static int h_step(inst_t c, double t, double h) { return fmi2DoStep(c, t, h, fmi2True); }
#endif
static int h_terminate(inst_t c) { return fmi2Terminate(c); }
static int h_reset(inst_t c) { return fmi2Reset(c); }
static int h_set_real(inst_t c, unsigned vr, double v) { return fmi2SetReal(c, &vr, 1, &v); }
static int h_get_real(inst_t c, unsigned vr, double *v) { return fmi2GetReal(c, &vr, 1, v); }
static int h_set_int(inst_t c, unsigned vr, int v) { return fmi2SetInteger(c, &vr, 1, &v); }
static int h_get_int(inst_t c, unsigned vr, int *v) { return fmi2GetInteger(c, &vr, 1, v); }
static int h_set_bool(inst_t c, unsigned vr, int v)
{
    fmi2Boolean x = v != 0;
    return fmi2SetBoolean(c, &vr, 1, &x);
}
static int h_get_bool(inst_t c, unsigned vr, int *v) { return fmi2GetBoolean(c, &vr, 1, v); }
static int h_set_string(inst_t c, unsigned vr, const char *v) { return fmi2SetString(c, &vr, 1, &v); }
static int h_get_string(inst_t c, unsigned vr, const char **v) { return fmi2GetString(c, &vr, 1, v); }
static int h_null_calls(inst_t c)
{
    return fmi2GetReal(c, NULL, 1, NULL) + fmi2SetReal(NULL, NULL, 0, NULL) + fmi2DoStep(NULL, 0, 1, 0);
}
static int h_get_state(inst_t c, void **s) { return fmi2GetFMUstate(c, s); }
static int h_set_state(inst_t c, void *s) { return fmi2SetFMUstate(c, s); }
static int h_free_state(inst_t c, void **s) { return fmi2FreeFMUstate(c, s); }
static int h_state_size(inst_t c, void *s, size_t *n) { return fmi2SerializedFMUstateSize(c, s, n); }
static int h_serialize(inst_t c, void *s, unsigned char *b, size_t n)
{
    return fmi2SerializeFMUstate(c, s, (fmi2Byte *)b, n);
}
static int h_deserialize(inst_t c, const unsigned char *b, size_t n, void **s)
{
    return fmi2DeSerializeFMUstate(c, (const fmi2Byte *)b, n, s);
}
static int h_logging(inst_t c, int on) { return fmi2SetDebugLogging(c, on, 0, NULL); }
#define ST_ERROR fmi2Error
#endif

#ifdef HOST_ME
static int worse(int a, int b) { return a > b ? a : b; }

/* the end of initialization as a model-exchange importer does it: on to continuous-time mode */
static int h_exit(inst_t c)
{
    int s = h_exit_init(c);
    if (s > 1) return s;
    s = worse(s, me_event(c, 1));
    return s > 1 ? s : worse(s, me_event(c, 2));
}
/* one explicit Euler step of the FMU's derivatives from t to t + h: the worst status of the calls */
static int h_step(inst_t c, double t, double h)
{
    double x[NX_MAX], dx[NX_MAX];
    size_t i, n = FG_MODEL_N_STATES;
    int s = me_time(c, t);
    if (s > 1) return s;
    s = worse(s, me_get_states(c, x, n));
    if (s > 1) return s;
    s = worse(s, me_derivatives(c, dx, n));
    if (s > 1) return s;
    for (i = 0; i < n; i++) x[i] += h * dx[i];
    s = worse(s, me_time(c, t + h));
    if (s > 1) return s;
    s = worse(s, me_set_states(c, x, n));
    if (s > 1) return s;
    s = worse(s, me_derivatives(c, dx, n)); /* the outputs and the derivatives at the new states */
    return s > 1 ? s : worse(s, me_completed(c, 0));
}
#else
static int h_exit(inst_t c) { return h_exit_init(c); }
#endif

#define CHECK(cond)                                                              \
    do {                                                                         \
        if (!(cond)) {                                                           \
            printf("FAIL line %d: %s\n", __LINE__, #cond);                       \
            exit(1);                                                             \
        }                                                                        \
    } while (0)

static const fg_variable *var_named(const char *name)
{
    size_t i;
    for (i = 0; i < FG_MODEL_N_VARIABLES; i++)
        if (strcmp(FG_MODEL_VARIABLES[i].name, name) == 0) return &FG_MODEL_VARIABLES[i];
    return NULL;
}

/* the communication step the model takes: Ts for the controller, 1e-4 s otherwise */
static double step_size(inst_t c)
{
    const fg_variable *ts = var_named("Ts");
    double h = 1e-4;
    if (ts != NULL) CHECK(h_get_real(c, ts->vr, &h) == 0);
    return h;
}

/* an instance initialized and stepped n times, with its inputs at non-trivial values */
static inst_t ready(const char *name, int n, double *t)
{
    inst_t c = h_new(name, INSTANTIATION_TOKEN);
    size_t i;
    double h;
    int k;
    CHECK(c != NULL);
    CHECK(h_enter(c, 0.0) == 0);
    CHECK(h_exit(c) == 0);
    for (i = 0; i < FG_MODEL_N_VARIABLES; i++)
        if (FG_MODEL_VARIABLES[i].kind == FG_INPUT && FG_MODEL_VARIABLES[i].type == FG_REAL)
            CHECK(h_set_real(c, FG_MODEL_VARIABLES[i].vr, strcmp(FG_MODEL_VARIABLES[i].name, "psi_ref") == 0
                                                              ? 0.9 : 10.0 + (double)i) == 0);
    h = step_size(c);
    for (*t = 0.0, k = 0; k < n; k++, *t += h) CHECK(h_step(c, *t, h) <= 1);
    return c;
}

/* ---- corrupt: every corrupted serialized state refused with an error and a message ---- */
static int offer(inst_t c, const unsigned char *b, size_t n, long *accepted, long *unlogged)
{
    void *s = NULL;
    long before = n_errors;
    int st = h_deserialize(c, b, n, &s);
    if (st != ST_ERROR || s != NULL) {
        (*accepted)++;
        if (s != NULL) CHECK(h_free_state(c, &s) == 0);
        return 1;
    }
    if (n_errors == before) (*unlogged)++;
    return 0;
}

static int mode_corrupt(long trials)
{
    double t, y0, y1;
    inst_t c = ready("corrupt", 20, &t);
    void *s = NULL, *back = NULL;
    size_t n, hdr = 168, i, k;
    unsigned char *good, *bad;
    long acc[4] = {0, 0, 0, 0}, unl[4] = {0, 0, 0, 0}, j;
    const fg_variable *out = NULL;
    for (i = 0; i < FG_MODEL_N_VARIABLES && out == NULL; i++)
        if (FG_MODEL_VARIABLES[i].kind == FG_OUTPUT && FG_MODEL_VARIABLES[i].type == FG_REAL)
            out = &FG_MODEL_VARIABLES[i];
    CHECK(h_get_state(c, &s) == 0 && h_state_size(c, s, &n) == 0 && n > hdr);
    good = (unsigned char *)malloc(n + 64);
    bad = (unsigned char *)malloc(n + 64);
    CHECK(good != NULL && bad != NULL && h_serialize(c, s, good, n) == 0);
    CHECK(h_step(c, t, step_size(c)) <= 1 && h_get_real(c, out->vr, &y0) == 0);
    for (j = 0; j < trials; j++) {
        memcpy(bad, good, n); /* random data region behind the intact header */
        for (k = hdr; k < n; k++) bad[k] = (unsigned char)rnd();
        offer(c, bad, n, &acc[0], &unl[0]);
        memcpy(bad, good, n); /* one flipped bit anywhere */
        k = rndn((unsigned)n);
        bad[k] ^= (unsigned char)(1u << rndn(8));
        offer(c, bad, n, &acc[1], &unl[1]);
        offer(c, good, rndn((unsigned)n), &acc[2], &unl[2]); /* truncated */
        memcpy(bad, good, n);                                 /* wrong size: bytes appended */
        k = 1 + rndn(64);
        for (i = n; i < n + k; i++) bad[i] = (unsigned char)rnd();
        offer(c, bad, n + k, &acc[3], &unl[3]);
    }
    /* the intact blob is still taken and replays the step bit for bit */
    CHECK(h_deserialize(c, good, n, &back) == 0 && back != NULL);
    CHECK(h_set_state(c, back) == 0);
    CHECK(h_step(c, t, step_size(c)) <= 1 && h_get_real(c, out->vr, &y1) == 0);
    CHECK(memcmp(&y0, &y1, sizeof y0) == 0);
    printf("corrupt: trials=%ld random_data_accepted=%ld bitflip_accepted=%ld truncated_accepted=%ld "
           "wrong_size_accepted=%ld unlogged=%ld size=%lu\n",
           trials, acc[0], acc[1], acc[2], acc[3], unl[0] + unl[1] + unl[2] + unl[3], (unsigned long)n);
    free(good);
    free(bad);
    h_free(c); /* s and back are freed with the instance */
    return 0;
}

/* ---- leak: states left to freeInstance; handles that are not the instance's own ---- */
static int mode_leak(void)
{
    double t;
    inst_t a = ready("a", 5, &t), b = ready("b", 5, &t);
    void *s[300], *sb = NULL, *dup, *made_up = &t;
    size_t n;
    unsigned char *buf;
    int k;
    for (k = 0; k < 300; k++) {
        s[k] = NULL;
        CHECK(h_get_state(a, &s[k]) == 0 && s[k] != NULL);
    }
    CHECK(h_state_size(a, s[0], &n) == 0);
    buf = (unsigned char *)malloc(n);
    CHECK(buf != NULL && h_serialize(a, s[0], buf, n) == 0);
    for (k = 0; k < 100; k++) {
        void *d = NULL;
        CHECK(h_deserialize(a, buf, n, &d) == 0 && d != NULL); /* left to freeInstance */
    }
    CHECK(h_get_state(b, &sb) == 0);
    CHECK(h_set_state(a, sb) == ST_ERROR);      /* b's state offered to a */
    CHECK(h_serialize(a, sb, buf, n) == ST_ERROR);
    CHECK(h_set_state(a, made_up) == ST_ERROR); /* an address that is no state: compared, never read */
    CHECK(h_get_state(a, &made_up) == ST_ERROR);
    dup = s[7];
    CHECK(h_free_state(a, &s[7]) == 0 && s[7] == NULL);
    CHECK(h_free_state(a, &dup) == ST_ERROR); /* freed twice: refused, not read */
    CHECK(h_set_state(a, dup) == ST_ERROR);   /* a freed state */
    CHECK(h_free_state(b, &s[8]) == ST_ERROR && s[8] != NULL); /* a's state freed through b */
    CHECK(h_set_state(a, s[9]) == 0);
    free(buf);
    h_free(a); /* 299 + 100 states */
    h_free(b); /* 1 */
    printf("leak: ok (400 states left to freeInstance)\n");
    return 0;
}

static int mode_doublefree(void)
{
    double t;
    inst_t a = ready("a", 3, &t), b = ready("b", 3, &t);
    void *s = NULL;
    CHECK(h_get_state(a, &s) == 0);
    h_free(a);
    h_free(a); /* ignored: a is no longer a live instance, and is not read */
    CHECK(h_step(b, t, step_size(b)) <= 1);
    h_free(b);
    h_free(b);
    h_free(a);
    printf("doublefree: ok\n");
    return 0;
}

/* ---- misuse: calls a host gets wrong, each refused with a status and the instance still usable ---- */
static int mode_misuse(void)
{
    inst_t c = h_new("misuse", INSTANTIATION_TOKEN);
    const fg_variable *in = NULL, *par = NULL, *out = NULL;
    double v = 1.0, h, t = 0.0;
    void *s = NULL;
    long before;
    size_t i;
    for (i = 0; i < FG_MODEL_N_VARIABLES; i++) {
        const fg_variable *x = &FG_MODEL_VARIABLES[i];
        if (x->type != FG_REAL) continue;
        if (x->kind == FG_INPUT && in == NULL && strcmp(x->name, "psi_ref") != 0) in = x;
        if (x->kind == FG_PARAMETER && par == NULL) par = x;
        if (x->kind == FG_OUTPUT && out == NULL) out = x;
    }
    CHECK(c != NULL && in != NULL && par != NULL && out != NULL);
    CHECK(h_new("bad token", "{not this build}") == NULL);
    CHECK(h_new(NULL, INSTANTIATION_TOKEN) == NULL);
    CHECK(h_step(c, 0.0, 1e-4) == ST_ERROR);            /* before initialization */
    CHECK(h_get_real(c, out->vr, &v) == ST_ERROR);      /* FMI 2: no getter before initialization */
    CHECK(h_exit(c) == ST_ERROR);                       /* exit before enter */
    CHECK(h_terminate(c) == ST_ERROR);
    CHECK(h_null_calls(c) == 3 * ST_ERROR);
    CHECK(h_set_real(c, out->vr, 1.0) == ST_ERROR);     /* an output is not settable */
    CHECK(h_set_real(c, 999999u, 1.0) == ST_ERROR);     /* unknown value reference */
    CHECK(h_enter(c, NAN) == ST_ERROR);                 /* non-finite start time */
    CHECK(h_enter(c, 0.0) == 0 && h_exit(c) == 0);
    h = step_size(c);
    CHECK(h_set_real(c, par->vr, 2.0) == ST_ERROR);     /* a fixed parameter after initialization */
    CHECK(h_step(c, 0.0, -h) == ST_ERROR && h_step(c, 0.0, NAN) == ST_ERROR && h_step(c, INFINITY, h) == ST_ERROR);
    CHECK(h_step(c, 1.0, h) == ST_ERROR);               /* not the FMU's time */
    CHECK(h_get_state(c, NULL) == ST_ERROR);
    CHECK(h_get_state(c, &s) == 0);
    before = n_messages;
    CHECK(h_set_real(c, in->vr, NAN) == 0 && h_step(c, t, h) == 2 && n_messages > before); /* NaN input: discard */
    CHECK(h_step(c, t, h) == ST_ERROR);                 /* no step after a discard ... */
    CHECK(h_get_real(c, out->vr, &v) == 0);             /* ... but getters */
    CHECK(h_set_state(c, s) == 0);                      /* ... and back to a good state */
    CHECK(h_set_real(c, in->vr, INFINITY) == 0 && h_step(c, t, h) == 2);
    CHECK(h_set_state(c, s) == 0 && h_set_real(c, in->vr, 1.0) == 0 && h_step(c, t, h) <= 1);
    CHECK(h_terminate(c) == 0 && h_terminate(c) == ST_ERROR && h_step(c, t + h, h) == ST_ERROR);
    CHECK(h_reset(c) == 0 && h_enter(c, 0.0) == 0 && h_exit(c) == 0 && h_step(c, 0.0, h) <= 1);
    CHECK(h_set_state(c, s) == 0 && h_free_state(c, &s) == 0 && s == NULL);
    h_free(c);
    printf("misuse: ok\n");
    return 0;
}

/* ---- bench: ns per doStep of the default run with the model's plausibility checks on and off ---- */
static int mode_bench(long n)
{
    static const char *const off[] = {"v_warn", "i_warn", "omega_warn"};
    double ns[2], t, h, w;
    int pass, k;
    long j;
    for (pass = 0; pass < 2; pass++) {
        inst_t c = h_new("bench", INSTANTIATION_TOKEN);
        const fg_variable *va = var_named("v_s_alpha"), *vb = var_named("v_s_beta");
        clock_t t0;
        CHECK(c != NULL && va != NULL && vb != NULL);
        CHECK(h_enter(c, 0.0) == 0);
        for (k = 0; k < 3 && pass == 1; k++)
            if (var_named(off[k]) != NULL) CHECK(h_set_real(c, var_named(off[k])->vr, 0.0) == 0);
        CHECK(h_exit(c) == 0);
        h = step_size(c);
        t0 = clock();
        for (j = 0, t = 0.0; j < n; j++, t += h) {
            w = 314.159 * t;
            CHECK(h_set_real(c, va->vr, 300.0 * cos(w)) == 0 && h_set_real(c, vb->vr, 300.0 * sin(w)) == 0);
            CHECK(h_step(c, t, h) == 0);
        }
        ns[pass] = (double)(clock() - t0) / CLOCKS_PER_SEC / (double)n * 1e9;
        h_free(c);
    }
    {
        inst_t c = h_new("bench", INSTANTIATION_TOKEN);
        void *s = NULL;
        clock_t t0;
        CHECK(c != NULL && h_enter(c, 0.0) == 0 && h_exit(c) == 0 && h_get_state(c, &s) == 0);
        t0 = clock();
        for (j = 0; j < n / 10; j++) CHECK(h_get_state(c, &s) == 0 && h_set_state(c, s) == 0);
        w = (double)(clock() - t0) / CLOCKS_PER_SEC / (double)(n / 10) * 1e9;
        {
            size_t size;
            unsigned char *buf;
            CHECK(h_state_size(c, s, &size) == 0 && (buf = (unsigned char *)malloc(size)) != NULL);
            t0 = clock();
            for (j = 0; j < n / 10; j++)
                CHECK(h_serialize(c, s, buf, size) == 0 && h_deserialize(c, buf, size, &s) == 0);
            t = (double)(clock() - t0) / CLOCKS_PER_SEC / (double)(n / 10) * 1e9;
            free(buf);
        }
        h_free(c);
    }
    printf("bench: steps=%ld ns_per_step_checks_on=%.1f ns_per_step_checks_off=%.1f "
           "ns_per_get_and_set_state=%.1f ns_per_serialize_and_deserialize=%.1f\n", n, ns[0], ns[1], w, t);
    return 0;
}

/* ---- fuzz ---- */
static double rnd_real(void)
{
    static const double pick[] = {0.0, 1.0, -1.0, 0.5, 1e-4, 1e-9, 100.0, 540.0, 1e6, 1e300, -1e300, 5e-324};
    switch (rndn(6)) {
    case 0: return NAN;
    case 1: return rndn(2) ? INFINITY : -INFINITY;
    case 2: return ((double)(int64_t)rnd()) / 9.2e18 * 1000.0;
    default: return pick[rndn(sizeof pick / sizeof pick[0])];
    }
}

static int rnd_int(void)
{
    static const int pick[] = {0, 1, -1, 2, 3, 1000, 50000, INT_MAX, INT_MIN};
    return pick[rndn(sizeof pick / sizeof pick[0])];
}

static void rnd_string(char *s, size_t cap)
{
    static const char *const pick[] = {"", "table", "arctan", "linear", "exponential", "polynomial", "pi",
                                       "saturated", "constant_m", "estimated", "known", "observer", "measured",
                                       "/nonexistent/file.csv", "../x", "profiles.txt"};
    size_t n, i;
    if (rndn(3)) {
        strcpy(s, pick[rndn(sizeof pick / sizeof pick[0])]);
        return;
    }
    n = rndn(2) ? rndn(16) : rndn((unsigned)cap - 1);
    for (i = 0; i < n; i++) s[i] = (char)(1 + rndn(255));
    s[n] = '\0';
}

static double max_call, now0;
static double now(void) { return (double)clock() / CLOCKS_PER_SEC; }
static void tick(void) { now0 = now(); }
static void tock(void)
{
    double d = now() - now0;
    if (d > max_call) max_call = d;
}

#define SLOTS 3
#define SSLOTS 4
static long n_calls, n_slow, n_steps_ok, n_states_set, n_deserialized;
static const fg_variable *init_var; /* fuzz NAME=VALUE: set after most instantiations */
static const char *init_value;

static void fuzz_one(int len)
{
    inst_t c[SLOTS] = {NULL, NULL, NULL};
    void *st[SLOTS][SSLOTS];
    void *stale = NULL; /* a freed state handle */
    double t[SLOTS] = {0, 0, 0};
    char str[400];
    unsigned char *buf = NULL;
    size_t bufn = 0;
    int op, i, k, v;
    memset(st, 0, sizeof st);
    for (op = 0; op < len; op++) {
        const fg_variable *var = &FG_MODEL_VARIABLES[rndn((unsigned)FG_MODEL_N_VARIABLES)];
        unsigned vr = rndn(8) ? var->vr : rndn(2) ? 100000u + rndn(10) : (unsigned)rnd();
        double x, before;
        const char *sp;
        i = (int)rndn(SLOTS);
        k = (int)rndn(SSLOTS);
        if (c[i] == NULL && rndn(4)) {
            static const char *const names[] = {"f", "", "fuzz instance"};
            c[i] = h_new(rndn(8) ? names[rndn(3)] : NULL, rndn(10) ? INSTANTIATION_TOKEN : "{bad}");
            if (c[i] != NULL && init_var != NULL && rndn(8)) (void)h_set_string(c[i], init_var->vr, init_value);
            memset(st[i], 0, sizeof st[i]);
            t[i] = 0.0;
            n_calls++;
            continue;
        }
        if (c[i] == NULL) continue;
        n_calls++;
        before = max_call;
        tick();
#ifdef HOST_ME
        switch (rndn(26)) {
#else
        switch (rndn(20)) {
#endif
        case 0: {
            inst_t dead = c[i];
            h_free(dead);
            if (rndn(2)) h_free(dead); /* double free */
            c[i] = NULL;
            break;
        }
        case 1: t[i] = rndn(4) ? 0.0 : rnd_real(); (void)h_enter(c[i], t[i]); break;
        case 2: (void)h_exit(c[i]); break;
        case 3:
        case 4:
        case 5: {
            static const double hs[] = {1e-4, 1e-4, 1e-3, 0.0, -1e-4, 1e-9, 0.01, 0.5, 10.0, 1e6};
            double h = rndn(8) ? hs[rndn(sizeof hs / sizeof hs[0])] : rnd_real();
            const fg_variable *ts = var_named("Ts");
            if (ts != NULL && rndn(2)) (void)h_get_real(c[i], ts->vr, &h);
            if (h_step(c[i], rndn(10) ? t[i] : rnd_real(), h) <= 1) {
                t[i] += h;
                n_steps_ok++;
            }
            break;
        }
        case 6:
        case 7:
            if (var->type == FG_REAL) (void)h_set_real(c[i], vr, rnd_real());
            else if (var->type == FG_INTEGER) {
                /* max_substeps: the values a host may set without asking for hours (the bound's point) */
                v = strcmp(var->name, "max_substeps") == 0 ? (int)rndn(3) - 1 + (rndn(2) ? 0 : 50000) : rnd_int();
                (void)h_set_int(c[i], vr, v);
            } else if (var->type == FG_BOOLEAN) (void)h_set_bool(c[i], vr, (int)rndn(3));
            else {
                rnd_string(str, sizeof str);
                (void)h_set_string(c[i], vr, rndn(20) ? str : NULL);
            }
            break;
        case 8:
            if (var->type == FG_REAL) (void)h_get_real(c[i], vr, &x);
            else if (var->type == FG_INTEGER) (void)h_get_int(c[i], vr, &v);
            else if (var->type == FG_BOOLEAN) (void)h_get_bool(c[i], vr, &v);
            else if (h_get_string(c[i], vr, &sp) == 0) CHECK(sp != NULL && strlen(sp) < 100000);
            break;
        case 9: (void)h_get_state(c[i], &st[i][k]); break;
        case 10: {
            int j = (int)rndn(SLOTS);
            void *s = rndn(6) ? st[i][k] : c[j] != NULL ? st[j][rndn(SSLOTS)] : stale;
            if (h_set_state(c[i], s) == 0) n_states_set++; /* own, another instance's, freed or NULL */
            break;
        }
        case 11:
            if (st[i][k] != NULL) stale = st[i][k];
            (void)h_free_state(c[i], rndn(10) ? &st[i][k] : &stale);
            if (stale == NULL) stale = &t[0]; /* a made-up handle */
            break;
        case 12: {
            size_t n = 0;
            void *d = NULL;
            if (st[i][k] == NULL || h_state_size(c[i], st[i][k], &n) != 0) break;
            if (n > bufn) {
                free(buf);
                buf = (unsigned char *)malloc(n + 8);
                bufn = buf ? n : 0;
                if (buf == NULL) break;
            }
            if (h_serialize(c[i], st[i][k], buf, n) != 0) break;
            switch (rndn(4)) {
            case 0: buf[rndn((unsigned)n)] ^= (unsigned char)(1u << rndn(8)); break;
            case 1: n = rndn((unsigned)n); break;
            default: break;
            }
            {
                int j = (int)rndn(SLOTS); /* deserialized by this or another live instance */
                if (c[j] == NULL) j = i;
                if (h_deserialize(c[j], buf, n, &d) == 0 && d != NULL) {
                    n_deserialized++;
                    if (rndn(2)) (void)h_set_state(c[j], d);
                    if (rndn(3)) CHECK(h_free_state(c[j], &d) == 0); /* else left to freeInstance */
                }
            }
            break;
        }
        case 13: (void)h_terminate(c[i]); break;
        case 14: (void)h_reset(c[i]); t[i] = 0.0; break;
        case 15: (void)h_null_calls(c[i]); break;
        case 16: (void)h_logging(c[i], (int)rndn(2)); break;
#ifdef HOST_ME
        case 20: (void)me_event(c[i], (int)rndn(3)); break; /* event mode, discrete states, continuous time */
        case 21: (void)me_time(c[i], rndn(3) ? t[i] + 1e-4 * rndn(4) : rnd_real()); break;
        case 22:
        case 23: { /* states: the FMU's own, some made random (NaN, inf, huge), or a wrong count, or NULL */
            double xs[NX_MAX];
            static const size_t counts[] = {0, 1, 10, 12, 63};
            size_t n = rndn(6) ? FG_MODEL_N_STATES : counts[rndn(5)], j;
            for (j = 0; j < NX_MAX; j++) xs[j] = 0.0;
            (void)me_get_states(c[i], xs, FG_MODEL_N_STATES);
            for (j = 0; j < n && rndn(2); j++) xs[rndn((unsigned)FG_MODEL_N_STATES)] = rnd_real();
            (void)me_set_states(c[i], rndn(20) ? xs : NULL, n);
            break;
        }
        case 24: { /* derivatives, states, nominals, event indicators: any count, NULL arrays */
            double out[NX_MAX];
            static const size_t counts[] = {0, 1, 10, 12, 63};
            size_t n = rndn(3) ? FG_MODEL_N_STATES : counts[rndn(5)];
            double *a = rndn(15) ? out : NULL;
            switch (rndn(5)) {
            case 0: (void)me_derivatives(c[i], a, n); break;
            case 1: (void)me_get_states(c[i], a, n); break;
            case 2: (void)me_nominals(c[i], a, n); break;
            case 3: (void)me_indicators(c[i], a, rndn(2) ? 0 : n); break;
            default: (void)me_counts(c[i]); break;
            }
            break;
        }
        case 25: (void)me_completed(c[i], rndn(6) == 0); break;
#endif
        default: {
            /* a plausible run: initialize and step a few times */
            double h;
            int s;
            (void)h_enter(c[i], 0.0);
            (void)h_exit(c[i]);
            h = step_size(c[i]);
            for (s = 0; s < 5; s++)
                if (h_step(c[i], t[i], h) <= 1) {
                    t[i] += h;
                    n_steps_ok++;
                }
            break;
        }
        }
        tock();
        if (max_call > before && max_call > 2.0) n_slow++;
    }
    for (i = 0; i < SLOTS; i++)
        if (c[i] != NULL) h_free(c[i]); /* the states still held die with their instance */
    free(buf);
}

static int mode_fuzz(long seqs)
{
    long q;
    for (q = 0; q < seqs; q++) fuzz_one(20 + (int)rndn(180));
    printf("fuzz: sequences=%ld calls=%ld messages=%ld steps_ok=%ld states_set=%ld deserialized=%ld "
           "slowest_call_s=%.3f calls_over_2s=%ld\n", seqs, n_calls, n_messages, n_steps_ok, n_states_set,
           n_deserialized, max_call, n_slow);
    return 0;
}

/* ---- file: the model's file readers on the files given ---- */
static int mode_file(const char *param, const char *extra, int n, char **paths)
{
    const fg_variable *p = var_named(param), *e = NULL;
    char name[64];
    const char *value = NULL;
    long ok = 0, refused = 0;
    int k;
    CHECK(p != NULL && p->type == FG_STRING);
    if (strcmp(extra, "-") != 0) {
        const char *eq = strchr(extra, '=');
        CHECK(eq != NULL && (size_t)(eq - extra) < sizeof name);
        memcpy(name, extra, (size_t)(eq - extra));
        name[eq - extra] = '\0';
        value = eq + 1;
        CHECK((e = var_named(name)) != NULL);
    }
    for (k = 0; k < n; k++) {
        inst_t c = h_new("file", INSTANTIATION_TOKEN);
        double t = 0.0, h;
        long before = n_errors;
        int s;
        CHECK(c != NULL);
        if (e != NULL) CHECK(h_set_string(c, e->vr, value) == 0);
        if (h_set_string(c, p->vr, paths[k]) != 0) { /* a path too long for the store: refused */
            refused++;
            h_free(c);
            continue;
        }
        CHECK(h_enter(c, 0.0) == 0);
        if (h_exit(c) == 0) {
            ok++;
            h = step_size(c);
            for (s = 0; s < 10; s++, t += h) CHECK(h_step(c, t, h) <= 2);
        } else {
            CHECK(n_errors > before); /* refused with a message */
            refused++;
        }
        h_free(c);
    }
    printf("file: files=%d accepted=%ld refused=%ld\n", n, ok, refused);
    return 0;
}

int main(int argc, char **argv)
{
    if (getenv("HOST_VERBOSE") != NULL) quiet = 0;
    if (argc >= 4 && strcmp(argv[1], "corrupt") == 0) {
        rng ^= strtoull(argv[3], NULL, 10) * 0x9E3779B97F4A7C15ULL;
        return mode_corrupt(atol(argv[2]));
    }
    if (argc >= 2 && strcmp(argv[1], "leak") == 0) return mode_leak();
    if (argc >= 2 && strcmp(argv[1], "leakcontrol") == 0) {
        void *p = malloc(4242);
        printf("leakcontrol: %p\n", p);
        p = NULL;
        return 0;
    }
    if (argc >= 2 && strcmp(argv[1], "doublefree") == 0) return mode_doublefree();
    if (argc >= 2 && strcmp(argv[1], "misuse") == 0) return mode_misuse();
    if (argc >= 3 && strcmp(argv[1], "bench") == 0) return mode_bench(atol(argv[2]));
    if (argc >= 4 && strcmp(argv[1], "fuzz") == 0) {
        rng ^= strtoull(argv[3], NULL, 10) * 0x9E3779B97F4A7C15ULL;
        if (argc >= 5) {
            static char name[64];
            const char *eq = strchr(argv[4], '=');
            CHECK(eq != NULL && (size_t)(eq - argv[4]) < sizeof name);
            memcpy(name, argv[4], (size_t)(eq - argv[4]));
            name[eq - argv[4]] = '\0';
            CHECK((init_var = var_named(name)) != NULL && init_var->type == FG_STRING);
            init_value = eq + 1;
        }
        return mode_fuzz(atol(argv[2]));
    }
    if (argc >= 4 && strcmp(argv[1], "file") == 0) return mode_file(argv[2], argv[3], argc - 4, argv + 4);
    fprintf(stderr, "usage: see the head of tests/reliability_host.c\n");
    return 2;
}

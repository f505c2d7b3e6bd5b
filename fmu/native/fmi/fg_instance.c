/* fg_instance.c - see fg_instance.h */
#include "fg_instance.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define FG_STATE_MAGIC "SMFMUST"
#define FG_STATE_FORMAT 1u
#define FG_TAG_LEN 64

typedef struct {
    char magic[8];
    uint32_t format_version;
    uint32_t phase;
    uint64_t data_size;
    char model_identifier[FG_TAG_LEN];
    char token[FG_TAG_LEN];
    double time;
} fg_state_header;

static char *dup_string(const char *s)
{
    size_t n;
    char *p;
    if (s == NULL) return NULL;
    n = strlen(s) + 1;
    p = (char *)malloc(n);
    if (p != NULL) memcpy(p, s, n);
    return p;
}

static int hexval(char c)
{
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

/* a file: URI (FMI 2) or a plain path (FMI 3) to a directory path ending in '/' */
static char *resource_dir(const char *loc)
{
    const char *s = loc;
    char *out, *o;
    size_t n;
    int uri = 1;
    if (loc == NULL || loc[0] == '\0') return NULL;
    if (strncmp(s, "file://localhost/", 17) == 0) s += 16;
    else if (strncmp(s, "file:///", 8) == 0) s += 7;
    else if (strncmp(s, "file:/", 6) == 0) s += 5;
    else uri = 0;
    n = strlen(s);
    out = (char *)malloc(n + 2);
    if (out == NULL) return NULL;
    for (o = out; *s; s++) {
        if (uri && *s == '%' && hexval(s[1]) >= 0 && hexval(s[2]) >= 0) {
            *o++ = (char)(hexval(s[1]) * 16 + hexval(s[2]));
            s += 2;
        } else {
            *o++ = *s;
        }
    }
    if (o == out || o[-1] != '/') *o++ = '/';
    *o = '\0';
    return out;
}

fg_instance *fg_instance_new(const char *name, const char *resource_path, void *env, fg_generic_fn logger,
                             fg_emit_fn emit, int logging_on)
{
    fg_instance *inst = (fg_instance *)calloc(1, sizeof(fg_instance));
    if (inst == NULL) return NULL;
    inst->name = dup_string(name);
    inst->resource_path = resource_dir(resource_path);
    inst->env = env;
    inst->logger = logger;
    inst->emit = emit;
    inst->logging_on = logging_on;
    inst->data = calloc(1, FG_MODEL_DATA_SIZE > 0 ? FG_MODEL_DATA_SIZE : 1);
    if (inst->name == NULL || inst->data == NULL) {
        fg_instance_free(inst);
        return NULL;
    }
    fg_instance_reset(inst);
    return inst;
}

void fg_instance_free(fg_instance *inst)
{
    if (inst == NULL) return;
    free(inst->name);
    free(inst->resource_path);
    free(inst->data);
    free(inst);
}

void fg_instance_reset(fg_instance *inst)
{
    memset(inst->data, 0, FG_MODEL_DATA_SIZE);
    inst->phase = FG_PHASE_INSTANTIATED;
    inst->me_continuous = 0;
    inst->time = 0.0;
    inst->stop_time = INFINITY;
    fg_model_start(inst, inst->data);
}

const char *fg_instance_name(const fg_instance *inst) { return inst ? inst->name : NULL; }
const char *fg_resource_path(const fg_instance *inst) { return inst ? inst->resource_path : NULL; }
double fg_stop_time(const fg_instance *inst) { return inst ? inst->stop_time : INFINITY; }

void fg_log(fg_instance *inst, fg_status status, const char *category, const char *fmt, ...)
{
    char buf[1024];
    va_list ap;
    if (inst == NULL || inst->emit == NULL || inst->logger == NULL) return;
    if (status == FG_OK && !inst->logging_on) return;
    if (category == NULL) {
        category = status == FG_ERROR ? "logStatusError" : status == FG_DISCARD ? "logStatusDiscard"
                 : status == FG_WARNING ? "logStatusWarning" : "logEvents";
    }
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    inst->emit(inst, status, category, buf);
}

static const char *phase_name(fg_phase p)
{
    switch (p) {
    case FG_PHASE_INSTANTIATED: return "instantiated";
    case FG_PHASE_INIT: return "initialization mode";
    case FG_PHASE_STEP: return "step mode";
    case FG_PHASE_STEP_FAILED: return "step failed (after discard)";
    case FG_PHASE_TERMINATED: return "terminated";
    case FG_PHASE_ERROR: return "error";
    }
    return "?";
}

int fg_allowed(fg_instance *inst, const char *func, unsigned mask)
{
    if (inst == NULL) return 0;
    if ((unsigned)inst->phase & mask) return 1;
    fg_log(inst, FG_ERROR, NULL, "%s: not allowed in phase '%s'", func, phase_name(inst->phase));
    return 0;
}

fg_status fg_unsupported(fg_instance *inst, const char *func)
{
    fg_log(inst, FG_ERROR, NULL, "%s is not supported by %s", func, FG_MODEL_IDENTIFIER_STRING);
    return FG_ERROR;
}

int fg_args_ok(fg_instance *inst, const char *func, size_t n, const void *a, const void *b)
{
    if (n > 0 && (a == NULL || b == NULL)) {
        fg_log(inst, FG_ERROR, NULL, "%s: NULL array argument", func);
        return 0;
    }
    return 1;
}

static const char *type_name(fg_type t)
{
    return t == FG_REAL ? "Real" : t == FG_INTEGER ? "Integer" : t == FG_BOOLEAN ? "Boolean" : "String";
}

static const fg_variable *lookup(fg_instance *inst, const char *func, uint32_t vr, fg_type type)
{
    size_t i;
    /* fast path: a table ordered so that entry vr has value reference vr */
    if (vr < FG_MODEL_N_VARIABLES && FG_MODEL_VARIABLES[vr].vr == vr && FG_MODEL_VARIABLES[vr].type == type)
        return &FG_MODEL_VARIABLES[vr];
    for (i = 0; i < FG_MODEL_N_VARIABLES; i++)
        if (FG_MODEL_VARIABLES[i].vr == vr && FG_MODEL_VARIABLES[i].type == type) return &FG_MODEL_VARIABLES[i];
    fg_log(inst, FG_ERROR, NULL, "%s: unknown value reference %lu for a %s variable", func, (unsigned long)vr,
           type_name(type));
    return NULL;
}

#define GET_MASK (FG_PHASE_INIT | FG_PHASE_STEP | FG_PHASE_STEP_FAILED | FG_PHASE_TERMINATED | FG_PHASE_ERROR)
#define SET_MASK (FG_PHASE_INSTANTIATED | FG_PHASE_INIT | FG_PHASE_STEP)

/* may the variable be set now? */
static int settable(fg_instance *inst, const char *func, const fg_variable *v)
{
    unsigned mask;
    switch (v->kind) {
    case FG_PARAMETER: mask = FG_PHASE_INSTANTIATED | FG_PHASE_INIT; break;
    case FG_TUNABLE_PARAMETER:
    case FG_INPUT: mask = SET_MASK; break;
    default:
        fg_log(inst, FG_ERROR, NULL, "%s: variable '%s' (value reference %lu) is not settable", func, v->name,
               (unsigned long)v->vr);
        return 0;
    }
    if ((unsigned)inst->phase & mask) return 1;
    fg_log(inst, FG_ERROR, NULL, "%s: variable '%s' (value reference %lu) %s cannot be set in phase '%s'", func,
           v->name, (unsigned long)v->vr, v->kind == FG_PARAMETER ? "is a fixed parameter and" : "",
           phase_name(inst->phase));
    return 0;
}

static fg_status worse(fg_status a, fg_status b) { return a > b ? a : b; }

#define DEFINE_GET(NAME, CTYPE, TYPE, MODELFN)                                                          \
    fg_status NAME(fg_instance *inst, const char *func, const uint32_t vr[], size_t n, CTYPE v[])      \
    {                                                                                                  \
        size_t i;                                                                                      \
        fg_status s = FG_OK;                                                                           \
        if (!fg_allowed(inst, func, GET_MASK) || !fg_args_ok(inst, func, n, vr, v)) return FG_ERROR;   \
        for (i = 0; i < n && s < FG_ERROR; i++) {                                                      \
            if (lookup(inst, func, vr[i], TYPE) == NULL) return FG_ERROR;                              \
            s = worse(s, MODELFN(inst, inst->data, vr[i], &v[i]));                                     \
        }                                                                                              \
        return s;                                                                                      \
    }

#define DEFINE_SET(NAME, CTYPE, TYPE, MODELFN)                                                         \
    fg_status NAME(fg_instance *inst, const char *func, const uint32_t vr[], size_t n, const CTYPE v[]) \
    {                                                                                                  \
        size_t i;                                                                                      \
        fg_status s = FG_OK;                                                                           \
        const fg_variable *var;                                                                        \
        if (!fg_allowed(inst, func, SET_MASK) || !fg_args_ok(inst, func, n, vr, v)) return FG_ERROR;   \
        for (i = 0; i < n && s < FG_ERROR; i++) {                                                      \
            if ((var = lookup(inst, func, vr[i], TYPE)) == NULL || !settable(inst, func, var))         \
                return FG_ERROR;                                                                       \
            s = worse(s, MODELFN(inst, inst->data, vr[i], v[i]));                                      \
        }                                                                                              \
        return s;                                                                                      \
    }

DEFINE_GET(fg_get_real, double, FG_REAL, fg_model_get_real)
DEFINE_SET(fg_set_real, double, FG_REAL, fg_model_set_real)
DEFINE_GET(fg_get_integer, int32_t, FG_INTEGER, fg_model_get_integer)
DEFINE_SET(fg_set_integer, int32_t, FG_INTEGER, fg_model_set_integer)
DEFINE_GET(fg_get_string, const char *, FG_STRING, fg_model_get_string)

fg_status fg_set_string(fg_instance *inst, const char *func, const uint32_t vr[], size_t n, const char *const v[])
{
    size_t i;
    fg_status s = FG_OK;
    const fg_variable *var;
    if (!fg_allowed(inst, func, SET_MASK) || !fg_args_ok(inst, func, n, vr, v)) return FG_ERROR;
    for (i = 0; i < n && s < FG_ERROR; i++) {
        if ((var = lookup(inst, func, vr[i], FG_STRING)) == NULL || !settable(inst, func, var)) return FG_ERROR;
        if (v[i] == NULL) {
            fg_log(inst, FG_ERROR, NULL, "%s: NULL string for '%s'", func, var->name);
            return FG_ERROR;
        }
        s = worse(s, fg_model_set_string(inst, inst->data, vr[i], v[i]));
    }
    return s;
}

fg_status fg_get_boolean1(fg_instance *inst, const char *func, uint32_t vr, int *v)
{
    if (!fg_allowed(inst, func, GET_MASK)) return FG_ERROR;
    if (lookup(inst, func, vr, FG_BOOLEAN) == NULL) return FG_ERROR;
    return fg_model_get_boolean(inst, inst->data, vr, v);
}

fg_status fg_set_boolean1(fg_instance *inst, const char *func, uint32_t vr, int v)
{
    const fg_variable *var;
    if (!fg_allowed(inst, func, SET_MASK)) return FG_ERROR;
    if ((var = lookup(inst, func, vr, FG_BOOLEAN)) == NULL || !settable(inst, func, var)) return FG_ERROR;
    return fg_model_set_boolean(inst, inst->data, vr, v ? 1 : 0);
}

fg_status fg_enter_initialization(fg_instance *inst, const char *func, double start_time)
{
    if (!fg_allowed(inst, func, FG_PHASE_INSTANTIATED)) return FG_ERROR;
    if (!isfinite(start_time)) {
        fg_log(inst, FG_ERROR, NULL, "%s: start time %g is not finite", func, start_time);
        return FG_ERROR;
    }
    inst->time = start_time;
    inst->phase = FG_PHASE_INIT;
    return FG_OK;
}

fg_status fg_exit_initialization(fg_instance *inst, const char *func)
{
    fg_status s;
    if (!fg_allowed(inst, func, FG_PHASE_INIT)) return FG_ERROR;
    s = fg_model_exit_initialization(inst, inst->data, inst->time);
    if (s >= FG_DISCARD) {  /* a discard here is an error too: initialization failed */
        inst->phase = FG_PHASE_ERROR;
        return FG_ERROR;
    }
    inst->phase = FG_PHASE_STEP;
    return s;
}

fg_status fg_do_step(fg_instance *inst, const char *func, double t, double h)
{
    fg_status s;
    double tol;
    if (!fg_allowed(inst, func, FG_PHASE_STEP)) return FG_ERROR;
    if (!isfinite(t) || !isfinite(h) || h < 0.0) {
        fg_log(inst, FG_ERROR, NULL, "%s: invalid communication point %g or step size %g", func, t, h);
        return FG_ERROR;
    }
    tol = 1e-9 * (fabs(inst->time) > 1.0 ? fabs(inst->time) : 1.0);
    if (fabs(t - inst->time) > tol) {
        fg_log(inst, FG_ERROR, NULL, "%s: communication point %.17g differs from the FMU time %.17g", func, t,
               inst->time);
        return FG_ERROR;
    }
    s = fg_model_do_step(inst, inst->data, t, h);
    if (s <= FG_WARNING) {
        inst->time = t + h;
    } else if (s == FG_DISCARD) {
        inst->phase = FG_PHASE_STEP_FAILED;
    } else {
        inst->phase = FG_PHASE_ERROR;
        s = FG_ERROR;
    }
    return s;
}

/* ---- FMU state ---- */

size_t fg_state_size(void) { return sizeof(fg_state_header) + FG_MODEL_DATA_SIZE; }

static void fill_header(const fg_instance *inst, fg_state_header *h)
{
    memset(h, 0, sizeof *h);
    memcpy(h->magic, FG_STATE_MAGIC, sizeof FG_STATE_MAGIC);
    h->format_version = FG_STATE_FORMAT;
    h->phase = (uint32_t)inst->phase;
    h->data_size = (uint64_t)FG_MODEL_DATA_SIZE;
    strncpy(h->model_identifier, FG_MODEL_IDENTIFIER_STRING, FG_TAG_LEN - 1);
    strncpy(h->token, INSTANTIATION_TOKEN, FG_TAG_LEN - 1);
    h->time = inst->time;
}

#define STATE_MASK (FG_PHASE_INSTANTIATED | FG_PHASE_INIT | FG_PHASE_STEP | FG_PHASE_STEP_FAILED | FG_PHASE_TERMINATED)

fg_status fg_state_get(fg_instance *inst, const char *func, void **state)
{
    fg_state_header h;
    unsigned char *blob;
    if (!fg_allowed(inst, func, STATE_MASK)) return FG_ERROR;
    if (state == NULL) {
        fg_log(inst, FG_ERROR, NULL, "%s: NULL state pointer", func);
        return FG_ERROR;
    }
    blob = (unsigned char *)(*state != NULL ? *state : malloc(fg_state_size()));
    if (blob == NULL) {
        fg_log(inst, FG_ERROR, NULL, "%s: out of memory", func);
        return FG_ERROR;
    }
    fill_header(inst, &h);
    memcpy(blob, &h, sizeof h);
    memcpy(blob + sizeof h, inst->data, FG_MODEL_DATA_SIZE);
    *state = blob;
    return FG_OK;
}

/* checks a blob of size bytes; logs why it is refused */
static int blob_ok(fg_instance *inst, const char *func, const unsigned char *buf, size_t size)
{
    fg_state_header h, mine;
    if (buf == NULL) {
        fg_log(inst, FG_ERROR, NULL, "%s: NULL state", func);
        return 0;
    }
    if (size < sizeof h) {
        fg_log(inst, FG_ERROR, NULL, "%s: state of %lu bytes is truncated (header is %lu bytes)", func,
               (unsigned long)size, (unsigned long)sizeof h);
        return 0;
    }
    memcpy(&h, buf, sizeof h);
    fill_header(inst, &mine);
    if (memcmp(h.magic, mine.magic, sizeof h.magic) != 0) {
        fg_log(inst, FG_ERROR, NULL, "%s: not a serialized FMU state of this glue (bad magic)", func);
        return 0;
    }
    if (h.format_version != mine.format_version) {
        fg_log(inst, FG_ERROR, NULL, "%s: state format version %lu, expected %lu", func,
               (unsigned long)h.format_version, (unsigned long)mine.format_version);
        return 0;
    }
    /* the whole zero-padded fields must match */
    h.model_identifier[FG_TAG_LEN - 1] = '\0';
    h.token[FG_TAG_LEN - 1] = '\0';
    if (memcmp(h.model_identifier, mine.model_identifier, FG_TAG_LEN) != 0) {
        fg_log(inst, FG_ERROR, NULL, "%s: state of another model ('%s'), this is '%s'", func, h.model_identifier,
               mine.model_identifier);
        return 0;
    }
    if (memcmp(h.token, mine.token, FG_TAG_LEN) != 0) {
        fg_log(inst, FG_ERROR, NULL, "%s: state of build %s, this is %s", func, h.token, mine.token);
        return 0;
    }
    if (h.data_size == mine.data_size && size < fg_state_size()) {
        fg_log(inst, FG_ERROR, NULL, "%s: state of %lu bytes is truncated (expected %lu)", func, (unsigned long)size,
               (unsigned long)fg_state_size());
        return 0;
    }
    if (h.data_size != mine.data_size || size != fg_state_size()) {
        fg_log(inst, FG_ERROR, NULL, "%s: state of %lu bytes with %lu data bytes, expected %lu and %lu", func,
               (unsigned long)size, (unsigned long)h.data_size, (unsigned long)fg_state_size(),
               (unsigned long)mine.data_size);
        return 0;
    }
    if (!(h.phase & STATE_MASK) || !isfinite(h.time)) {
        fg_log(inst, FG_ERROR, NULL, "%s: state with invalid phase %lu or time", func, (unsigned long)h.phase);
        return 0;
    }
    return 1;
}

fg_status fg_state_set(fg_instance *inst, const char *func, const void *state)
{
    fg_state_header h;
    if (!fg_allowed(inst, func, STATE_MASK)) return FG_ERROR;
    if (!blob_ok(inst, func, (const unsigned char *)state, fg_state_size())) return FG_ERROR;
    memcpy(&h, state, sizeof h);
    memcpy(inst->data, (const unsigned char *)state + sizeof h, FG_MODEL_DATA_SIZE);
    inst->phase = (fg_phase)h.phase;
    inst->time = h.time;
    return FG_OK;
}

void fg_state_free(void *state) { free(state); }

fg_status fg_state_serialize(fg_instance *inst, const char *func, const void *state, unsigned char *buf, size_t size)
{
    if (!fg_allowed(inst, func, FG_PHASE_ANY)) return FG_ERROR;
    if (state == NULL || buf == NULL) {
        fg_log(inst, FG_ERROR, NULL, "%s: NULL state or buffer", func);
        return FG_ERROR;
    }
    if (size != fg_state_size()) {
        fg_log(inst, FG_ERROR, NULL, "%s: buffer of %lu bytes, the state has %lu", func, (unsigned long)size,
               (unsigned long)fg_state_size());
        return FG_ERROR;
    }
    memcpy(buf, state, size);
    return FG_OK;
}

fg_status fg_state_deserialize(fg_instance *inst, const char *func, const unsigned char *buf, size_t size, void **state)
{
    void *blob;
    if (!fg_allowed(inst, func, FG_PHASE_ANY)) return FG_ERROR;
    if (state == NULL) {
        fg_log(inst, FG_ERROR, NULL, "%s: NULL state pointer", func);
        return FG_ERROR;
    }
    if (!blob_ok(inst, func, buf, size)) return FG_ERROR;
    blob = *state != NULL ? *state : malloc(size);
    if (blob == NULL) {
        fg_log(inst, FG_ERROR, NULL, "%s: out of memory", func);
        return FG_ERROR;
    }
    memcpy(blob, buf, size);
    *state = blob;
    return FG_OK;
}

/* sm_instance.c - see sm_instance.h */
#include "sm_instance.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SM_STATE_MAGIC "SMFMUST"
#define SM_STATE_FORMAT 1u
#define SM_TAG_LEN 64

typedef struct {
    char magic[8];
    uint32_t format_version;
    uint32_t phase;
    uint64_t data_size;
    char model_identifier[SM_TAG_LEN];
    char token[SM_TAG_LEN];
    double time;
} sm_state_header;

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

sm_instance *sm_instance_new(const char *name, const char *resource_path, void *env, sm_generic_fn logger,
                             sm_emit_fn emit, int logging_on)
{
    sm_instance *inst = (sm_instance *)calloc(1, sizeof(sm_instance));
    if (inst == NULL) return NULL;
    inst->name = dup_string(name);
    inst->resource_path = resource_dir(resource_path);
    inst->env = env;
    inst->logger = logger;
    inst->emit = emit;
    inst->logging_on = logging_on;
    inst->data = calloc(1, SM_MODEL_DATA_SIZE > 0 ? SM_MODEL_DATA_SIZE : 1);
    if (inst->name == NULL || inst->data == NULL) {
        sm_instance_free(inst);
        return NULL;
    }
    sm_instance_reset(inst);
    return inst;
}

void sm_instance_free(sm_instance *inst)
{
    if (inst == NULL) return;
    free(inst->name);
    free(inst->resource_path);
    free(inst->data);
    free(inst);
}

void sm_instance_reset(sm_instance *inst)
{
    memset(inst->data, 0, SM_MODEL_DATA_SIZE);
    inst->phase = SM_PHASE_INSTANTIATED;
    inst->time = 0.0;
    sm_model_start(inst, inst->data);
}

const char *sm_instance_name(const sm_instance *inst) { return inst ? inst->name : NULL; }
const char *sm_resource_path(const sm_instance *inst) { return inst ? inst->resource_path : NULL; }

void sm_log(sm_instance *inst, sm_status status, const char *category, const char *fmt, ...)
{
    char buf[1024];
    va_list ap;
    if (inst == NULL || inst->emit == NULL || inst->logger == NULL) return;
    if (status == SM_OK && !inst->logging_on) return;
    if (category == NULL) {
        category = status == SM_ERROR ? "logStatusError" : status == SM_DISCARD ? "logStatusDiscard"
                 : status == SM_WARNING ? "logStatusWarning" : "logEvents";
    }
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    inst->emit(inst, status, category, buf);
}

static const char *phase_name(sm_phase p)
{
    switch (p) {
    case SM_PHASE_INSTANTIATED: return "instantiated";
    case SM_PHASE_INIT: return "initialization mode";
    case SM_PHASE_STEP: return "step mode";
    case SM_PHASE_STEP_FAILED: return "step failed (after discard)";
    case SM_PHASE_TERMINATED: return "terminated";
    case SM_PHASE_ERROR: return "error";
    }
    return "?";
}

int sm_allowed(sm_instance *inst, const char *func, unsigned mask)
{
    if (inst == NULL) return 0;
    if ((unsigned)inst->phase & mask) return 1;
    sm_log(inst, SM_ERROR, NULL, "%s: not allowed in phase '%s'", func, phase_name(inst->phase));
    return 0;
}

sm_status sm_unsupported(sm_instance *inst, const char *func)
{
    sm_log(inst, SM_ERROR, NULL, "%s is not supported by %s", func, SM_MODEL_IDENTIFIER_STRING);
    return SM_ERROR;
}

int sm_args_ok(sm_instance *inst, const char *func, size_t n, const void *a, const void *b)
{
    if (n > 0 && (a == NULL || b == NULL)) {
        sm_log(inst, SM_ERROR, NULL, "%s: NULL array argument", func);
        return 0;
    }
    return 1;
}

static const char *type_name(sm_type t)
{
    return t == SM_REAL ? "Real" : t == SM_INTEGER ? "Integer" : t == SM_BOOLEAN ? "Boolean" : "String";
}

static const sm_variable *lookup(sm_instance *inst, const char *func, uint32_t vr, sm_type type)
{
    size_t i;
    /* fast path: a table ordered so that entry vr has value reference vr */
    if (vr < SM_MODEL_N_VARIABLES && SM_MODEL_VARIABLES[vr].vr == vr && SM_MODEL_VARIABLES[vr].type == type)
        return &SM_MODEL_VARIABLES[vr];
    for (i = 0; i < SM_MODEL_N_VARIABLES; i++)
        if (SM_MODEL_VARIABLES[i].vr == vr && SM_MODEL_VARIABLES[i].type == type) return &SM_MODEL_VARIABLES[i];
    sm_log(inst, SM_ERROR, NULL, "%s: unknown value reference %lu for a %s variable", func, (unsigned long)vr,
           type_name(type));
    return NULL;
}

#define GET_MASK (SM_PHASE_INIT | SM_PHASE_STEP | SM_PHASE_STEP_FAILED | SM_PHASE_TERMINATED | SM_PHASE_ERROR)
#define SET_MASK (SM_PHASE_INSTANTIATED | SM_PHASE_INIT | SM_PHASE_STEP)

/* may the variable be set now? */
static int settable(sm_instance *inst, const char *func, const sm_variable *v)
{
    unsigned mask;
    switch (v->kind) {
    case SM_PARAMETER: mask = SM_PHASE_INSTANTIATED | SM_PHASE_INIT; break;
    case SM_TUNABLE_PARAMETER:
    case SM_INPUT: mask = SET_MASK; break;
    default:
        sm_log(inst, SM_ERROR, NULL, "%s: variable '%s' (value reference %lu) is not settable", func, v->name,
               (unsigned long)v->vr);
        return 0;
    }
    if ((unsigned)inst->phase & mask) return 1;
    sm_log(inst, SM_ERROR, NULL, "%s: variable '%s' (value reference %lu) %s cannot be set in phase '%s'", func,
           v->name, (unsigned long)v->vr, v->kind == SM_PARAMETER ? "is a fixed parameter and" : "",
           phase_name(inst->phase));
    return 0;
}

static sm_status worse(sm_status a, sm_status b) { return a > b ? a : b; }

#define DEFINE_GET(NAME, CTYPE, TYPE, MODELFN)                                                          \
    sm_status NAME(sm_instance *inst, const char *func, const uint32_t vr[], size_t n, CTYPE v[])      \
    {                                                                                                  \
        size_t i;                                                                                      \
        sm_status s = SM_OK;                                                                           \
        if (!sm_allowed(inst, func, GET_MASK) || !sm_args_ok(inst, func, n, vr, v)) return SM_ERROR;   \
        for (i = 0; i < n && s < SM_ERROR; i++) {                                                      \
            if (lookup(inst, func, vr[i], TYPE) == NULL) return SM_ERROR;                              \
            s = worse(s, MODELFN(inst, inst->data, vr[i], &v[i]));                                     \
        }                                                                                              \
        return s;                                                                                      \
    }

#define DEFINE_SET(NAME, CTYPE, TYPE, MODELFN)                                                         \
    sm_status NAME(sm_instance *inst, const char *func, const uint32_t vr[], size_t n, const CTYPE v[]) \
    {                                                                                                  \
        size_t i;                                                                                      \
        sm_status s = SM_OK;                                                                           \
        const sm_variable *var;                                                                        \
        if (!sm_allowed(inst, func, SET_MASK) || !sm_args_ok(inst, func, n, vr, v)) return SM_ERROR;   \
        for (i = 0; i < n && s < SM_ERROR; i++) {                                                      \
            if ((var = lookup(inst, func, vr[i], TYPE)) == NULL || !settable(inst, func, var))         \
                return SM_ERROR;                                                                       \
            s = worse(s, MODELFN(inst, inst->data, vr[i], v[i]));                                      \
        }                                                                                              \
        return s;                                                                                      \
    }

DEFINE_GET(sm_get_real, double, SM_REAL, sm_model_get_real)
DEFINE_SET(sm_set_real, double, SM_REAL, sm_model_set_real)
DEFINE_GET(sm_get_integer, int32_t, SM_INTEGER, sm_model_get_integer)
DEFINE_SET(sm_set_integer, int32_t, SM_INTEGER, sm_model_set_integer)
DEFINE_GET(sm_get_string, const char *, SM_STRING, sm_model_get_string)

sm_status sm_set_string(sm_instance *inst, const char *func, const uint32_t vr[], size_t n, const char *const v[])
{
    size_t i;
    sm_status s = SM_OK;
    const sm_variable *var;
    if (!sm_allowed(inst, func, SET_MASK) || !sm_args_ok(inst, func, n, vr, v)) return SM_ERROR;
    for (i = 0; i < n && s < SM_ERROR; i++) {
        if ((var = lookup(inst, func, vr[i], SM_STRING)) == NULL || !settable(inst, func, var)) return SM_ERROR;
        if (v[i] == NULL) {
            sm_log(inst, SM_ERROR, NULL, "%s: NULL string for '%s'", func, var->name);
            return SM_ERROR;
        }
        s = worse(s, sm_model_set_string(inst, inst->data, vr[i], v[i]));
    }
    return s;
}

sm_status sm_get_boolean1(sm_instance *inst, const char *func, uint32_t vr, int *v)
{
    if (!sm_allowed(inst, func, GET_MASK)) return SM_ERROR;
    if (lookup(inst, func, vr, SM_BOOLEAN) == NULL) return SM_ERROR;
    return sm_model_get_boolean(inst, inst->data, vr, v);
}

sm_status sm_set_boolean1(sm_instance *inst, const char *func, uint32_t vr, int v)
{
    const sm_variable *var;
    if (!sm_allowed(inst, func, SET_MASK)) return SM_ERROR;
    if ((var = lookup(inst, func, vr, SM_BOOLEAN)) == NULL || !settable(inst, func, var)) return SM_ERROR;
    return sm_model_set_boolean(inst, inst->data, vr, v ? 1 : 0);
}

sm_status sm_enter_initialization(sm_instance *inst, const char *func, double start_time)
{
    if (!sm_allowed(inst, func, SM_PHASE_INSTANTIATED)) return SM_ERROR;
    if (!isfinite(start_time)) {
        sm_log(inst, SM_ERROR, NULL, "%s: start time %g is not finite", func, start_time);
        return SM_ERROR;
    }
    inst->time = start_time;
    inst->phase = SM_PHASE_INIT;
    return SM_OK;
}

sm_status sm_exit_initialization(sm_instance *inst, const char *func)
{
    sm_status s;
    if (!sm_allowed(inst, func, SM_PHASE_INIT)) return SM_ERROR;
    s = sm_model_exit_initialization(inst, inst->data, inst->time);
    if (s >= SM_DISCARD) {  /* a discard here is an error too: initialization failed */
        inst->phase = SM_PHASE_ERROR;
        return SM_ERROR;
    }
    inst->phase = SM_PHASE_STEP;
    return s;
}

sm_status sm_do_step(sm_instance *inst, const char *func, double t, double h)
{
    sm_status s;
    double tol;
    if (!sm_allowed(inst, func, SM_PHASE_STEP)) return SM_ERROR;
    if (!isfinite(t) || !isfinite(h) || h < 0.0) {
        sm_log(inst, SM_ERROR, NULL, "%s: invalid communication point %g or step size %g", func, t, h);
        return SM_ERROR;
    }
    tol = 1e-9 * (fabs(inst->time) > 1.0 ? fabs(inst->time) : 1.0);
    if (fabs(t - inst->time) > tol) {
        sm_log(inst, SM_ERROR, NULL, "%s: communication point %.17g differs from the FMU time %.17g", func, t,
               inst->time);
        return SM_ERROR;
    }
    s = sm_model_do_step(inst, inst->data, t, h);
    if (s <= SM_WARNING) {
        inst->time = t + h;
    } else if (s == SM_DISCARD) {
        inst->phase = SM_PHASE_STEP_FAILED;
    } else {
        inst->phase = SM_PHASE_ERROR;
        s = SM_ERROR;
    }
    return s;
}

/* ---- FMU state ---- */

size_t sm_state_size(void) { return sizeof(sm_state_header) + SM_MODEL_DATA_SIZE; }

static void fill_header(const sm_instance *inst, sm_state_header *h)
{
    memset(h, 0, sizeof *h);
    memcpy(h->magic, SM_STATE_MAGIC, sizeof SM_STATE_MAGIC);
    h->format_version = SM_STATE_FORMAT;
    h->phase = (uint32_t)inst->phase;
    h->data_size = (uint64_t)SM_MODEL_DATA_SIZE;
    strncpy(h->model_identifier, SM_MODEL_IDENTIFIER_STRING, SM_TAG_LEN - 1);
    strncpy(h->token, INSTANTIATION_TOKEN, SM_TAG_LEN - 1);
    h->time = inst->time;
}

#define STATE_MASK (SM_PHASE_INSTANTIATED | SM_PHASE_INIT | SM_PHASE_STEP | SM_PHASE_STEP_FAILED | SM_PHASE_TERMINATED)

sm_status sm_state_get(sm_instance *inst, const char *func, void **state)
{
    sm_state_header h;
    unsigned char *blob;
    if (!sm_allowed(inst, func, STATE_MASK)) return SM_ERROR;
    if (state == NULL) {
        sm_log(inst, SM_ERROR, NULL, "%s: NULL state pointer", func);
        return SM_ERROR;
    }
    blob = (unsigned char *)(*state != NULL ? *state : malloc(sm_state_size()));
    if (blob == NULL) {
        sm_log(inst, SM_ERROR, NULL, "%s: out of memory", func);
        return SM_ERROR;
    }
    fill_header(inst, &h);
    memcpy(blob, &h, sizeof h);
    memcpy(blob + sizeof h, inst->data, SM_MODEL_DATA_SIZE);
    *state = blob;
    return SM_OK;
}

/* checks a blob of size bytes; logs why it is refused */
static int blob_ok(sm_instance *inst, const char *func, const unsigned char *buf, size_t size)
{
    sm_state_header h, mine;
    if (buf == NULL) {
        sm_log(inst, SM_ERROR, NULL, "%s: NULL state", func);
        return 0;
    }
    if (size < sizeof h) {
        sm_log(inst, SM_ERROR, NULL, "%s: state of %lu bytes is truncated (header is %lu bytes)", func,
               (unsigned long)size, (unsigned long)sizeof h);
        return 0;
    }
    memcpy(&h, buf, sizeof h);
    fill_header(inst, &mine);
    if (memcmp(h.magic, mine.magic, sizeof h.magic) != 0) {
        sm_log(inst, SM_ERROR, NULL, "%s: not a serialized FMU state of this glue (bad magic)", func);
        return 0;
    }
    if (h.format_version != mine.format_version) {
        sm_log(inst, SM_ERROR, NULL, "%s: state format version %lu, expected %lu", func,
               (unsigned long)h.format_version, (unsigned long)mine.format_version);
        return 0;
    }
    /* the whole zero-padded fields must match */
    h.model_identifier[SM_TAG_LEN - 1] = '\0';
    h.token[SM_TAG_LEN - 1] = '\0';
    if (memcmp(h.model_identifier, mine.model_identifier, SM_TAG_LEN) != 0) {
        sm_log(inst, SM_ERROR, NULL, "%s: state of another model ('%s'), this is '%s'", func, h.model_identifier,
               mine.model_identifier);
        return 0;
    }
    if (memcmp(h.token, mine.token, SM_TAG_LEN) != 0) {
        sm_log(inst, SM_ERROR, NULL, "%s: state of build %s, this is %s", func, h.token, mine.token);
        return 0;
    }
    if (h.data_size == mine.data_size && size < sm_state_size()) {
        sm_log(inst, SM_ERROR, NULL, "%s: state of %lu bytes is truncated (expected %lu)", func, (unsigned long)size,
               (unsigned long)sm_state_size());
        return 0;
    }
    if (h.data_size != mine.data_size || size != sm_state_size()) {
        sm_log(inst, SM_ERROR, NULL, "%s: state of %lu bytes with %lu data bytes, expected %lu and %lu", func,
               (unsigned long)size, (unsigned long)h.data_size, (unsigned long)sm_state_size(),
               (unsigned long)mine.data_size);
        return 0;
    }
    if (!(h.phase & STATE_MASK) || !isfinite(h.time)) {
        sm_log(inst, SM_ERROR, NULL, "%s: state with invalid phase %lu or time", func, (unsigned long)h.phase);
        return 0;
    }
    return 1;
}

sm_status sm_state_set(sm_instance *inst, const char *func, const void *state)
{
    sm_state_header h;
    if (!sm_allowed(inst, func, STATE_MASK)) return SM_ERROR;
    if (!blob_ok(inst, func, (const unsigned char *)state, sm_state_size())) return SM_ERROR;
    memcpy(&h, state, sizeof h);
    memcpy(inst->data, (const unsigned char *)state + sizeof h, SM_MODEL_DATA_SIZE);
    inst->phase = (sm_phase)h.phase;
    inst->time = h.time;
    return SM_OK;
}

void sm_state_free(void *state) { free(state); }

sm_status sm_state_serialize(sm_instance *inst, const char *func, const void *state, unsigned char *buf, size_t size)
{
    if (!sm_allowed(inst, func, SM_PHASE_ANY)) return SM_ERROR;
    if (state == NULL || buf == NULL) {
        sm_log(inst, SM_ERROR, NULL, "%s: NULL state or buffer", func);
        return SM_ERROR;
    }
    if (size != sm_state_size()) {
        sm_log(inst, SM_ERROR, NULL, "%s: buffer of %lu bytes, the state has %lu", func, (unsigned long)size,
               (unsigned long)sm_state_size());
        return SM_ERROR;
    }
    memcpy(buf, state, size);
    return SM_OK;
}

sm_status sm_state_deserialize(sm_instance *inst, const char *func, const unsigned char *buf, size_t size, void **state)
{
    void *blob;
    if (!sm_allowed(inst, func, SM_PHASE_ANY)) return SM_ERROR;
    if (state == NULL) {
        sm_log(inst, SM_ERROR, NULL, "%s: NULL state pointer", func);
        return SM_ERROR;
    }
    if (!blob_ok(inst, func, buf, size)) return SM_ERROR;
    blob = *state != NULL ? *state : malloc(size);
    if (blob == NULL) {
        sm_log(inst, SM_ERROR, NULL, "%s: out of memory", func);
        return SM_ERROR;
    }
    memcpy(blob, buf, size);
    *state = blob;
    return SM_OK;
}

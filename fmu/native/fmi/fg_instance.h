/* fg_instance.h - the model-agnostic FMU instance shared by fmi2_glue.c and fmi3_glue.c:
 * instance name, logger, FMI phase (state machine), resource path, the model data buffer,
 * variable checks and the FMU state blob. No global mutable state. */
#ifndef FG_INSTANCE_H
#define FG_INSTANCE_H

#include "fg_model.h"

/* a source-code FMU carries its identity in fg_identity.h beside the sources (written by the build),
 * so that `cc -shared *.c` needs no -D; the build itself passes both with -D */
#if !defined(MODEL_IDENTIFIER) && !defined(INSTANTIATION_TOKEN)
#include "fg_identity.h"
#endif
#if !defined(MODEL_IDENTIFIER) || !defined(INSTANTIATION_TOKEN)
#error "compile with -DMODEL_IDENTIFIER=<id> -DINSTANTIATION_TOKEN=\"{guid}\""
#endif
#define FG_STR_(x) #x
#define FG_STR(x) FG_STR_(x)
#define FG_MODEL_IDENTIFIER_STRING FG_STR(MODEL_IDENTIFIER)

/* phases as bit flags, so a function states where it is allowed as a mask */
typedef enum {
    FG_PHASE_INSTANTIATED = 1,
    FG_PHASE_INIT = 2,          /* initialization mode */
    FG_PHASE_STEP = 4,          /* fmi2 stepComplete / fmi3 step mode */
    FG_PHASE_STEP_FAILED = 8,   /* a step returned discard */
    FG_PHASE_TERMINATED = 16,
    FG_PHASE_ERROR = 32
} fg_phase;
#define FG_PHASE_ANY 63u

/* the FMI-version specific emitter of one formatted message */
typedef void (*fg_emit_fn)(fg_instance *inst, fg_status status, const char *category, const char *message);
typedef void (*fg_generic_fn)(void);

struct fg_instance {
    char *name;
    char *resource_path;
    void *env;                  /* fmi2ComponentEnvironment / fmi3InstanceEnvironment */
    fg_generic_fn logger;       /* the importer's logger, cast back by the glue */
    fg_emit_fn emit;
    int logging_on;
    fg_phase phase;
    int me_continuous;          /* model exchange in FG_PHASE_STEP: 1 continuous-time mode, 0 event mode */
    double time;
    double stop_time;           /* the host's stop time, +inf when it gave none */
    void *data;                 /* FG_MODEL_DATA_SIZE bytes */
};

fg_instance *fg_instance_new(const char *name, const char *resource_path, void *env, fg_generic_fn logger,
                             fg_emit_fn emit, int logging_on);
void fg_instance_free(fg_instance *inst);
void fg_instance_reset(fg_instance *inst);

/* 1 if inst is in one of the phases of mask, else log an error naming func and return 0 */
int fg_allowed(fg_instance *inst, const char *func, unsigned mask);
fg_status fg_unsupported(fg_instance *inst, const char *func);
/* non-NULL check for array arguments with n > 0 */
int fg_args_ok(fg_instance *inst, const char *func, size_t n, const void *a, const void *b);

fg_status fg_get_real(fg_instance *inst, const char *func, const uint32_t vr[], size_t n, double v[]);
fg_status fg_set_real(fg_instance *inst, const char *func, const uint32_t vr[], size_t n, const double v[]);
fg_status fg_get_integer(fg_instance *inst, const char *func, const uint32_t vr[], size_t n, int32_t v[]);
fg_status fg_set_integer(fg_instance *inst, const char *func, const uint32_t vr[], size_t n, const int32_t v[]);
/* booleans one at a time: fmi2Boolean is int, fmi3Boolean is bool */
fg_status fg_get_boolean1(fg_instance *inst, const char *func, uint32_t vr, int *v);
fg_status fg_set_boolean1(fg_instance *inst, const char *func, uint32_t vr, int v);
fg_status fg_get_string(fg_instance *inst, const char *func, const uint32_t vr[], size_t n, const char *v[]);
fg_status fg_set_string(fg_instance *inst, const char *func, const uint32_t vr[], size_t n, const char *const v[]);

fg_status fg_enter_initialization(fg_instance *inst, const char *func, double start_time);
fg_status fg_exit_initialization(fg_instance *inst, const char *func);
fg_status fg_do_step(fg_instance *inst, const char *func, double t, double h);

/* FMU state: one heap blob = header + model data; the in-memory and serialized forms are the same */
size_t fg_state_size(void);
fg_status fg_state_get(fg_instance *inst, const char *func, void **state);
fg_status fg_state_set(fg_instance *inst, const char *func, const void *state);
void fg_state_free(void *state);
fg_status fg_state_serialize(fg_instance *inst, const char *func, const void *state, unsigned char *buf, size_t size);
/* checks tag, sizes; on success *state holds a new (or the reused *state) blob; on failure unchanged */
fg_status fg_state_deserialize(fg_instance *inst, const char *func, const unsigned char *buf, size_t size, void **state);

#endif

/* sm_instance.h - the model-agnostic FMU instance shared by fmi2_glue.c and fmi3_glue.c:
 * instance name, logger, FMI phase (state machine), resource path, the model data buffer,
 * variable checks and the FMU state blob. No global mutable state. */
#ifndef SM_INSTANCE_H
#define SM_INSTANCE_H

#include "sm_model.h"

#if !defined(MODEL_IDENTIFIER) || !defined(INSTANTIATION_TOKEN)
#error "compile with -DMODEL_IDENTIFIER=<id> -DINSTANTIATION_TOKEN=\"{guid}\""
#endif
#define SM_STR_(x) #x
#define SM_STR(x) SM_STR_(x)
#define SM_MODEL_IDENTIFIER_STRING SM_STR(MODEL_IDENTIFIER)

/* phases as bit flags, so a function states where it is allowed as a mask */
typedef enum {
    SM_PHASE_INSTANTIATED = 1,
    SM_PHASE_INIT = 2,          /* initialization mode */
    SM_PHASE_STEP = 4,          /* fmi2 stepComplete / fmi3 step mode */
    SM_PHASE_STEP_FAILED = 8,   /* a step returned discard */
    SM_PHASE_TERMINATED = 16,
    SM_PHASE_ERROR = 32
} sm_phase;
#define SM_PHASE_ANY 63u

/* the FMI-version specific emitter of one formatted message */
typedef void (*sm_emit_fn)(sm_instance *inst, sm_status status, const char *category, const char *message);
typedef void (*sm_generic_fn)(void);

struct sm_instance {
    char *name;
    char *resource_path;
    void *env;                  /* fmi2ComponentEnvironment / fmi3InstanceEnvironment */
    sm_generic_fn logger;       /* the importer's logger, cast back by the glue */
    sm_emit_fn emit;
    int logging_on;
    sm_phase phase;
    double time;
    void *data;                 /* SM_MODEL_DATA_SIZE bytes */
};

sm_instance *sm_instance_new(const char *name, const char *resource_path, void *env, sm_generic_fn logger,
                             sm_emit_fn emit, int logging_on);
void sm_instance_free(sm_instance *inst);
void sm_instance_reset(sm_instance *inst);

/* 1 if inst is in one of the phases of mask, else log an error naming func and return 0 */
int sm_allowed(sm_instance *inst, const char *func, unsigned mask);
sm_status sm_unsupported(sm_instance *inst, const char *func);
/* non-NULL check for array arguments with n > 0 */
int sm_args_ok(sm_instance *inst, const char *func, size_t n, const void *a, const void *b);

sm_status sm_get_real(sm_instance *inst, const char *func, const uint32_t vr[], size_t n, double v[]);
sm_status sm_set_real(sm_instance *inst, const char *func, const uint32_t vr[], size_t n, const double v[]);
sm_status sm_get_integer(sm_instance *inst, const char *func, const uint32_t vr[], size_t n, int32_t v[]);
sm_status sm_set_integer(sm_instance *inst, const char *func, const uint32_t vr[], size_t n, const int32_t v[]);
/* booleans one at a time: fmi2Boolean is int, fmi3Boolean is bool */
sm_status sm_get_boolean1(sm_instance *inst, const char *func, uint32_t vr, int *v);
sm_status sm_set_boolean1(sm_instance *inst, const char *func, uint32_t vr, int v);
sm_status sm_get_string(sm_instance *inst, const char *func, const uint32_t vr[], size_t n, const char *v[]);
sm_status sm_set_string(sm_instance *inst, const char *func, const uint32_t vr[], size_t n, const char *const v[]);

sm_status sm_enter_initialization(sm_instance *inst, const char *func, double start_time);
sm_status sm_exit_initialization(sm_instance *inst, const char *func);
sm_status sm_do_step(sm_instance *inst, const char *func, double t, double h);

/* FMU state: one heap blob = header + model data; the in-memory and serialized forms are the same */
size_t sm_state_size(void);
sm_status sm_state_get(sm_instance *inst, const char *func, void **state);
sm_status sm_state_set(sm_instance *inst, const char *func, const void *state);
void sm_state_free(void *state);
sm_status sm_state_serialize(sm_instance *inst, const char *func, const void *state, unsigned char *buf, size_t size);
/* checks tag, sizes; on success *state holds a new (or the reused *state) blob; on failure unchanged */
sm_status sm_state_deserialize(sm_instance *inst, const char *func, const unsigned char *buf, size_t size, void **state);

#endif

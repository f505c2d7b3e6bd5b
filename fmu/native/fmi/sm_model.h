/* sm_model.h - the interface a model implements for the satmotor native FMI glue.
 *
 * The glue (sm_instance.c, fmi2_glue.c, fmi3_glue.c) knows nothing of the model; a model is one or
 * more C files defining the symbols declared below. The glue
 *   - allocates SM_MODEL_DATA_SIZE bytes per instance (zeroed, then sm_model_start),
 *   - checks every value reference against SM_MODEL_VARIABLES (type, causality and the FMI phase)
 *     before it calls a getter/setter, so a model getter/setter is only called with a value
 *     reference of its own type,
 *   - copies the model data byte for byte to save/restore/serialize the FMU state: the data MUST be
 *     a plain struct without pointers (strings are fixed-size char arrays inside it).
 * No model description is needed in C: modelDescription.xml is generated in Python.
 *
 * Messages: call sm_log(inst, status, category, printf-format, ...); messages of status
 * SM_WARNING/SM_DISCARD/SM_ERROR always reach the importer's logger, SM_OK ones only with
 * debug logging on. A rejected parameter must name the variable and the value, e.g.
 *   sm_log(inst, SM_ERROR, NULL, "tau = %g is invalid: must be > 0", d->tau); return SM_ERROR;
 */
#ifndef SM_MODEL_H
#define SM_MODEL_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* the numeric values equal fmi2Status and fmi3Status */
typedef enum { SM_OK = 0, SM_WARNING = 1, SM_DISCARD = 2, SM_ERROR = 3 } sm_status;

typedef enum { SM_REAL = 0, SM_INTEGER = 1, SM_BOOLEAN = 2, SM_STRING = 3 } sm_type;

typedef enum {
    SM_INDEPENDENT = 0,      /* time: read only */
    SM_PARAMETER = 1,        /* fixed parameter: settable before exit-initialization only */
    SM_TUNABLE_PARAMETER = 2,/* settable before and between steps */
    SM_INPUT = 3,            /* settable before and between steps */
    SM_OUTPUT = 4,           /* read only */
    SM_LOCAL = 5             /* read only (calculated parameters, locals) */
} sm_kind;

typedef struct {
    uint32_t vr;        /* value reference, unique per type */
    sm_type type;
    sm_kind kind;
    const char *name;   /* for messages only */
} sm_variable;

typedef struct sm_instance sm_instance;   /* opaque to the model */

/* ---- provided by the glue ---- */
void sm_log(sm_instance *inst, sm_status status, const char *category, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
const char *sm_instance_name(const sm_instance *inst);
const char *sm_resource_path(const sm_instance *inst);  /* a directory path ending in '/', or NULL */

/* ---- implemented by the model ---- */
extern const sm_variable SM_MODEL_VARIABLES[];
extern const size_t SM_MODEL_N_VARIABLES;
extern const size_t SM_MODEL_DATA_SIZE;       /* sizeof the model's data struct */

/* start values; data is zeroed before the call (so padding bytes are deterministic) */
void sm_model_start(sm_instance *inst, void *data);

sm_status sm_model_get_real(sm_instance *inst, const void *data, uint32_t vr, double *value);
sm_status sm_model_set_real(sm_instance *inst, void *data, uint32_t vr, double value);
sm_status sm_model_get_integer(sm_instance *inst, const void *data, uint32_t vr, int32_t *value);
sm_status sm_model_set_integer(sm_instance *inst, void *data, uint32_t vr, int32_t value);
sm_status sm_model_get_boolean(sm_instance *inst, const void *data, uint32_t vr, int *value);
sm_status sm_model_set_boolean(sm_instance *inst, void *data, uint32_t vr, int value);
/* the returned string must live in data (valid until the next call on the instance) */
sm_status sm_model_get_string(sm_instance *inst, const void *data, uint32_t vr, const char **value);
/* value is never NULL; copy it into data (refuse with SM_ERROR if too long) */
sm_status sm_model_set_string(sm_instance *inst, void *data, uint32_t vr, const char *value);

/* end of initialization: check the parameters, compute the initial state and outputs */
sm_status sm_model_exit_initialization(sm_instance *inst, void *data, double start_time);
/* advance from t to t + h (h >= 0); SM_DISCARD with a message for non-finite inputs or a failed
 * integration (the glue then refuses further steps), SM_ERROR for an unrecoverable failure */
sm_status sm_model_do_step(sm_instance *inst, void *data, double t, double h);

#ifdef __cplusplus
}
#endif
#endif

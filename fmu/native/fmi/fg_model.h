/* fg_model.h - the interface a model implements for the satmotor native FMI glue.
 *
 * The glue (fg_instance.c, fmi2_glue.c, fmi3_glue.c) knows nothing of the model; a model is one or
 * more C files defining the symbols declared below. The glue
 *   - allocates FG_MODEL_DATA_SIZE bytes per instance (zeroed, then fg_model_start),
 *   - checks every value reference against FG_MODEL_VARIABLES (type, causality and the FMI phase)
 *     before it calls a getter/setter, so a model getter/setter is only called with a value
 *     reference of its own type,
 *   - copies the model data byte for byte to save/restore/serialize the FMU state: the data MUST be
 *     a plain struct without pointers (strings are fixed-size char arrays inside it).
 * No model description is needed in C: modelDescription.xml is generated in Python.
 *
 * Messages: call fg_log(inst, status, category, printf-format, ...); messages of status
 * FG_WARNING/FG_DISCARD/FG_ERROR always reach the importer's logger, FG_OK ones only with
 * debug logging on. A rejected parameter must name the variable and the value, e.g.
 *   fg_log(inst, FG_ERROR, NULL, "tau = %g is invalid: must be > 0", d->tau); return FG_ERROR;
 */
#ifndef FG_MODEL_H
#define FG_MODEL_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* the numeric values equal fmi2Status and fmi3Status */
typedef enum { FG_OK = 0, FG_WARNING = 1, FG_DISCARD = 2, FG_ERROR = 3 } fg_status;

typedef enum { FG_REAL = 0, FG_INTEGER = 1, FG_BOOLEAN = 2, FG_STRING = 3 } fg_type;

typedef enum {
    FG_INDEPENDENT = 0,      /* time: read only */
    FG_PARAMETER = 1,        /* fixed parameter: settable before exit-initialization only */
    FG_TUNABLE_PARAMETER = 2,/* settable before and between steps */
    FG_INPUT = 3,            /* settable before and between steps */
    FG_OUTPUT = 4,           /* read only */
    FG_LOCAL = 5             /* read only (calculated parameters, locals) */
} fg_kind;

typedef struct {
    uint32_t vr;        /* value reference, unique per type */
    fg_type type;
    fg_kind kind;
    const char *name;   /* for messages only */
} fg_variable;

typedef struct fg_instance fg_instance;   /* opaque to the model */

/* ---- provided by the glue ---- */
void fg_log(fg_instance *inst, fg_status status, const char *category, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
const char *fg_instance_name(const fg_instance *inst);
const char *fg_resource_path(const fg_instance *inst);  /* a directory path ending in '/', or NULL */
/* the host's stop time [s] (fmi2SetupExperiment / fmi3EnterInitializationMode), +inf if it gave none */
double fg_stop_time(const fg_instance *inst);

/* ---- implemented by the model ---- */
extern const fg_variable FG_MODEL_VARIABLES[];
extern const size_t FG_MODEL_N_VARIABLES;
extern const size_t FG_MODEL_DATA_SIZE;       /* sizeof the model's data struct */

/* start values; data is zeroed before the call (so padding bytes are deterministic) */
void fg_model_start(fg_instance *inst, void *data);

fg_status fg_model_get_real(fg_instance *inst, const void *data, uint32_t vr, double *value);
fg_status fg_model_set_real(fg_instance *inst, void *data, uint32_t vr, double value);
fg_status fg_model_get_integer(fg_instance *inst, const void *data, uint32_t vr, int32_t *value);
fg_status fg_model_set_integer(fg_instance *inst, void *data, uint32_t vr, int32_t value);
fg_status fg_model_get_boolean(fg_instance *inst, const void *data, uint32_t vr, int *value);
fg_status fg_model_set_boolean(fg_instance *inst, void *data, uint32_t vr, int value);
/* the returned string must live in data (valid until the next call on the instance) */
fg_status fg_model_get_string(fg_instance *inst, const void *data, uint32_t vr, const char **value);
/* value is never NULL; copy it into data (refuse with FG_ERROR if too long) */
fg_status fg_model_set_string(fg_instance *inst, void *data, uint32_t vr, const char *value);

/* end of initialization: check the parameters, compute the initial state and outputs */
fg_status fg_model_exit_initialization(fg_instance *inst, void *data, double start_time);
/* advance from t to t + h (h >= 0); FG_DISCARD with a message for non-finite inputs or a failed
 * integration (the glue then refuses further steps), FG_ERROR for an unrecoverable failure */
fg_status fg_model_do_step(fg_instance *inst, void *data, double t, double h);

#ifdef __cplusplus
}
#endif
#endif

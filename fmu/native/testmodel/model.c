/* testmodel/model.c - a first-order lag x' = (u - x)/tau, for the tests of the FMI glue only.
 *
 *  vr type     kind                 name    start
 *   0 Real     independent          time
 *   1 Real     input                u       0
 *   2 Boolean  input                hold    false  (x is frozen while true)
 *   3 Real     fixed parameter      tau     1      (> 0)
 *   4 Integer  fixed parameter      n_sub   1      (>= 1; sub-steps per communication step)
 *   5 String   fixed parameter      label   "lag"
 *   6 Real     output               y       = x
 *   7 Integer  output               steps   number of completed steps
 *   8 Boolean  output               rising  x < u
 * Each (sub-)step is the exact solution for a constant u: x <- u + (x - u) exp(-h/tau).
 */
#include <math.h>
#include <string.h>

#include "fg_model.h"

#define LABEL_MAX 64

typedef struct {
    double time, u, tau, x;
    int32_t n_sub, steps;
    int hold;
    char label[LABEL_MAX];
} lag_data;

enum { VR_TIME, VR_U, VR_HOLD, VR_TAU, VR_NSUB, VR_LABEL, VR_Y, VR_STEPS, VR_RISING };

const fg_variable FG_MODEL_VARIABLES[] = {
    {VR_TIME, FG_REAL, FG_INDEPENDENT, "time"},
    {VR_U, FG_REAL, FG_INPUT, "u"},
    {VR_HOLD, FG_BOOLEAN, FG_INPUT, "hold"},
    {VR_TAU, FG_REAL, FG_PARAMETER, "tau"},
    {VR_NSUB, FG_INTEGER, FG_PARAMETER, "n_sub"},
    {VR_LABEL, FG_STRING, FG_PARAMETER, "label"},
    {VR_Y, FG_REAL, FG_OUTPUT, "y"},
    {VR_STEPS, FG_INTEGER, FG_OUTPUT, "steps"},
    {VR_RISING, FG_BOOLEAN, FG_OUTPUT, "rising"},
};
const size_t FG_MODEL_N_VARIABLES = sizeof FG_MODEL_VARIABLES / sizeof FG_MODEL_VARIABLES[0];
const size_t FG_MODEL_DATA_SIZE = sizeof(lag_data);

void fg_model_start(fg_instance *inst, void *data)
{
    lag_data *d = (lag_data *)data;
    (void)inst;
    d->tau = 1.0;
    d->n_sub = 1;
    strcpy(d->label, "lag");
}

fg_status fg_model_get_real(fg_instance *inst, const void *data, uint32_t vr, double *value)
{
    const lag_data *d = (const lag_data *)data;
    (void)inst;
    switch (vr) {
    case VR_TIME: *value = d->time; break;
    case VR_U: *value = d->u; break;
    case VR_TAU: *value = d->tau; break;
    default: *value = d->x; break; /* VR_Y */
    }
    return FG_OK;
}

fg_status fg_model_set_real(fg_instance *inst, void *data, uint32_t vr, double value)
{
    lag_data *d = (lag_data *)data;
    (void)inst;
    if (vr == VR_U) d->u = value;
    else d->tau = value;
    return FG_OK;
}

fg_status fg_model_get_integer(fg_instance *inst, const void *data, uint32_t vr, int32_t *value)
{
    const lag_data *d = (const lag_data *)data;
    (void)inst;
    *value = vr == VR_NSUB ? d->n_sub : d->steps;
    return FG_OK;
}

fg_status fg_model_set_integer(fg_instance *inst, void *data, uint32_t vr, int32_t value)
{
    (void)inst;
    (void)vr;
    ((lag_data *)data)->n_sub = value;
    return FG_OK;
}

fg_status fg_model_get_boolean(fg_instance *inst, const void *data, uint32_t vr, int *value)
{
    const lag_data *d = (const lag_data *)data;
    (void)inst;
    *value = vr == VR_HOLD ? d->hold : (d->x < d->u);
    return FG_OK;
}

fg_status fg_model_set_boolean(fg_instance *inst, void *data, uint32_t vr, int value)
{
    (void)inst;
    (void)vr;
    ((lag_data *)data)->hold = value;
    return FG_OK;
}

fg_status fg_model_get_string(fg_instance *inst, const void *data, uint32_t vr, const char **value)
{
    (void)inst;
    (void)vr;
    *value = ((const lag_data *)data)->label;
    return FG_OK;
}

fg_status fg_model_set_string(fg_instance *inst, void *data, uint32_t vr, const char *value)
{
    lag_data *d = (lag_data *)data;
    (void)vr;
    if (strlen(value) >= LABEL_MAX) {
        fg_log(inst, FG_ERROR, NULL, "label is longer than %d characters", LABEL_MAX - 1);
        return FG_ERROR;
    }
    memset(d->label, 0, LABEL_MAX);
    strcpy(d->label, value);
    return FG_OK;
}

fg_status fg_model_exit_initialization(fg_instance *inst, void *data, double start_time)
{
    lag_data *d = (lag_data *)data;
    if (!(d->tau > 0.0) || !isfinite(d->tau)) {
        fg_log(inst, FG_ERROR, NULL, "tau = %g is invalid: must be finite and > 0", d->tau);
        return FG_ERROR;
    }
    if (d->n_sub < 1) {
        fg_log(inst, FG_ERROR, NULL, "n_sub = %ld is invalid: must be >= 1", (long)d->n_sub);
        return FG_ERROR;
    }
    d->time = start_time;
    fg_log(inst, FG_OK, NULL, "initialized '%s' with tau = %g", d->label, d->tau);
    return FG_OK;
}

fg_status fg_model_do_step(fg_instance *inst, void *data, double t, double h)
{
    lag_data *d = (lag_data *)data;
    int32_t i;
    double a;
    if (!isfinite(d->u)) {
        fg_log(inst, FG_DISCARD, NULL, "non-finite input u = %g at t = %g", d->u, t);
        return FG_DISCARD;
    }
    if (!d->hold) {
        a = exp(-(h / d->n_sub) / d->tau);
        for (i = 0; i < d->n_sub; i++) d->x = d->u + (d->x - d->u) * a;
    }
    d->steps += 1;
    d->time = t + h;
    return FG_OK;
}

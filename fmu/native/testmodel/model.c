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
 * The table is tests/test_native_glue.py's TABLE: the value references, the value store and its start
 * values are generated from it (orchestration/packaging/native/tables.py: sm_vars.h / sm_vars.c), the get/set
 * accessors are the shared fmu/native/common/sm_values.c, as for every native model (strings of at
 * most 63 bytes: the store's string size, 64, refuses longer labels when set).  The outputs
 * are computed at the end of initialization and of each step (y, rising: at those points).
 * Each (sub-)step is the exact solution for a constant u: x <- u + (x - u) exp(-h/tau).
 */
#include <math.h>
#include <string.h>

#include "fg_model.h"
#include "sm_vars.h"

typedef struct {
    sm_values v; /* first: the generated value store */
    double x;
} lag_data;

const size_t FG_MODEL_DATA_SIZE = sizeof(lag_data);

static void publish(lag_data *d)
{
    d->v.r[SM_VR_y] = d->x;
    d->v.b[SM_VR_rising] = d->x < d->v.r[SM_VR_u];
}

void fg_model_start(fg_instance *inst, void *data)
{
    (void)inst;
    sm_vars_start(&((lag_data *)data)->v);
}

fg_status fg_model_exit_initialization(fg_instance *inst, void *data, double start_time)
{
    lag_data *d = (lag_data *)data;
    const double tau = d->v.r[SM_VR_tau];
    const int32_t n_sub = d->v.i[SM_VR_n_sub];
    if (!(tau > 0.0) || !isfinite(tau)) {
        fg_log(inst, FG_ERROR, NULL, "tau = %g is invalid: must be finite and > 0", tau);
        return FG_ERROR;
    }
    if (n_sub < 1) {
        fg_log(inst, FG_ERROR, NULL, "n_sub = %ld is invalid: must be >= 1", (long)n_sub);
        return FG_ERROR;
    }
    d->v.r[SM_VR_time] = start_time;
    publish(d);
    fg_log(inst, FG_OK, NULL, "initialized '%s' with tau = %g", d->v.s[SM_SLOT_label], tau);
    return FG_OK;
}

fg_status fg_model_do_step(fg_instance *inst, void *data, double t, double h)
{
    lag_data *d = (lag_data *)data;
    const double u = d->v.r[SM_VR_u];
    const int32_t n_sub = d->v.i[SM_VR_n_sub];
    int32_t i;
    double a;
    if (!isfinite(u)) {
        fg_log(inst, FG_DISCARD, NULL, "non-finite input u = %g at t = %g", u, t);
        return FG_DISCARD;
    }
    if (!d->v.b[SM_VR_hold]) {
        a = exp(-(h / n_sub) / d->v.r[SM_VR_tau]);
        for (i = 0; i < n_sub; i++) d->x = u + (d->x - u) * a;
    }
    d->v.i[SM_VR_steps] += 1;
    d->v.r[SM_VR_time] = t + h;
    publish(d);
    return FG_OK;
}

/* The controller as a native FMU model: ControllerUnit of satmotor/interface.py on the C core
 * (fmu/native/core/sm_controller.c), behind the FMI glue of fmu/native/fmi (fg_model.h).  The value
 * references, start values, the parameter copy into the core's structs and the input/output orders
 * are generated (sm_vars.h / sm_vars.c, orchestration/packaging/native/tables.py); the get/set accessors are
 * fmu/native/common/sm_values.c. */
#include <string.h>

#include "fg_model_clock.h"
#include "sm_common.h"
#include "sm_controller.h"
#include "sm_values.h"
#include "sm_vars.h"

typedef struct {
    sm_values v; /* first: the generated value store */
    sm_controller u;
    int ready;
} controller_data;

const size_t FG_MODEL_DATA_SIZE = sizeof(controller_data);
/* the model's inputs and outputs are the core's, in the same order (one table): checked at compile time */
typedef char sm_inputs_are_the_cores[SM_N_INPUTS == SM_CONTROLLER_N_IN ? 1 : -1];
typedef char sm_outputs_are_the_cores[SM_N_OUTPUTS == SM_CONTROLLER_N_OUT ? 1 : -1];

void fg_model_start(fg_instance *inst, void *data)
{
    (void)inst;
    sm_vars_start(&((controller_data *)data)->v);
}

fg_status fg_model_exit_initialization(fg_instance *inst, void *data, double start_time)
{
    controller_data *d = (controller_data *)data;
    sm_controller_params params;
    sm_motor_params motor;
    char msg[SM_MSG_LEN];
    d->v.r[SM_VR_time] = start_time;
    sm_vars_controller_params(&d->v, &params);
    sm_vars_motor_params(&d->v, &motor);
    if (sm_resolve_file(inst, "table_file", motor.table_file, sizeof motor.table_file) != FG_OK) {
        return FG_ERROR;
    }
    if (sm_controller_init(&d->u, &params, &motor, msg, sizeof msg) != 0) {
        fg_log(inst, FG_ERROR, "logStatusError", "%s", msg);
        return FG_ERROR;
    }
    d->ready = 1;
    return FG_OK;
}

/* the clocked variant (fmi3_se_glue.c): one sample per activation of its clock, whose interval is Ts */
double fg_model_clock_period(const void *data) { return ((const controller_data *)data)->u.Ts; }

fg_status fg_model_do_step(fg_instance *inst, void *data, double t, double h)
{
    controller_data *d = (controller_data *)data;
    double in[SM_CONTROLLER_N_IN];
    char msg[SM_MSG_LEN];
    if (!d->ready) {
        fg_log(inst, FG_ERROR, "logStatusError", "doStep before initialization");
        return FG_ERROR;
    }
    sm_vars_get_inputs(&d->v, in);
    /* this instance's stop time, also after a state set from another (a remainder ending there: no sample) */
    d->u.stop_time = fg_stop_time(inst);
    if (sm_controller_step(&d->u, t, h, in, msg, sizeof msg) != 0) {
        fg_log(inst, FG_DISCARD, "logStatusDiscard", "BacksteppingController at t = %.17g s: %s", t, msg);
        return FG_DISCARD;
    }
    sm_vars_put_outputs(&d->v, d->u.out);
    d->v.r[SM_VR_time] = t + h;
    if (d->u.has_warning) { /* the drive's warning, once per run (the pythonfmu FMU logs the same text) */
        d->u.has_warning = 0;
        fg_log(inst, FG_WARNING, "logStatusWarning", "BacksteppingController: %s", d->u.warning);
    }
    return FG_OK;
}

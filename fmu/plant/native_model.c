/* The plant as a native FMU model: PlantUnit of satmotor/interface.py on the C core
 * (fmu/native/core/sm_plant_unit.c), behind the FMI glue of fmu/native/fmi (fg_model.h).  The value
 * references, start values, the parameter copy into the core's structs and the input/output orders
 * are generated (sm_vars.h / sm_vars.c, orchestration/packaging/native/tables.py); the get/set accessors are
 * fmu/native/common/sm_values.c. */
#include "sm_common.h"
#include "sm_plant_unit.h"
#include "sm_values.h"
#include "sm_vars.h"

typedef struct {
    sm_values v; /* first: the generated value store */
    sm_plant_unit u;
    int ready;
} plant_data;

const size_t FG_MODEL_DATA_SIZE = sizeof(plant_data);
/* the model's inputs and outputs are the core's, in the same order (one table): checked at compile time */
typedef char sm_inputs_are_the_cores[SM_N_INPUTS == SM_PLANT_N_IN ? 1 : -1];
typedef char sm_outputs_are_the_cores[SM_N_OUTPUTS == SM_PLANT_N_OUT ? 1 : -1];

/* the unit's warnings (plausibility, over-voltage) into the host's log, in their order */
static void log_warnings(fg_instance *inst, sm_plant_unit *u)
{
    int k;
    for (k = 0; k < u->n_warnings; ++k) {
        fg_log(inst, FG_WARNING, "logStatusWarning", "%s", u->warnings[k]);
    }
    u->n_warnings = 0;
}

void fg_model_start(fg_instance *inst, void *data)
{
    (void)inst;
    sm_vars_start(&((plant_data *)data)->v);
}

fg_status fg_model_exit_initialization(fg_instance *inst, void *data, double start_time)
{
    plant_data *d = (plant_data *)data;
    sm_motor_params motor;
    sm_plant_params plant;
    sm_dclink_params link;
    char msg[SM_MSG_LEN];
    d->v.r[SM_VR_time] = start_time;
    sm_vars_motor_params(&d->v, &motor);
    sm_vars_plant_params(&d->v, &plant);
    sm_vars_dclink_params(&d->v, &link);
    if (sm_resolve_file(inst, "table_file", motor.table_file, sizeof motor.table_file) != FG_OK) {
        return FG_ERROR;
    }
    if (sm_plant_unit_init(&d->u, &motor, &plant, &link, msg, sizeof msg) != 0) {
        fg_log(inst, FG_ERROR, "logStatusError", "%s", msg);
        return FG_ERROR;
    }
    sm_vars_put_outputs(&d->v, d->u.out);
    d->ready = 1;
    return FG_OK;
}

fg_status fg_model_do_step(fg_instance *inst, void *data, double t, double h)
{
    plant_data *d = (plant_data *)data;
    double in[SM_PLANT_N_IN];
    char msg[SM_MSG_LEN];
    int st;
    if (!d->ready) {
        fg_log(inst, FG_ERROR, "logStatusError", "doStep before initialization");
        return FG_ERROR;
    }
    sm_vars_get_inputs(&d->v, in);
    st = sm_plant_unit_step(&d->u, t, h, in, msg, sizeof msg);
    log_warnings(inst, &d->u); /* also of a failed step (the |v_s| warning is given before it) */
    if (st != 0) {
        fg_log(inst, FG_DISCARD, "logStatusDiscard", "SaturatedInductionMotor at t = %.17g s: %s", t, msg);
        return FG_DISCARD;
    }
    sm_vars_put_outputs(&d->v, d->u.out);
    d->v.r[SM_VR_time] = t + h;
    return FG_OK;
}

/* The plant as a native FMU model: PlantUnit of satmotor/interface.py on the C core
 * (fmu/native/core/sm_plant.c), behind the FMI glue of fmu/native/fmi (fg_model.h).  The value
 * references, start values and the parameter copy into the core's structs are generated (sm_vars.h /
 * sm_vars.c, orchestration/build/native/tables.py); the get/set accessors are fmu/native/common/sm_values.c. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "sm_common.h"
#include "sm_dclink.h"
#include "sm_inverter.h"
#include "sm_plant.h"
#include "sm_values.h"
#include "sm_vars.h"

typedef struct {
    sm_values v; /* first: the generated value store */
    sm_motor p;
    sm_dclink link;                  /* the DC link (satmotor/machine/dc_link.py) */
    /* the motor's six states, then the thermal ones (p.n_states of them in all), then (capacitor) v_dc,
     * E_regen, E_chop at sm_dclink_iv(&p) */
    double x[SM_N_LINK_STATES_MAX];
    int chop, fault;                 /* the chopper's state, the latched over-voltage fault */
    sm_solve_memo memo; /* the outputs' solve at x, reused by the next step's first stage */
    sm_inverter inv; /* the stator voltage source (average-value or pwm, with its switching state) */
    double v_avg[2]; /* [V] the voltage held over the last step, pwm: its step average (outputs v_avg_*) */
    int ready;
    int warned[3]; /* a plausibility warning of |v_s|, |i_s|, |omega_m| was logged in this run */
} plant_data;

const size_t FG_MODEL_DATA_SIZE = sizeof(plant_data);

/* the plausibility warnings (as PlantUnit.step, satmotor/interface.py): quantity k above its bound
 * v_warn / i_warn / omega_warn (> 0) is logged once per run at warning level; nothing else changes */
static const char *const WARN_NAME[3] = {"v_warn", "i_warn", "omega_warn"};
static const char *const WARN_WHAT[3][3] = {
    {"|v_s|", "V", "input"}, {"|i_s|", "A", "output"}, {"|omega_m|", "rad/s", "output"}};

static double warn_bound(const plant_data *d, int k)
{
    return d->v.r[k == 0 ? SM_VR_v_warn : k == 1 ? SM_VR_i_warn : SM_VR_omega_warn];
}

/* quantity k: |v_s| of the inputs, |i_s| or |omega_m| of the outputs */
static void plausible(fg_instance *inst, plant_data *d, int k, double t)
{
    char a[40], b[40], c[40];
    const double *r = d->v.r;
    double bound = warn_bound(d, k), x, y, value;
    if (d->warned[k] || !(bound > 0.0)) return;
    if (k == 2) {
        value = fabs(r[SM_VR_omega_m]);
        if (!(value > bound)) return;
    } else { /* the squares first (cheap, as PlantUnit), the magnitude only for the message */
        x = r[k == 0 ? SM_VR_v_s_alpha : SM_VR_i_s_alpha];
        y = r[k == 0 ? SM_VR_v_s_beta : SM_VR_i_s_beta];
        if (!(x * x + y * y > bound * bound)) return;
        value = sm_hypot(x, y);
    }
    d->warned[k] = 1;
    fg_log(inst, FG_WARNING, "logStatusWarning", "SaturatedInductionMotor: implausible %s at t = %s s: %s = %s %s "
           "exceeds %s = %s %s; the step is computed as given (logged once per run)", WARN_WHAT[k][2],
           sm_repr_double(t, a, sizeof a), WARN_WHAT[k][0], sm_repr_double(value, b, sizeof b), WARN_WHAT[k][1],
           WARN_NAME[k], sm_repr_double(bound, c, sizeof c), WARN_WHAT[k][1]);
}

/* the outputs at x; v_a, v_b [V]: the stator voltage held over the step just ended (zero at
 * initialization), which the terminal current and P_fe need with R_fe > 0 (as PlantUnit.outputs) */
static void publish(plant_data *d, double v_a, double v_b)
{
    sm_plant_outputs o;
    double *r = d->v.r;
    if (sm_plant_outputs_memo(&d->p, &d->memo, d->x, v_a, v_b, &o) != 0) {
        o.i_s_alpha = o.i_s_beta = o.T_e = o.i_mu = o.P_fe = o.T_s = o.T_r = NAN;
    }
    r[SM_VR_i_s_alpha] = o.i_s_alpha;
    r[SM_VR_i_s_beta] = o.i_s_beta;
    r[SM_VR_psi_s_alpha] = d->x[SM_PSI_S_A];
    r[SM_VR_psi_s_beta] = d->x[SM_PSI_S_B];
    r[SM_VR_psi_r_alpha] = d->x[SM_PSI_R_A];
    r[SM_VR_psi_r_beta] = d->x[SM_PSI_R_B];
    r[SM_VR_omega_m] = d->x[SM_OMEGA_M];
    r[SM_VR_theta_m] = d->x[SM_THETA_M];
    r[SM_VR_T_e] = o.T_e;
    r[SM_VR_i_mu] = o.i_mu;
    if (d->link.capacitor) {
        int iv = sm_dclink_iv(&d->p);
        r[SM_VR_v_dc] = d->x[iv];
        r[SM_VR_E_regen] = d->x[iv + 1];
        r[SM_VR_E_chop] = d->x[iv + 2];
    } else {
        r[SM_VR_v_dc] = d->link.V_dc;
        r[SM_VR_E_regen] = 0.0;
        r[SM_VR_E_chop] = 0.0;
    }
    r[SM_VR_dc_fault] = d->fault ? 1.0 : 0.0;
    r[SM_VR_P_fe] = o.P_fe;
    r[SM_VR_T_s] = o.T_s;
    r[SM_VR_T_r] = o.T_r;
    r[SM_VR_v_avg_alpha] = d->v_avg[0];
    r[SM_VR_v_avg_beta] = d->v_avg[1];
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
    int st;
    d->v.r[SM_VR_time] = start_time;
    sm_vars_motor_params(&d->v, &motor);
    sm_vars_plant_params(&d->v, &plant);
    sm_vars_dclink_params(&d->v, &link);
    if (sm_resolve_file(inst, "table_file", motor.table_file, sizeof motor.table_file) != FG_OK) {
        return FG_ERROR;
    }
    if (sm_require_integer("max_substeps", d->v.i[SM_VR_max_substeps], 1, msg, sizeof msg) != 0) {
        fg_log(inst, FG_ERROR, "logStatusError", "%s", msg);
        return FG_ERROR;
    }
    for (st = 0; st < 3; ++st) {
        if (sm_require_number(WARN_NAME[st], warn_bound(d, st), 1, 0.0, 1, msg, sizeof msg) != 0) {
            fg_log(inst, FG_ERROR, "logStatusError", "%s", msg);
            return FG_ERROR;
        }
    }
    st = sm_motor_init(&d->p, &motor, &plant, msg, sizeof msg);
    if (st != 0) {
        fg_log(inst, FG_ERROR, "logStatusError", "%s", msg);
        return FG_ERROR;
    }
    st = sm_dclink_init(&d->link, &link, msg, sizeof msg);
    if (st != 0) {
        fg_log(inst, FG_ERROR, "logStatusError", "%s", msg);
        return FG_ERROR;
    }
    /* the inverter switches the link's V_dc (one parameter; a capacitor link: its voltage, a state) */
    st = sm_inverter_init(&d->inv, &plant, d->link.V_dc, msg, sizeof msg);
    if (st != 0) {
        fg_log(inst, FG_ERROR, "logStatusError", "%s", msg);
        return FG_ERROR;
    }
    d->v_avg[0] = d->v_avg[1] = 0.0;
    for (st = 0; st < SM_N_STATES_MAX; ++st) {
        d->x[st] = d->p.x0[st];
    }
    if (d->link.capacitor) { /* DCLink.initial_state: after the motor's states (with the thermal ones) */
        int iv = sm_dclink_iv(&d->p);
        d->x[iv] = d->link.V_dc;
        d->x[iv + 1] = 0.0;
        d->x[iv + 2] = 0.0;
    }
    d->chop = 0;
    d->fault = 0;
    d->ready = 1;
    sm_solve_memo_clear(&d->memo);
    publish(d, 0.0, 0.0);
    return FG_OK;
}

fg_status fg_model_do_step(fg_instance *inst, void *data, double t, double h)
{
    plant_data *d = (plant_data *)data;
    const double *r = d->v.r;
    double x[SM_N_LINK_STATES_MAX], v_avg[2], v_held[2], t_fault = NAN;
    char msg[SM_MSG_LEN];
    int n_sub = 1, st, j, chop = d->chop, fault = d->fault;
    if (!d->ready) {
        fg_log(inst, FG_ERROR, "logStatusError", "doStep before initialization");
        return FG_ERROR;
    }
    st = sm_plant_check_step(&d->p, r[SM_VR_v_s_alpha], r[SM_VR_v_s_beta], r[SM_VR_T_load], h, &n_sub, msg,
                             sizeof msg);
    if (st == 0 && n_sub > d->v.i[SM_VR_max_substeps]) { /* bounded work per call: as PlantUnit.step */
        char v[40], hi[40];
        snprintf(msg, sizeof msg, "communicationStepSize = %s: needs %d RK4 sub-steps of h_int = %s s, more than "
                 "max_substeps = %ld: take shorter communication steps or raise max_substeps",
                 sm_repr_double(h, v, sizeof v), n_sub, sm_repr_double(d->p.h_int, hi, sizeof hi),
                 (long)d->v.i[SM_VR_max_substeps]);
        st = 1;
    }
    if (st == 0 && d->inv.pwm) { /* the switching intervals too (as PlantUnit.step) */
        double n_pwm = (double)n_sub + sm_inverter_intervals_bound(&d->inv, h);
        if (n_pwm > (double)d->v.i[SM_VR_max_substeps]) {
            char v[40], f[40];
            snprintf(msg, sizeof msg, "communicationStepSize = %s: needs up to %.0f RK4 sub-steps with the pwm "
                     "inverter (f_sw = %s Hz), more than max_substeps = %ld: take shorter communication steps "
                     "or raise max_substeps", sm_repr_double(h, v, sizeof v), n_pwm,
                     sm_repr_double(d->inv.f_sw, f, sizeof f), (long)d->v.i[SM_VR_max_substeps]);
            st = 1;
        }
    }
    if (st != 0) {
        fg_log(inst, FG_DISCARD, "logStatusDiscard", "SaturatedInductionMotor at t = %.17g s: %s", t, msg);
        return FG_DISCARD;
    }
    plausible(inst, d, 0, t);
    for (j = 0; j < (int)(sizeof x / sizeof x[0]); ++j) {
        x[j] = d->x[j];
    }
    if (d->inv.pwm && d->link.capacitor) { /* the switched stage on the link (satmotor/machine/pwm_link.py) */
        st = sm_inverter_step_link(&d->inv, &d->p, &d->link, &d->memo, x, t, h, r[SM_VR_v_s_alpha],
                                   r[SM_VR_v_s_beta], r[SM_VR_T_load], v_avg, &chop, &fault, &t_fault, NULL, 0,
                                   NULL);
    } else if (d->inv.pwm) { /* the switched voltages to the switching instants; d->inv changes only on success */
        st = sm_inverter_step_memo(&d->inv, &d->p, &d->memo, x, t, h, r[SM_VR_v_s_alpha], r[SM_VR_v_s_beta],
                                   r[SM_VR_T_load], v_avg, NULL, 0, NULL);
    } else if (d->link.capacitor) { /* (the memo is for the motor's step alone: publish refills it) */
        st = sm_dclink_step(&d->p, &d->link, t, x, r[SM_VR_v_s_alpha], r[SM_VR_v_s_beta], r[SM_VR_T_load], h,
                            n_sub, &chop, &fault, &t_fault);
    } else {
        st = sm_plant_step_memo(&d->p, &d->memo, x, r[SM_VR_v_s_alpha], r[SM_VR_v_s_beta], r[SM_VR_T_load], h,
                                n_sub);
    }
    if (!d->inv.pwm) {
        v_avg[0] = r[SM_VR_v_s_alpha];
        v_avg[1] = r[SM_VR_v_s_beta];
    }
    if (st != 0) {
        double y[SM_N_STATES];
        for (j = 0; j < SM_N_STATES; ++j) {
            y[j] = NAN;
        }
        sm_plant_nonfinite_message(t, h, y, msg, sizeof msg);
        fg_log(inst, FG_DISCARD, "logStatusDiscard", "SaturatedInductionMotor at t = %.17g s: %s", t, msg);
        return FG_DISCARD;
    }
    for (j = 0; j < (int)(sizeof x / sizeof x[0]); ++j) {
        d->x[j] = x[j];
    }
    d->chop = chop;
    d->fault = fault;
    if (!isnan(t_fault)) { /* set in this step: once per run (the fault is latched) */
        sm_dclink_over_voltage_message(t_fault, x[sm_dclink_iv(&d->p)], d->link.V_dc_max, msg, sizeof msg);
        fg_log(inst, FG_WARNING, "logStatusWarning", "%s", msg);
    }
    d->v_avg[0] = v_avg[0];
    d->v_avg[1] = v_avg[1];
    d->v.r[SM_VR_time] = t + h;
    v_held[0] = v_avg[0];
    v_held[1] = v_avg[1];
    if (d->link.capacitor && !d->inv.pwm) /* PlantUnit._held: the command as the link bounds it at the end */
        sm_dclink_applied(v_avg[0], v_avg[1], x[sm_dclink_iv(&d->p)], &v_held[0], &v_held[1]);
    publish(d, v_held[0], v_held[1]);
    plausible(inst, d, 1, t + h);
    plausible(inst, d, 2, t + h);
    return FG_OK;
}

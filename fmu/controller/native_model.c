/* The controller as a native FMU model: ControllerUnit of satmotor/interface.py on the C core
 * (fmu/native/core/sm_controller.c), behind the FMI glue of fmu/native/fmi (sm_model.h). */
#include <stdio.h>
#include <string.h>

#include "sm_common.h"
#include "sm_controller.h"
#include "sm_vars.h"

#include "sm_values_access.h"

typedef struct {
    sm_values v; /* first: the generated value store */
    sm_controller u;
    int ready;
} controller_data;

const size_t SM_MODEL_DATA_SIZE = sizeof(controller_data);

/* the outputs in the order of CONTROLLER_OUTPUTS (sm_controller.out) */
static const int OUT_VR[SM_CTRL_N_OUT] = {
    SM_VR_v_s_alpha, SM_VR_v_s_beta, SM_VR_v_sd, SM_VR_v_sq, SM_VR_e1, SM_VR_e2, SM_VR_z1, SM_VR_z2, SM_VR_W,
    SM_VR_T_load_est, SM_VR_psi_r_hat_alpha, SM_VR_psi_r_hat_beta, SM_VR_omega_ref_shaped, SM_VR_psi_ref_shaped,
    SM_VR_phase, SM_VR_voltage_limited, SM_VR_current_limited, SM_VR_singular_limited};
static const int IN_VR[SM_CTRL_N_IN] = {SM_VR_i_s_alpha, SM_VR_i_s_beta, SM_VR_psi_r_alpha, SM_VR_psi_r_beta,
                                        SM_VR_psi_s_alpha, SM_VR_psi_s_beta, SM_VR_omega_m, SM_VR_omega_ref,
                                        SM_VR_psi_ref, SM_VR_T_load};

void sm_model_start(sm_instance *inst, void *data)
{
    (void)inst;
    sm_vars_start(&((controller_data *)data)->v);
}

static void copy_str(char *dst, const char *src)
{
    size_t n = strlen(src);
    if (n >= SM_STR_MAX) {
        n = SM_STR_MAX - 1; /* the model's strings are shorter (sm_model_set_string); a table path in
                               the resources may not be: sm_model_exit_initialization refuses it */
    }
    memcpy(dst, src, n);
    dst[n] = '\0';
}

sm_status sm_model_exit_initialization(sm_instance *inst, void *data, double start_time)
{
    controller_data *d = (controller_data *)data;
    const double *r = d->v.r;
    sm_controller_params params, *p = &params;
    char msg[SM_MSG_LEN], table[SM_VAR_STRING_MAX + 512];
    int st;
    memset(p, 0, sizeof *p);
    d->v.r[SM_VR_time] = start_time;
    p->c1 = r[SM_VR_c1];
    p->c2 = r[SM_VR_c2];
    p->d1 = r[SM_VR_d1];
    p->d2 = r[SM_VR_d2];
    p->c0 = r[SM_VR_c0];
    p->d0 = r[SM_VR_d0];
    p->Ts = r[SM_VR_Ts];
    p->V_dc = r[SM_VR_V_dc];
    p->ref_bandwidth = r[SM_VR_ref_bandwidth];
    p->g_theta = r[SM_VR_g_theta];
    p->theta_max = r[SM_VR_theta_max];
    p->I_max = r[SM_VR_I_max];
    p->delay_samples = d->v.i[SM_VR_delay_samples];
    p->use_stator_flux = d->v.b[SM_VR_use_stator_flux];
    copy_str(p->mode, d->v.s[SM_SLOT_mode]);
    copy_str(p->load_mode, d->v.s[SM_SLOT_load_mode]);
    copy_str(p->flux_source, d->v.s[SM_SLOT_flux_source]);
    p->R_s = r[SM_VR_R_s];
    p->R_r = r[SM_VR_R_r];
    p->l_s = r[SM_VR_l_s];
    p->l_r = r[SM_VR_l_r];
    p->k = r[SM_VR_k];
    p->J = r[SM_VR_J];
    p->B = r[SM_VR_B];
    p->L_m0 = r[SM_VR_L_m0];
    p->L_m_inf = r[SM_VR_L_m_inf];
    p->I_par = r[SM_VR_I_par];
    p->poly_b = r[SM_VR_poly_b];
    p->n_p = d->v.i[SM_VR_n_p];
    p->poly_n = d->v.i[SM_VR_poly_n];
    copy_str(p->curve, d->v.s[SM_SLOT_curve]);
    sm_resolve_file(inst, d->v.s[SM_SLOT_table_file], table, sizeof table);
    if (strlen(table) >= SM_STR_MAX) {
        sm_log(inst, SM_ERROR, "logStatusError", "table_file: the path %s is longer than %d bytes", table,
               SM_STR_MAX - 1);
        return SM_ERROR;
    }
    copy_str(p->table_file, table);
    st = sm_controller_init(&d->u, p, msg, sizeof msg);
    if (st != 0) {
        sm_log(inst, SM_ERROR, "logStatusError", "%s", msg);
        return SM_ERROR;
    }
    d->ready = 1;
    return SM_OK;
}

sm_status sm_model_do_step(sm_instance *inst, void *data, double t, double h)
{
    controller_data *d = (controller_data *)data;
    double in[SM_CTRL_N_IN];
    char msg[SM_MSG_LEN];
    int j, st;
    if (!d->ready) {
        sm_log(inst, SM_ERROR, "logStatusError", "doStep before initialization");
        return SM_ERROR;
    }
    for (j = 0; j < SM_CTRL_N_IN; ++j) {
        in[j] = d->v.r[IN_VR[j]];
    }
    st = sm_controller_step(&d->u, t, h, in, msg, sizeof msg);
    if (st != 0) {
        sm_log(inst, SM_DISCARD, "logStatusDiscard", "BacksteppingController at t = %.17g s: %s", t, msg);
        return SM_DISCARD;
    }
    for (j = 0; j < SM_CTRL_N_OUT; ++j) {
        const double value = d->u.out[j];
        const int vr = OUT_VR[j];
        if (SM_MODEL_VARIABLES[vr].type == SM_INTEGER) {
            d->v.i[vr] = (int32_t)value;
        } else if (SM_MODEL_VARIABLES[vr].type == SM_BOOLEAN) {
            d->v.b[vr] = value != 0.0;
        } else {
            d->v.r[vr] = value;
        }
    }
    d->v.r[SM_VR_time] = t + h;
    return SM_OK;
}

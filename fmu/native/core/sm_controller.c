/* ControllerUnit of satmotor/interface.py in C (see sm_controller.h). */
#include "sm_controller.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "sm_common.h"

static const char *const INPUT_NAMES[SM_CTRL_N_IN] = {"i_s_alpha", "i_s_beta", "psi_r_alpha", "psi_r_beta",
                                                      "psi_s_alpha", "psi_s_beta", "omega_m", "omega_ref",
                                                      "psi_ref", "T_load"};

size_t sm_controller_size(void)
{
    return sizeof(sm_controller);
}

size_t sm_controller_params_size(void)
{
    return sizeof(sm_controller_params);
}

static void copy(char *dst, const char *src)
{
    (void)snprintf(dst, SM_STR_MAX, "%s", src);
}

void sm_controller_params_default(sm_controller_params *v)
{
    memset(v, 0, sizeof *v);
    v->c1 = 200.0;
    v->c2 = 1000.0;
    v->d1 = 100.0;
    v->d2 = 500.0;
    v->c0 = 0.0;
    v->d0 = 0.0;
    v->Ts = 1e-4;
    copy(v->mode, "saturated");
    copy(v->load_mode, "known");
    v->V_dc = 540.0;
    v->ref_bandwidth = 40.0;
    v->g_theta = 5.0;
    v->theta_max = 1.0e4;
    v->I_max = 30.0;
    copy(v->flux_source, "measured");
    v->delay_samples = 0;
    v->use_stator_flux = 0;
    v->R_s = 1.405;
    v->R_r = 1.395;
    v->l_s = 5.839e-3;
    v->l_r = 5.839e-3;
    v->k = 1.0;
    v->n_p = 2;
    v->J = 0.0131;
    v->B = 2.985e-3;
    copy(v->curve, "arctan");
    v->L_m0 = 0.2772;
    v->L_m_inf = 0.01;
    v->I_par = 3.31;
    v->poly_b = 2.46;
    v->poly_n = 7;
    copy(v->table_file, "");
}

static int str_error(char *msg, size_t len, const char *field, const char *value, const char *reason)
{
    char repr[SM_STR_MAX + 8];
    return sm_param_error(msg, len, NULL, field, sm_repr_str(value, repr, sizeof repr), reason);
}

int sm_controller_init(sm_controller *u, const sm_controller_params *v, char *msg, size_t msg_len)
{
    sm_motor p;
    sm_gains g;
    sm_law_config cfg;
    sm_ifoc_gains ig;
    sm_drive_config dc;
    sm_mode mode;
    int st, j;
    const double reals[] = {v->c1, v->c2, v->d1, v->d2, v->c0, v->d0, v->Ts, v->V_dc, v->ref_bandwidth,
                            v->g_theta, v->theta_max, v->I_max};
    const char *const real_names[] = {"c1", "c2", "d1", "d2", "c0", "d0", "Ts", "V_dc", "ref_bandwidth",
                                      "g_theta", "theta_max", "I_max"};
    if (u == NULL || v == NULL) {
        return SM_ERR_ARG;
    }
    memset(u, 0, sizeof *u);
    /* motor_params(values): the motor parameters and their curve (PlantUnit-style checks) */
    if ((st = sm_motor_init(&p, v->R_s, v->R_r, v->l_s, v->l_r, v->k, v->n_p, v->J, v->B, v->curve, v->L_m0,
                            v->L_m_inf, v->I_par, v->poly_b, v->poly_n, v->table_file, 0.0, 0.0, 1e-4, 0.0, msg,
                            msg_len))) {
        return st;
    }
    for (j = 0; j < (int)(sizeof reals / sizeof reals[0]); ++j) { /* interface._number: finite */
        if ((st = sm_require_number(real_names[j], reals[j], 0, 0.0, 0, msg, msg_len))) {
            return st;
        }
    }
    if (strcmp(v->mode, "saturated") == 0) {
        mode = SM_MODE_SATURATED;
    } else if (strcmp(v->mode, "constant_m") == 0) {
        mode = SM_MODE_CONSTANT_M;
    } else if (strcmp(v->mode, "pi") == 0) {
        mode = SM_MODE_PI;
    } else {
        return str_error(msg, msg_len, "mode", v->mode, "must be one of saturated, constant_m, pi");
    }
    sm_drive_config_default(&dc);
    if (strcmp(v->flux_source, "observer") == 0) {
        dc.observer = 1;
    } else if (strcmp(v->flux_source, "measured") != 0) {
        return str_error(msg, msg_len, "flux_source", v->flux_source, "must be one of measured, observer");
    }
    if (dc.observer && v->use_stator_flux) {
        return sm_param_error(msg, msg_len, NULL, "use_stator_flux", "True",
                              "needs measured fluxes: not with flux_source = observer");
    }
    if (v->delay_samples != 0 && v->delay_samples != 1) {
        char repr[24];
        (void)snprintf(repr, sizeof repr, "%d", v->delay_samples);
        return sm_param_error(msg, msg_len, NULL, "delay_samples", repr, "must be 0 or 1");
    }
    dc.ref_bandwidth = v->ref_bandwidth;
    dc.I_max = v->I_max;
    dc.delay_samples = v->delay_samples;
    sm_gains_default(&g);
    g.c1 = v->c1;
    g.c2 = v->c2;
    g.d1 = v->d1;
    g.d2 = v->d2;
    g.c0 = v->c0;
    g.d0 = v->d0;
    sm_law_config_default(&cfg);
    cfg.V_dc = v->V_dc;
    cfg.Ts = v->Ts;
    if (strcmp(v->load_mode, "estimated") == 0) {
        cfg.load_estimated = 1;
    } else if (strcmp(v->load_mode, "known") != 0) {
        if (mode != SM_MODE_PI) {
            return str_error(msg, msg_len, "load_mode", v->load_mode, "must be one of ('known', 'estimated')");
        }
    }
    cfg.g_theta = v->g_theta;
    cfg.theta_max = v->theta_max;
    cfg.use_stator_flux = v->use_stator_flux ? 1 : 0;
    ig.w_c = 2000.0;
    ig.w_speed = 200.0;
    ig.I_max = v->I_max;
    ig.V_dc = v->V_dc;
    if ((st = sm_drive_init(&u->drive, mode, &p, &g, &cfg, &ig, &dc, msg, msg_len))) {
        return st;
    }
    u->Ts = v->Ts;
    for (j = 0; j < SM_CTRL_N_OUT; ++j) {
        u->out[j] = 0.0;
    }
    return SM_CORE_OK;
}

int sm_controller_step(sm_controller *u, double t, double dt, const double in[SM_CTRL_N_IN], char *msg,
                       size_t msg_len)
{
    double meas[7], sum = 0.0;
    sm_drive_output d;
    int st, j;
    (void)t;
    if (!(fabs(dt - u->Ts) <= 1e-9 * u->Ts)) {
        char reason[96], repr[32], drepr[32];
        (void)snprintf(reason, sizeof reason, "must equal the sample period Ts = %s s",
                       sm_repr_double(u->Ts, repr, sizeof repr));
        return sm_param_error(msg, msg_len, NULL, "communicationStepSize", sm_repr_double(dt, drepr, sizeof drepr),
                              reason);
    }
    for (j = 0; j < SM_CTRL_N_IN; ++j) {
        sum += in[j];
    }
    if (!isfinite(sum)) {
        for (j = 0; j < SM_CTRL_N_IN; ++j) {
            if ((st = sm_require_number(INPUT_NAMES[j], in[j], 0, 0.0, 0, msg, msg_len))) {
                return st;
            }
        }
    }
    meas[0] = in[0];
    meas[1] = in[1];
    meas[2] = in[2];
    meas[3] = in[3];
    meas[4] = in[6];
    meas[5] = in[4];
    meas[6] = in[5];
    if ((st = sm_drive_step(&u->drive, meas, in[7], in[8], in[9], &d, msg, msg_len))) {
        return st;
    }
    u->out[0] = d.v_s_alpha;
    u->out[1] = d.v_s_beta;
    u->out[2] = d.v_sd;
    u->out[3] = d.v_sq;
    u->out[4] = d.e1;
    u->out[5] = d.e2;
    u->out[6] = d.z1;
    u->out[7] = d.z2;
    u->out[8] = d.W;
    u->out[9] = d.T_load_est;
    u->out[10] = d.psi_r_hat_alpha;
    u->out[11] = d.psi_r_hat_beta;
    u->out[12] = d.omega_ref;
    u->out[13] = d.psi_ref;
    u->out[14] = (double)d.phase;
    u->out[15] = (double)d.voltage_limited;
    u->out[16] = (double)d.current_limited;
    u->out[17] = (double)d.singular_limited;
    return SM_CORE_OK;
}

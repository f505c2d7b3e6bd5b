/* satmotor/control/delay.py in C: the same operations in the same order (see sm_delay.h). */
#include "sm_delay.h"

#include <stdio.h>

#include "sm_common.h"
#include "sm_law.h"

int sm_delay_init(sm_delay *d, double Ts, double bias_gain, int n_samples, char *msg, size_t msg_len)
{
    if (d == NULL) {
        return SM_ERR_ARG;
    }
    if (sm_require_number("Ts", Ts, 1, 0.0, 0, msg, msg_len) != SM_CORE_OK) {
        return SM_ERR_PARAM;
    }
    if (!(bias_gain >= 0.0 && bias_gain <= 1.0)) {
        char repr[32];
        return sm_param_error(msg, msg_len, NULL, "bias_gain", sm_repr_double(bias_gain, repr, sizeof repr),
                              "must be a finite number >= 0 and <= 1");
    }
    if (n_samples < 1 || n_samples > SM_DELAY_MAX) {
        char repr[24];
        (void)snprintf(repr, sizeof repr, "%d", n_samples);
        return sm_param_error(msg, msg_len, NULL, "n_samples", repr, "must be an integer >= 1");
    }
    d->Ts = Ts;
    d->bias_gain = bias_gain;
    d->n = n_samples;
    sm_delay_reset(d);
    return SM_CORE_OK;
}

void sm_delay_reset(sm_delay *d)
{
    int j;
    for (j = 0; j < 2 * SM_DELAY_MAX; ++j) {
        d->queue[j] = 0.0;
    }
    d->applied_now[0] = d->applied_now[1] = 0.0;
    d->has_pred = 0;
    for (j = 0; j < 5; ++j) {
        d->pred[j] = 0.0;
        d->corr[j] = 0.0;
    }
}

void sm_delay_push(sm_delay *d, double v_alpha, double v_beta, int hold, double *va, double *vb)
{
    int j, last = 2 * (d->n - 1);
    double last_a = d->queue[last], last_b = d->queue[last + 1];
    d->applied_now[0] = d->queue[0];
    d->applied_now[1] = d->queue[1];
    for (j = 0; j < last; ++j) {
        d->queue[j] = d->queue[j + 2];
    }
    d->queue[last] = v_alpha;
    d->queue[last + 1] = v_beta;
    *va = hold ? last_a : v_alpha;
    *vb = hold ? last_b : v_beta;
}

/* DelayCompensator._step: one corrected sample ahead of meas under (va, vb); pred the raw prediction in its
 * flux frame */
static int one_step(const sm_delay *d, const sm_motor *p, const double meas[SM_MEAS_LEN], double va, double vb,
                    double T_load, double pred[5], double out[SM_MEAS_LEN])
{
    double i_a = meas[SM_MEAS_I_S_A], i_b = meas[SM_MEAS_I_S_B], pr_a = meas[SM_MEAS_PSI_R_A];
    double pr_b = meas[SM_MEAS_PSI_R_B], w = meas[SM_MEAS_OMEGA_M];
    double phi = sm_hypot(pr_a, pr_b), c = 1.0, s = 0.0, c1, s1, qa, qb, phi1, x[6], v[5];
    sm_magnetizing ms;
    sm_plant_outputs o;
    int j, st;
    if (phi > 0.0) {
        c = pr_a / phi;
        s = pr_b / phi;
    }
    if ((st = sm_from_rotor_flux(i_a, i_b, pr_a, pr_b, p, &ms)) != SM_CORE_OK) {
        return st;
    }
    x[0] = p->l_s * i_a + ms.m * ms.i_mu_alpha;
    x[1] = p->l_s * i_b + ms.m * ms.i_mu_beta;
    x[2] = pr_a;
    x[3] = pr_b;
    x[4] = w;
    x[5] = 0.0;
    if ((st = sm_plant_step(p, x, va, vb, T_load, d->Ts, 1)) != SM_CORE_OK ||
        (st = sm_plant_outputs_of(p, x, &o)) != SM_CORE_OK) {
        return st;
    }
    qa = x[SM_PSI_R_A];
    qb = x[SM_PSI_R_B];
    phi1 = sm_hypot(qa, qb);
    c1 = c;
    s1 = s;
    if (phi1 > 0.0) {
        c1 = qa / phi1;
        s1 = qb / phi1;
    }
    pred[0] = c1 * o.i_s_alpha + s1 * o.i_s_beta;
    pred[1] = c1 * o.i_s_beta - s1 * o.i_s_alpha;
    pred[2] = phi1;
    pred[3] = 0.0;
    pred[4] = x[SM_OMEGA_M];
    for (j = 0; j < 5; ++j) {
        v[j] = pred[j] + d->corr[j];
    }
    out[SM_MEAS_I_S_A] = c1 * v[0] - s1 * v[1];
    out[SM_MEAS_I_S_B] = s1 * v[0] + c1 * v[1];
    out[SM_MEAS_PSI_R_A] = c1 * v[2] - s1 * v[3];
    out[SM_MEAS_PSI_R_B] = s1 * v[2] + c1 * v[3];
    out[SM_MEAS_PSI_S_A] = x[SM_PSI_S_A];
    out[SM_MEAS_PSI_S_B] = x[SM_PSI_S_B];
    out[SM_MEAS_OMEGA_M] = v[4];
    return SM_CORE_OK;
}

int sm_delay_predict(sm_delay *d, const sm_motor *p, const double meas[SM_MEAS_LEN], double T_load,
                     double out[SM_MEAS_LEN])
{
    double i_a = meas[SM_MEAS_I_S_A], i_b = meas[SM_MEAS_I_S_B], pr_a = meas[SM_MEAS_PSI_R_A];
    double pr_b = meas[SM_MEAS_PSI_R_B], w = meas[SM_MEAS_OMEGA_M];
    double phi = sm_hypot(pr_a, pr_b), c = 1.0, s = 0.0, cur[SM_MEAS_LEN], pred[5];
    int j, k, st;
    if (phi > 0.0) {
        c = pr_a / phi;
        s = pr_b / phi;
    }
    if (d->has_pred && d->bias_gain > 0.0) { /* correction, in this sample's flux frame */
        double y[5];
        double g = d->bias_gain;
        y[0] = c * i_a + s * i_b;
        y[1] = c * i_b - s * i_a;
        y[2] = phi;
        y[3] = 0.0;
        y[4] = w;
        for (j = 0; j < 5; ++j) {
            d->corr[j] = d->corr[j] + g * (y[j] - d->pred[j] - d->corr[j]);
        }
    }
    for (j = 0; j < SM_MEAS_LEN; ++j) {
        cur[j] = meas[j];
    }
    for (k = 0; k < d->n; ++k) {
        if ((st = one_step(d, p, cur, d->queue[2 * k], d->queue[2 * k + 1], T_load, pred, out)) != SM_CORE_OK) {
            return st;
        }
        if (k == 0) { /* the one-sample prediction: the correction learns from it */
            for (j = 0; j < 5; ++j) {
                d->pred[j] = pred[j];
            }
            d->has_pred = 1;
        }
        for (j = 0; j < SM_MEAS_LEN; ++j) {
            cur[j] = out[j];
        }
    }
    return SM_CORE_OK;
}

/* satmotor/control/ifoc.py in C: same formulas in the same order (see sm_ifoc.h). */
#include "sm_ifoc.h"

#include <math.h>
#include <stdio.h>

static const double SM_PI = 3.14159265358979323846;

static int bad(char *msg, size_t len, const char *name, double value, const char *what)
{
    if (msg != NULL && len > 0) {
        (void)snprintf(msg, len, "%s = %.17g: %s", name, value, what);
    }
    return 1;
}

static int positive(char *msg, size_t len, const char *name, double value)
{
    if (!(isfinite(value) && value > 0.0)) {
        return bad(msg, len, name, value, "must be a finite number > 0");
    }
    return 0;
}

int sm_ifoc_set_inductance(sm_ifoc *c, double L_m, char *msg, size_t msg_len)
{
    double kLm, L_ra;
    if (c == NULL) {
        return bad(msg, msg_len, "ifoc", 0.0, "NULL argument");
    }
    if (positive(msg, msg_len, "L_m", L_m)) {
        return 1;
    }
    c->L_m = L_m;
    c->L_ra = L_ra = c->l_r + c->k * c->k * L_m;
    kLm = c->k * L_m;
    c->sigL = c->l_s + L_m - kLm * kLm / L_ra;
    c->R_eq = c->R_s + c->R_r * pow(kLm / L_ra, 2.0);
    c->tau_r = L_ra / c->R_r;
    c->Kp_i = c->sigL * c->w_c;
    c->Ki_i = c->R_eq * c->w_c;
    c->kLm = kLm;
    c->inv_kLm = 1.0 / kLm;
    c->kT = 1.5 * (double)c->n_p * kLm / L_ra;
    c->c_fd = kLm * c->R_r / (L_ra * L_ra);
    c->c_fq = (double)c->n_p * kLm / L_ra;
    c->kiT_i = c->Ki_i * c->Ts;
    c->phi_gain = -expm1(-c->Ts / c->tau_r);
    return 0;
}

int sm_ifoc_init(sm_ifoc *c, double R_s, double R_r, double l_s, double l_r, double k, int n_p, double J,
                 const sm_ifoc_gains *g, double Ts, double L_m, char *msg, size_t msg_len)
{
    if (c == NULL || g == NULL) {
        return bad(msg, msg_len, "ifoc", 0.0, "NULL argument");
    }
    if (positive(msg, msg_len, "R_s", R_s) || positive(msg, msg_len, "R_r", R_r) ||
        (!(isfinite(l_s) && l_s >= 0.0) && bad(msg, msg_len, "l_s", l_s, "must be a finite number >= 0")) ||
        positive(msg, msg_len, "l_r", l_r) ||
        positive(msg, msg_len, "k", k) || positive(msg, msg_len, "J", J) ||
        positive(msg, msg_len, "w_c", g->w_c) || positive(msg, msg_len, "w_speed", g->w_speed) ||
        positive(msg, msg_len, "I_max", g->I_max) || positive(msg, msg_len, "V_dc", g->V_dc) ||
        positive(msg, msg_len, "Ts", Ts) || positive(msg, msg_len, "L_m", L_m)) {
        return 1;
    }
    if (n_p < 1) {
        return bad(msg, msg_len, "n_p", (double)n_p, "must be an integer >= 1");
    }
    c->Ts = Ts;
    c->R_s = R_s;
    c->R_r = R_r;
    c->l_s = l_s;
    c->l_r = l_r;
    c->k = k;
    c->n_p = n_p;
    if (g->w_c * Ts > 1.0) {
        char what[96];
        (void)snprintf(what, sizeof what, "w_c Ts must be <= 1 (Ts = %.17g s)", Ts);
        return bad(msg, msg_len, "w_c", g->w_c, what);
    }
    c->w_c = g->w_c;
    c->T_sigma = 1.0 / g->w_c + Ts;
    c->a_so = 1.0 / (g->w_speed * c->T_sigma);
    if (c->a_so < 2.0) {
        char what[96];
        (void)snprintf(what, sizeof what, "symmetric optimum needs w_speed <= 1/(2 T_sigma) = %.6g rad/s",
                       0.5 / c->T_sigma);
        return bad(msg, msg_len, "w_speed", g->w_speed, what);
    }
    c->Kp_w = J * g->w_speed;
    c->Ki_w = c->Kp_w / (c->a_so * c->a_so * c->T_sigma);
    c->V_max = g->V_dc / sqrt(3.0);
    c->V_max2 = c->V_max * c->V_max;
    c->I_max = g->I_max;
    c->I_max2 = g->I_max * g->I_max;
    c->kiT_w = c->Ki_w * Ts;
    c->k_aw = fmin(1.0, g->w_c * Ts);
    c->half_Ts = 0.5 * Ts;
    if (sm_ifoc_set_inductance(c, L_m, msg, msg_len)) {
        return 1;
    }
    return sm_ifoc_reset(c, 0.0, 0.0, msg, msg_len);
}

int sm_ifoc_reset(sm_ifoc *c, double theta_f, double phi_r, char *msg, size_t msg_len)
{
    if (!isfinite(theta_f)) {
        return bad(msg, msg_len, "theta_f", theta_f, "must be a finite number");
    }
    if (!(isfinite(phi_r) && phi_r >= 0.0)) {
        return bad(msg, msg_len, "phi_r", phi_r, "must be a finite number >= 0");
    }
    c->x_w = 0.0;
    c->x_d = c->R_eq * phi_r * c->inv_kLm;
    c->x_q = 0.0;
    c->theta = remainder(theta_f, 2.0 * SM_PI);
    c->phi = phi_r;
    return 0;
}

int sm_ifoc_step(sm_ifoc *c, double i_s_alpha, double i_s_beta, double omega_m, double omega_ref_shaped,
                 double psi_ref_shaped, double *v_alpha, double *v_beta, sm_ifoc_diagnostics *d,
                 char *msg, size_t msg_len)
{
    double i_d_ref, kT, T_lim, e_w, x_w, T_u, T_ref, i_q_ref, w_slip, w_f, th, cth, sth, i_d, i_q;
    double e_d, e_q, phi, wsig, Kp, v_du, v_qu, mag2, v_d, v_q, k_aw, th_next, tho, co, so;
    int current_limited = 0, voltage_limited;
    if (!(psi_ref_shaped > 0.0 && psi_ref_shaped < INFINITY)) {
        return bad(msg, msg_len, "psi_ref_shaped", psi_ref_shaped, "must be a finite number > 0");
    }
    /* speed loop -> current references (current limit, clamping anti-windup) */
    i_d_ref = psi_ref_shaped * c->inv_kLm;
    if (i_d_ref > c->I_max) {
        i_d_ref = c->I_max;
    }
    kT = c->kT * psi_ref_shaped;
    T_lim = kT * sqrt(c->I_max2 - i_d_ref * i_d_ref);
    e_w = omega_ref_shaped - omega_m;
    x_w = c->x_w;
    T_u = c->Kp_w * e_w + x_w;
    if (T_u > T_lim) {
        T_ref = T_lim;
        current_limited = 1;
        if (e_w < 0.0) {
            x_w += c->kiT_w * e_w;
        }
    } else if (T_u < -T_lim) {
        T_ref = -T_lim;
        current_limited = 1;
        if (e_w > 0.0) {
            x_w += c->kiT_w * e_w;
        }
    } else {
        T_ref = T_u;
        x_w += c->kiT_w * e_w;
    }
    if (x_w > T_lim) {
        x_w = T_lim;
    } else if (x_w < -T_lim) {
        x_w = -T_lim;
    }
    i_q_ref = T_ref / kT;
    w_slip = i_q_ref / (c->tau_r * i_d_ref);
    w_f = (double)c->n_p * omega_m + w_slip;
    /* current loops in the flux frame */
    th = c->theta;
    cth = cos(th);
    sth = sin(th);
    i_d = cth * i_s_alpha + sth * i_s_beta;
    i_q = cth * i_s_beta - sth * i_s_alpha;
    e_d = i_d_ref - i_d;
    e_q = i_q_ref - i_q;
    phi = c->phi;
    wsig = w_f * c->sigL;
    Kp = c->Kp_i;
    v_du = Kp * e_d + c->x_d - wsig * i_q - c->c_fd * phi;
    v_qu = Kp * e_q + c->x_q + wsig * i_d + c->c_fq * omega_m * phi;
    mag2 = v_du * v_du + v_qu * v_qu;
    if (mag2 > c->V_max2) {
        double gain = c->V_max / sqrt(mag2);
        v_d = v_du * gain;
        v_q = v_qu * gain;
        voltage_limited = 1;
    } else {
        v_d = v_du;
        v_q = v_qu;
        voltage_limited = 0;
    }
    /* state update (one sample) */
    k_aw = c->k_aw;
    c->x_d += c->kiT_i * e_d + k_aw * (v_d - v_du);
    c->x_q += c->kiT_i * e_q + k_aw * (v_q - v_qu);
    c->x_w = x_w;
    c->phi = phi + c->phi_gain * (c->kLm * i_d - phi);
    th_next = th + c->Ts * w_f;
    if (th_next > SM_PI || th_next < -SM_PI) {
        th_next = remainder(th_next, 2.0 * SM_PI);
    }
    c->theta = th_next;
    /* back to alpha-beta at the mean angle of the hold interval */
    tho = th + c->half_Ts * w_f;
    co = cos(tho);
    so = sin(tho);
    *v_alpha = co * v_d - so * v_q;
    *v_beta = so * v_d + co * v_q;
    if (d != NULL) {
        d->i_sd = i_d;
        d->i_sq = i_q;
        d->i_sd_ref = i_d_ref;
        d->i_sq_ref = i_q_ref;
        d->T_ref = T_ref;
        d->omega_slip = w_slip;
        d->theta_f = th;
        d->phi_hat = phi;
        d->v_sd = v_d;
        d->v_sq = v_q;
        d->voltage_limited = voltage_limited;
        d->current_limited = current_limited;
    }
    return 0;
}

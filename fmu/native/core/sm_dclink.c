/* satmotor/converter/dc_link.py in C99 (see sm_dclink.h). */
#include "sm_dclink.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define SM_DCLINK_PI 3.141592653589793 /* math.pi */

int sm_dclink_init(sm_dclink *l, const sm_dclink_params *pp, char *msg, size_t msg_len)
{
    sm_dclink q;
    const char *names[] = {"V_dc", "C_dc", "R_src", "V_grid", "f_grid"};
    double vals[5];
    int i = 0, st;
    if (msg != NULL && msg_len > 0) msg[0] = '\0';
    if (l == NULL || pp == NULL) return SM_ERR_ARG;
    if (sm_dclink_params_require_finite(pp, msg, msg_len)) return SM_ERR_PARAM;
    memset(&q, 0, sizeof q);
    if ((st = sm_choice_parse(SM_CHOICE_PARAM_dc_link, pp->dc_link, &i, msg, msg_len)) != SM_CORE_OK) return st;
    q.capacitor = i == SM_CHOICE_dc_link_capacitor;
    if ((st = sm_choice_parse(SM_CHOICE_PARAM_dc_source, pp->dc_source, &i, msg, msg_len)) != SM_CORE_OK) return st;
    q.src_dc = i == SM_CHOICE_dc_source_dc;
    vals[0] = pp->V_dc;
    vals[1] = pp->C_dc;
    vals[2] = pp->R_src;
    vals[3] = pp->V_grid;
    vals[4] = pp->f_grid;
    for (i = 0; i < 5; ++i)
        if (sm_require_number(names[i], vals[i], 1, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("R_chop", pp->R_chop, 1, 0.0, 1, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("V_dc_max", pp->V_dc_max, 1, 0.0, 1, msg, msg_len)) return SM_ERR_PARAM;
    /* checked without a chopper too (R_chop = 0): an inverted hysteresis is never accepted silently */
    if (sm_require_number("V_chop_on", pp->V_chop_on, 1, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("V_chop_off", pp->V_chop_off, 1, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
    if (!(pp->V_chop_off < pp->V_chop_on)) {
        char v[40], on[40], reason[160];
        snprintf(reason, sizeof reason, "must be below V_chop_on = %s V (the hysteresis: the chopper switches on "
                 "above V_chop_on and off below V_chop_off)", sm_repr_double(pp->V_chop_on, on, sizeof on));
        return sm_param_error(msg, msg_len, NULL, "V_chop_off", sm_repr_double(pp->V_chop_off, v, sizeof v),
                              reason);
    }
    /* with the chopper and the fault check both on, the chopper acts first (dc_link.py CHOPPER_BELOW_FAULT) */
    if (pp->R_chop > 0.0 && pp->V_dc_max > 0.0 && !(pp->V_chop_on < pp->V_dc_max)) {
        char v[40], on[40], reason[200];
        snprintf(reason, sizeof reason, "must be above V_chop_on = %s V with a brake chopper (R_chop > 0): the "
                 "chopper switches on below the over-voltage fault's level (V_dc_max = 0: no fault check)",
                 sm_repr_double(pp->V_chop_on, on, sizeof on));
        return sm_param_error(msg, msg_len, NULL, "V_dc_max", sm_repr_double(pp->V_dc_max, v, sizeof v), reason);
    }
    q.V_dc = pp->V_dc;
    q.C_dc = pp->C_dc;
    q.R_src = pp->R_src;
    q.V_grid = pp->V_grid;
    q.f_grid = pp->f_grid;
    q.V_chop_on = pp->V_chop_on;
    q.V_chop_off = pp->V_chop_off;
    q.R_chop = pp->R_chop;
    q.V_dc_max = pp->V_dc_max;
    /* DCLink.__init__ */
    q.inv_R_src = 1.0 / q.R_src;
    q.inv_C = 1.0 / q.C_dc;
    q.chop_enabled = q.R_chop > 0.0;
    q.inv_R_chop = q.chop_enabled ? 1.0 / q.R_chop : 0.0;
    q.amp = sqrt(2.0) * q.V_grid;
    q.omega_g = 2.0 * SM_DCLINK_PI * q.f_grid;
    q.third = SM_DCLINK_PI / 3.0;
    q.sixth = SM_DCLINK_PI / 6.0;
    memcpy(l, &q, sizeof q);
    return SM_CORE_OK;
}

size_t sm_dclink_size(void)
{
    return sizeof(sm_dclink);
}

double sm_dclink_source_voltage(const sm_dclink *l, double t)
{
    double theta, phi;
    if (l->src_dc) return l->V_dc;
    theta = l->omega_g * t;
    phi = theta - l->third * floor(theta / l->third) - l->sixth;
    return l->amp * cos(phi);
}

void sm_dclink_applied(double v_a, double v_b, double v_dc, double *out_a, double *out_b)
{
    double vmax, vn, g;
    if (!(v_dc > 0.0)) {
        *out_a = 0.0;
        *out_b = 0.0;
        return;
    }
    vmax = v_dc / sqrt(3.0);
    vn = sm_hypot(v_a, v_b);
    if (vn > vmax) {
        g = vmax / vn;
        *out_a = v_a * g;
        *out_b = v_b * g;
        return;
    }
    *out_a = v_a;
    *out_b = v_b;
}

int sm_dclink_derivatives(const sm_motor *p, const sm_dclink *l, double t, const double *x, double v_a,
                          double v_b, double T_load, int chop, double *dx)
{
    sm_plant_outputs o;
    double va, vb, v_dc, p_inv;
    int st, i, iv;
    if (p == NULL || l == NULL || x == NULL || dx == NULL) return SM_ERR_ARG;
    iv = sm_dclink_iv(p);
    v_dc = x[iv];
    sm_dclink_applied(v_a, v_b, v_dc, &va, &vb);
    st = sm_plant_outputs_v(p, x, va, vb, &o); /* the terminal current at the applied voltage */
    if (st == SM_CORE_OK) st = sm_plant_derivatives(p, x, va, vb, T_load, dx);
    if (st != SM_CORE_OK || !isfinite(v_dc)) {
        for (i = 0; i < iv + 3; ++i) dx[i] = NAN;
        return st != SM_CORE_OK ? st : SM_ERR_NONFINITE;
    }
    p_inv = 1.5 * (va * o.i_s_alpha + vb * o.i_s_beta);
    sm_dclink_rates(l, t, v_dc, p_inv, chop, dx + iv);
    for (i = iv; i < iv + 3; ++i)
        if (!isfinite(dx[i])) return SM_ERR_NONFINITE;
    return SM_CORE_OK;
}

void sm_dclink_rates(const sm_dclink *l, double t, double v_dc, double p_inv, int chop, double r[3])
{
    double i_dc = v_dc > 0.0 ? p_inv / v_dc : 0.0, i_src, i_chop;
    i_src = (sm_dclink_source_voltage(l, t) - v_dc) * l->inv_R_src;
    if (!(i_src > 0.0)) i_src = 0.0;
    i_chop = chop ? v_dc * l->inv_R_chop : 0.0;
    r[0] = (i_src - i_dc - i_chop) * l->inv_C;
    r[1] = p_inv < 0.0 ? -p_inv : 0.0;
    r[2] = v_dc * i_chop;
}

void sm_dclink_substep_end(const sm_dclink *l, double v_dc, double t_end, int *chop, int *fault, double *t_fault)
{
    *chop = sm_dclink_switch(l, v_dc, *chop);
    if (!*fault && l->V_dc_max > 0.0 && v_dc > l->V_dc_max) {
        *fault = 1;
        *t_fault = t_end;
    }
}

int sm_dclink_switch(const sm_dclink *l, double v_dc, int chop)
{
    if (!l->chop_enabled) return 0;
    if (v_dc > l->V_chop_on) return 1;
    if (v_dc < l->V_chop_off) return 0;
    return chop;
}

int sm_dclink_step(const sm_motor *p, const sm_dclink *l, double t, double *x, double v_a,
                   double v_b, double T_load, double dt, int n_sub, int *chop, int *fault, double *t_fault)
{
    enum { NM = SM_N_LINK_STATES_MAX };
    double xc[NM], xt[NM], k1[NM], k2[NM], k3[NM], k4[NM], h, half, sixth, tj;
    int j, i, st, c, f, N, iv;
    if (p == NULL || l == NULL || x == NULL || chop == NULL || fault == NULL || t_fault == NULL || n_sub < 1)
        return SM_ERR_ARG;
    iv = sm_dclink_iv(p);
    N = iv + 3;
    *t_fault = NAN;
    if (!isfinite(dt)) return SM_ERR_NONFINITE;
    h = dt / (double)n_sub;
    half = 0.5 * h;
    sixth = h / 6.0;
    c = *chop;
    f = *fault;
    memcpy(xc, x, (size_t)N * sizeof xc[0]);
    for (j = 0; j < n_sub; ++j) {
        tj = t + (double)j * h;
        if ((st = sm_dclink_derivatives(p, l, tj, xc, v_a, v_b, T_load, c, k1)) != SM_CORE_OK) return st;
        for (i = 0; i < N; ++i) xt[i] = xc[i] + half * k1[i];
        if ((st = sm_dclink_derivatives(p, l, tj + half, xt, v_a, v_b, T_load, c, k2)) != SM_CORE_OK) return st;
        for (i = 0; i < N; ++i) xt[i] = xc[i] + half * k2[i];
        if ((st = sm_dclink_derivatives(p, l, tj + half, xt, v_a, v_b, T_load, c, k3)) != SM_CORE_OK) return st;
        for (i = 0; i < N; ++i) xt[i] = xc[i] + h * k3[i];
        if ((st = sm_dclink_derivatives(p, l, tj + h, xt, v_a, v_b, T_load, c, k4)) != SM_CORE_OK) return st;
        for (i = 0; i < N; ++i) xc[i] = xc[i] + sixth * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        sm_dclink_substep_end(l, xc[iv], tj + h, &c, &f, t_fault);
    }
    for (i = 0; i < N; ++i)
        if (!isfinite(xc[i])) return SM_ERR_NONFINITE;
    memcpy(x, xc, (size_t)N * sizeof xc[0]);
    *chop = c;
    *fault = f;
    return SM_CORE_OK;
}

void sm_dclink_over_voltage_message(double t, double v_dc, double V_dc_max, char *msg, size_t msg_len)
{
    char a[40], b[40], c[40];
    if (msg == NULL || msg_len == 0) return;
    snprintf(msg, msg_len, "SaturatedInductionMotor: DC-link over-voltage at t = %s s: v_dc = %s V exceeds "
             "V_dc_max = %s V; dc_fault is set and the simulation goes on (logged once per run)",
             sm_repr_double(t, a, sizeof a), sm_repr_double(v_dc, b, sizeof b),
             sm_repr_double(V_dc_max, c, sizeof c));
}

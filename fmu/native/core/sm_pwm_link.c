/* satmotor/converter/pwm_link.py in C99 (see sm_pwm_link.h). */
#include "sm_pwm_link.h"

#include "sm_phases.h"

#include <math.h>
#include <string.h>

int sm_pwm_link_derivatives(const sm_motor *p, const sm_dclink *l, double t, const double *y, const double sig[3],
                            const double dl[3], double T_load, int chop, double *dy)
{
    sm_plant_outputs o;
    double v_dc, half, g[3], ga, gb, va, vb, p_dc;
    int st, i, iv;
    if (p == NULL || l == NULL || y == NULL || sig == NULL || dl == NULL || dy == NULL) return SM_ERR_ARG;
    iv = sm_dclink_iv(p);
    v_dc = y[iv];
    if (v_dc > 0.0) {
        half = 0.5 * v_dc;
        for (i = 0; i < 3; ++i) g[i] = sig[i] * half;
        sm_alpha_beta(g[0], g[1], g[2], &ga, &gb);
        sm_alpha_beta(g[0] + dl[0], g[1] + dl[1], g[2] + dl[2], &va, &vb);
    } else {
        ga = gb = va = vb = 0.0;
    }
    st = sm_plant_outputs_v(p, y, va, vb, &o);
    if (st == SM_CORE_OK) st = sm_plant_derivatives(p, y, va, vb, T_load, dy);
    if (st != SM_CORE_OK || !isfinite(v_dc)) {
        for (i = 0; i < iv + 5; ++i) dy[i] = NAN;
        return st != SM_CORE_OK ? st : SM_ERR_NONFINITE;
    }
    p_dc = 1.5 * (ga * o.i_s_alpha + gb * o.i_s_beta);
    sm_dclink_rates(l, t, v_dc, p_dc, chop, dy + iv);
    dy[iv + 3] = va;
    dy[iv + 4] = vb;
    for (i = iv; i < iv + 5; ++i)
        if (!isfinite(dy[i])) return SM_ERR_NONFINITE;
    return SM_CORE_OK;
}

int sm_pwm_link_step(const sm_motor *p, const sm_dclink *l, double t, double *x, const double sig[3],
                     const double dl[3], double T_load, double h, int n_sub, int *chop, int *fault, double *t_fault,
                     double v_int[2])
{
    enum { NM = SM_N_LINK_STATES_MAX + 2 };
    double yc[NM], yt[NM], k1[NM], k2[NM], k3[NM], k4[NM], dt, half, sixth, tj;
    int j, i, st, c, f, N, iv;
    if (p == NULL || l == NULL || x == NULL || chop == NULL || fault == NULL || t_fault == NULL || v_int == NULL ||
        n_sub < 1)
        return SM_ERR_ARG;
    *t_fault = NAN;
    if (!isfinite(h)) return SM_ERR_NONFINITE;
    iv = sm_dclink_iv(p);
    N = iv + 5;
    dt = h / (double)n_sub;
    half = 0.5 * dt;
    sixth = dt / 6.0;
    c = *chop;
    f = *fault;
    memcpy(yc, x, (size_t)(iv + 3) * sizeof yc[0]);
    yc[iv + 3] = 0.0;
    yc[iv + 4] = 0.0;
    for (j = 0; j < n_sub; ++j) {
        tj = t + (double)j * dt;
        if ((st = sm_pwm_link_derivatives(p, l, tj, yc, sig, dl, T_load, c, k1)) != SM_CORE_OK) return st;
        for (i = 0; i < N; ++i) yt[i] = yc[i] + half * k1[i];
        if ((st = sm_pwm_link_derivatives(p, l, tj + half, yt, sig, dl, T_load, c, k2)) != SM_CORE_OK) return st;
        for (i = 0; i < N; ++i) yt[i] = yc[i] + half * k2[i];
        if ((st = sm_pwm_link_derivatives(p, l, tj + half, yt, sig, dl, T_load, c, k3)) != SM_CORE_OK) return st;
        for (i = 0; i < N; ++i) yt[i] = yc[i] + dt * k3[i];
        if ((st = sm_pwm_link_derivatives(p, l, tj + dt, yt, sig, dl, T_load, c, k4)) != SM_CORE_OK) return st;
        for (i = 0; i < N; ++i) yc[i] = yc[i] + sixth * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        sm_dclink_substep_end(l, yc[iv], tj + dt, &c, &f, t_fault);
    }
    for (i = 0; i < N; ++i)
        if (!isfinite(yc[i])) return SM_ERR_NONFINITE;
    memcpy(x, yc, (size_t)(iv + 3) * sizeof yc[0]);
    v_int[0] = yc[iv + 3];
    v_int[1] = yc[iv + 4];
    *chop = c;
    *fault = f;
    return SM_CORE_OK;
}

int sm_pwm_link_interval(const sm_motor *p, sm_pwm_link_run *lk, double *x, double t, double L, const double sig[3],
                         const double dl[3], double T_load, int n_sub, double v_int[2])
{
    double tf;
    int st, f;
    if (lk == NULL) return SM_ERR_ARG;
    f = lk->fault;
    st = sm_pwm_link_step(p, lk->l, t, x, sig, dl, T_load, L, n_sub, &lk->chop, &f, &tf, v_int);
    if (st != SM_CORE_OK) return st;
    if (!isnan(tf) && isnan(lk->t_fault)) lk->t_fault = tf;
    lk->fault = f;
    return SM_CORE_OK;
}

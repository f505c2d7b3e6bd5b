/* The backstepping law chain of satmotor (fo_model.py, measurements.py, backstepping.py) in C99.
 * Every expression keeps the Python's operands and their order (C and Python associate + - * /
 * the same way), so the results are the Python's floats; comments name the Python source. */
#include "sm_law.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "sm_atan.h"

/* ---- fo_model.py ----------------------------------------------------------------------------- */

void sm_model_constants_of(const sm_motor *p, sm_model_constants *c)
{
    double k = p->k, lr = p->l_r, ls = p->l_s;
    double a = p->R_r / lr;
    double k_lr = k / lr;
    c->k = k;
    c->l_s = ls;
    c->R_s = p->R_s;
    c->n_p = p->n_p;
    c->a = a;
    c->ak = a * k;
    c->K = 1.5 * p->n_p * k / (p->J * lr);
    c->b = p->B / p->J;
    c->sigma = 1.0 + k * k * ls / lr;
    c->k_lr = k_lr;
    c->k2_lr = k * k_lr;
    c->kls_lr = ls * k_lr;
}

double sm_flux_rate(double a, double k, double phi, double i_mu_d, double m)
{
    return a * (k * m * i_mu_d - phi);
}

void sm_vector_fields(const sm_model_constants *c, double phi, double imd, double imq, double w,
                      double m, double dm, double I, double theta, double phi_ws, sm_fields *f)
{
    double Md, Mq, Mdq, l11, l22, l12, detL, a11, a22, a12, cc, ls_sm, isd, psd, dphi, ws, r1, r2;
    double te_J;
    const double ls = c->l_s, sg = c->sigma;
    sm_inductance_matrix(m, dm, imd, imq, I, &Md, &Mq, &Mdq);
    l11 = ls + sg * Md;
    l22 = ls + sg * Mq;
    l12 = sg * Mdq;
    detL = l11 * l22 - l12 * l12;
    a11 = l22 / detL;
    a22 = l11 / detL;
    a12 = -l12 / detL;
    cc = 1.0 + c->k2_lr * m;
    ls_sm = ls + sg * m;
    isd = cc * imd - c->k_lr * phi;
    psd = ls_sm * imd - c->kls_lr * phi;
    dphi = sm_flux_rate(c->a, c->k, phi, imd, m);
    ws = c->n_p * w + c->ak * m * imq / phi_ws;
    r1 = -c->R_s * isd + ws * ls_sm * imq + c->kls_lr * dphi;
    r2 = -c->R_s * cc * imq - ws * psd;
    te_J = c->K * m * phi * imq;
    f->F_phi = dphi;
    f->F_d = a11 * r1 + a12 * r2;
    f->F_q = a12 * r1 + a22 * r2;
    f->F_w = te_J - theta - c->b * w;
    f->g_dd = a11;
    f->g_dq = a12;
    f->g_qq = a22;
    f->omega_s = ws;
    f->M_d = Md;
    f->M_q = Mq;
    f->M_dq = Mdq;
    f->i_sd = isd;
    f->i_sq = cc * imq;
    f->psi_sd = psd;
    f->psi_sq = ls_sm * imq;
    f->te_J = te_J;
    f->det_L = detL;
}

/* ---- measurements.py ------------------------------------------------------------------------- */

static void in_flux_frame(double ima, double imb, double I, double m, double pra, double prb,
                          sm_magnetizing *ms)
{
    double phi = sm_hypot(pra, prb);
    double rho = sm_atan2(prb, pra); /* the own atan2: the same bits on every platform */
    double c = cos(rho), s = sin(rho);
    ms->i_mu_alpha = ima;
    ms->i_mu_beta = imb;
    ms->I = I;
    ms->m = m;
    ms->Phi_rd = phi;
    ms->i_mu_d = c * ima + s * imb;
    ms->i_mu_q = c * imb - s * ima;
    ms->rho = rho;
}

static int all_finite(const double *v, int n)
{
    int i;
    for (i = 0; i < n; ++i)
        if (!isfinite(v[i])) return 0;
    return 1;
}

int sm_from_rotor_flux(double i_sa, double i_sb, double psi_ra, double psi_rb, const sm_motor *p,
                       sm_magnetizing *ms)
{
    double in[4], k_lr, wa, wb, wn, a, I = 0.0, psi = 0.0, s;
    int st;
    if (p == NULL || ms == NULL) return SM_ERR_ARG;
    in[0] = i_sa;
    in[1] = i_sb;
    in[2] = psi_ra;
    in[3] = psi_rb;
    k_lr = p->k / p->l_r;
    wa = i_sa + k_lr * psi_ra;
    wb = i_sb + k_lr * psi_rb;
    wn = sm_hypot(wa, wb);
    a = p->l_r / (p->k * p->k);
    st = sm_curve_solve(&p->curve, a, a * wn, &I, &psi);
    if (st == SM_ERR_NOCONV) {
        in_flux_frame(NAN, NAN, NAN, NAN, psi_ra, psi_rb, ms);
        return st;
    }
    if (st != SM_CORE_OK) { /* a non-finite |w|: Python's solve returns NaN (or inf) iterates */
        I = NAN;
        psi = NAN;
    }
    if (I == 0.0) {
        in_flux_frame(0.0, 0.0, 0.0, sm_curve_m(&p->curve, 0.0), psi_ra, psi_rb, ms);
    } else {
        s = I / wn;
        in_flux_frame(s * wa, s * wb, I, psi / I, psi_ra, psi_rb, ms);
    }
    return (st == SM_CORE_OK && all_finite(in, 4)) ? SM_CORE_OK : SM_ERR_NONFINITE; /* |w| may overflow */
}

int sm_from_magnetizing_current(double i_mu_a, double i_mu_b, double psi_ra, double psi_rb,
                                const sm_motor *p, sm_magnetizing *ms)
{
    double in[4], I;
    if (p == NULL || ms == NULL) return SM_ERR_ARG;
    in[0] = i_mu_a;
    in[1] = i_mu_b;
    in[2] = psi_ra;
    in[3] = psi_rb;
    I = sm_hypot(i_mu_a, i_mu_b);
    in_flux_frame(i_mu_a, i_mu_b, I, sm_curve_m(&p->curve, I), psi_ra, psi_rb, ms);
    return all_finite(in, 4) ? SM_CORE_OK : SM_ERR_NONFINITE;
}

int sm_from_stator_flux(double i_sa, double i_sb, double psi_ra, double psi_rb, double psi_sa,
                        double psi_sb, const sm_motor *p, sm_magnetizing *ms)
{
    double in[6], k, ls, k_lr, sg, ima, imb, I, m;
    if (p == NULL || ms == NULL) return SM_ERR_ARG;
    in[0] = i_sa;
    in[1] = i_sb;
    in[2] = psi_ra;
    in[3] = psi_rb;
    in[4] = psi_sa;
    in[5] = psi_sb;
    k = p->k;
    ls = p->l_s;
    k_lr = k / p->l_r;
    sg = 1.0 + p->k * p->k * p->l_s / p->l_r; /* MotorParams.sigma */
    ima = sg * i_sa + k_lr * (psi_ra - k * psi_sa);
    imb = sg * i_sb + k_lr * (psi_rb - k * psi_sb);
    I = sm_hypot(ima, imb);
    if (I == 0.0)
        m = sm_curve_m(&p->curve, 0.0);
    else
        m = sm_hypot(psi_sa - ls * i_sa, psi_sb - ls * i_sb) / I;
    in_flux_frame(ima, imb, I, m, psi_ra, psi_rb, ms);
    return all_finite(in, 6) ? SM_CORE_OK : SM_ERR_NONFINITE;
}

/* ---- backstepping.py: parameters --------------------------------------------------------------- */

int sm_gains_check(const sm_gains *g, char *msg, size_t msg_len)
{
    int st;
    if (g == NULL) return SM_ERR_ARG;
    if ((st = sm_require_number("c1", g->c1, 1, 0.0, 0, msg, msg_len)) != SM_CORE_OK) return st;
    if ((st = sm_require_number("c2", g->c2, 1, 0.0, 0, msg, msg_len)) != SM_CORE_OK) return st;
    if ((st = sm_require_number("d1", g->d1, 1, 0.0, 0, msg, msg_len)) != SM_CORE_OK) return st;
    if ((st = sm_require_number("d2", g->d2, 1, 0.0, 0, msg, msg_len)) != SM_CORE_OK) return st;
    if ((st = sm_require_number("c0", g->c0, 1, 0.0, 1, msg, msg_len)) != SM_CORE_OK) return st;
    return sm_require_number("d0", g->d0, 1, 0.0, 1, msg, msg_len);
}

static int require_flag(const char *field, int value, const char *reason, char *msg, size_t msg_len)
{
    char v[24];
    if (value == 0 || value == 1) return SM_CORE_OK;
    snprintf(v, sizeof v, "%d", value);
    return sm_param_error(msg, msg_len, NULL, field, v, reason);
}

int sm_law_config_check(const sm_law_config *cfg, char *msg, size_t msg_len)
{
    int st;
    if (cfg == NULL) return SM_ERR_ARG;
    if ((st = sm_require_number("V_dc", cfg->V_dc, 1, 0.0, 0, msg, msg_len)) != SM_CORE_OK) return st;
    if ((st = sm_require_number("Ts", cfg->Ts, 1, 0.0, 1, msg, msg_len)) != SM_CORE_OK) return st;
    if ((st = sm_require_number("phi_min", cfg->phi_min, 1, 0.0, 0, msg, msg_len)) != SM_CORE_OK) return st;
    if ((st = require_flag("load_estimated", cfg->load_estimated,
                           "must be 0 ('known') or 1 ('estimated')", msg, msg_len)) != SM_CORE_OK)
        return st;
    if ((st = require_flag("overmodulation", cfg->overmodulation,
                           "must be 0 ('linear') or 1 ('overmodulation')", msg, msg_len)) != SM_CORE_OK)
        return st;
    if ((st = sm_require_number("g_theta", cfg->g_theta, 1, 0.0, 0, msg, msg_len)) != SM_CORE_OK) return st;
    if ((st = sm_require_number("theta_max", cfg->theta_max, 1, 0.0, 0, msg, msg_len)) != SM_CORE_OK)
        return st;
    return require_flag("use_stator_flux", cfg->use_stator_flux, "must be a bool (0 or 1)", msg,
                        msg_len);
}

/* ---- backstepping.py: the error system ------------------------------------------------------- */

/* backstepping._clip */
static double clip(double x, double lo, double hi)
{
    return x < lo ? lo : x > hi ? hi : x;
}

/* modulation.phase_spread: the largest line-to-line voltage [V], max - min of the phase voltages */
static double phase_spread(double v_alpha, double v_beta)
{
    double s32 = 0.5 * sqrt(3.0), v0 = v_alpha, v1, v2, hi, lo;
    v1 = -0.5 * v_alpha + s32 * v_beta;
    v2 = -0.5 * v_alpha - s32 * v_beta;
    hi = v0 > v1 ? v0 : v1;
    hi = hi > v2 ? hi : v2;
    lo = v0 < v1 ? v0 : v1;
    lo = lo < v2 ? lo : v2;
    return hi - lo;
}

/* modulation.limit_voltage (sm_law.h) */
int sm_voltage_limit(double *vd, double *vq, double c, double s, double V_dc, int overmodulation)
{
    double vmax = V_dc / sqrt(3.0), vn = sm_hypot(*vd, *vq);
    int vlim;
    if (overmodulation) {
        double spread = phase_spread(c * *vd - s * *vq, s * *vd + c * *vq);
        vlim = !(spread <= V_dc);
        if (vlim && isfinite(spread)) {
            double f = V_dc / spread;
            *vd = *vd * f;
            *vq = *vq * f;
            return 1;
        }
    } else {
        vlim = !(vn <= vmax);
    }
    if (vlim) {
        if (isfinite(vn)) {
            double f = vmax / vn;
            *vd = *vd * f;
            *vq = *vq * f;
        } else if (fabs(*vd) >= fabs(*vq)) { /* overflow: keep the direction where it is defined */
            *vd = copysign(vmax, *vd);
            *vq = 0.0;
        } else {
            *vd = 0.0;
            *vq = copysign(vmax, *vq);
        }
    }
    return vlim;
}

/* backstepping._core; adapt NULL or (g_theta, theta_max). */
static void core(const sm_model_constants *c, const sm_gains *g, double phi_min, double phi,
                 double imd, double imq, double w, double m, double dm, double I, const double ref[6],
                 double theta, double theta_dot, const double *adapt, double e0, double z0,
                 double i_max, sm_error_state *es)
{
    /* the drive's shaped references and their first two time derivatives */
    const double psi_ref_shaped = ref[0], psi_ref_shaped_dot = ref[1], psi_ref_shaped_ddot = ref[2];
    const double omega_ref_shaped = ref[3], omega_ref_shaped_dot = ref[4], omega_ref_shaped_ddot = ref[5];
    const double c1 = g->c1, d1 = g->d1, c0 = g->c0, d0 = g->d0;
    const double a = c->a, ak = c->ak, K = c->K, b = c->b;
    int limited = phi < phi_min;
    const double phe = limited ? phi_min : phi;
    double e1, z1, alpha1, gamma1, e2, z2, Kp, L11, L12, L21, L22, W, floor_;
    int d_lim = 0, q_lim = 0;
    sm_fields f;
    /* drift F and L^-1 of the control model (Phi_rd floored in omega_s) */
    sm_vector_fields(c, phi, imd, imq, w, m, dm, I, theta, phe, &f);
    e1 = phi - psi_ref_shaped;
    z1 = w - omega_ref_shaped;
    /* virtual controls: alpha1 for a k m i_mu_d, gamma1 for T_e/J */
    alpha1 = -c1 * e1 - c0 * e0 + a * phi + psi_ref_shaped_dot;
    gamma1 = -d1 * z1 - d0 * z0 + theta + b * w + omega_ref_shaped_dot;
    if (i_max < (double)INFINITY) { /* the currents they demand, bounded (m held at its value) */
        double cc = 1.0 + c->k2_lr * m;
        double ak_m = ak * m;
        double i_sd = cc * alpha1 / ak_m - c->k_lr * phi;
        double i_sd_c = clip(i_sd, -SM_D_SHARE * i_max, SM_D_SHARE * i_max);
        double g_max;
        if (i_sd_c != i_sd) {
            d_lim = i_sd > i_sd_c ? 1 : -1;
            alpha1 = ak_m * (i_sd_c + c->k_lr * phi) / cc;
        }
        g_max = K * m * phi * sqrt(i_max * i_max - i_sd_c * i_sd_c) / cc;
        if (!(-g_max <= gamma1 && gamma1 <= g_max)) {
            q_lim = gamma1 > g_max ? 1 : -1;
            gamma1 = clip(gamma1, -g_max, g_max);
        }
    }
    e2 = ak * m * imd - alpha1;
    z2 = f.te_J - gamma1;
    if (adapt != NULL) {
        const double g_theta = adapt[0], theta_max = adapt[1];
        theta_dot = -g_theta * (z1 + (d1 - b) * z2);
        if (q_lim * theta_dot > 0.0) theta_dot = 0.0; /* anti-windup: not further into the bound */
        if ((theta >= theta_max && theta_dot > 0.0) || (theta <= -theta_max && theta_dot < 0.0))
            theta_dot = 0.0;
    }
    /* gradients and explicit time derivatives; a bounded virtual control is held constant */
    es->grad_e2[1] = ak * f.M_d;
    es->grad_e2[2] = ak * f.M_dq;
    es->grad_e2[3] = 0.0;
    if (d_lim) {
        es->grad_e2[0] = 0.0;
        es->dt_e2 = 0.0;
    } else {
        es->grad_e2[0] = c1 - a;
        es->dt_e2 = -c1 * psi_ref_shaped_dot - psi_ref_shaped_ddot + c0 * e1;
    }
    es->grad_z2[0] = K * m * imq;
    es->grad_z2[1] = K * phi * f.M_dq;
    es->grad_z2[2] = K * phi * f.M_q;
    if (q_lim) {
        es->grad_z2[3] = 0.0;
        es->dt_z2 = 0.0;
    } else {
        es->grad_z2[3] = d1 - b;
        es->dt_z2 = -d1 * omega_ref_shaped_dot - omega_ref_shaped_ddot - theta_dot + d0 * z1;
    }
    es->beta1 = es->grad_e2[0] * f.F_phi + es->grad_e2[1] * f.F_d + es->grad_e2[2] * f.F_q + es->dt_e2;
    es->beta2 = es->grad_z2[0] * f.F_phi + es->grad_z2[1] * f.F_d + es->grad_z2[2] * f.F_q
                + es->grad_z2[3] * f.F_w + es->dt_z2;
    /* Lambda = diag(a k, K Phi_rd) M L^-1 */
    Kp = K * phe;
    L11 = ak * (f.M_d * f.g_dd + f.M_dq * f.g_dq);
    L12 = ak * (f.M_d * f.g_dq + f.M_dq * f.g_qq);
    L21 = Kp * (f.M_dq * f.g_dd + f.M_q * f.g_dq);
    L22 = Kp * (f.M_dq * f.g_dq + f.M_q * f.g_qq);
    W = L11 * L22 - L12 * L21;
    floor_ = SM_W_REL_FLOOR * (fabs(L11 * L22) + fabs(L12 * L21));
    if (!(fabs(W) > floor_)) limited = 1;
    es->e1 = e1;
    es->e2 = e2;
    es->z1 = z1;
    es->z2 = z2;
    es->Lambda[0][0] = L11;
    es->Lambda[0][1] = L12;
    es->Lambda[1][0] = L21;
    es->Lambda[1][1] = L22;
    es->W = W * (phi / phe);
    es->omega_s = f.omega_s;
    es->theta_dot = theta_dot;
    es->singular_limited = limited;
    es->flux_limited = d_lim;
    es->torque_limited = q_lim;
}

int sm_error_system(const double x[4], const double ref[6], const sm_motor *p, const sm_gains *g,
                    double theta, double theta_dot, double phi_min, const double *adapt,
                    const double *integ, double i_max, sm_error_state *es)
{
    sm_model_constants c;
    double psi, m, dm, ldyn, I, e0 = 0.0, z0 = 0.0;
    int finite;
    if (x == NULL || ref == NULL || p == NULL || g == NULL || es == NULL) return SM_ERR_ARG;
    if (integ != NULL) {
        e0 = integ[0];
        z0 = integ[1];
    }
    I = sm_hypot(x[1], x[2]);
    sm_curve_evaluate(&p->curve, I, &psi, &m, &dm, &ldyn);
    sm_model_constants_of(p, &c);
    core(&c, g, phi_min, x[0], x[1], x[2], x[3], m, dm, I, ref, theta, theta_dot, adapt, e0, z0,
         i_max, es);
    finite = all_finite(x, 4) && all_finite(ref, 6) && isfinite(theta) && isfinite(e0)
             && isfinite(z0) && (adapt != NULL || isfinite(theta_dot));
    return finite ? SM_CORE_OK : SM_ERR_NONFINITE;
}

/* ---- backstepping.py: control ---------------------------------------------------------------- */

int sm_control(const double meas[SM_MEAS_LEN], const double ref[6], const double load[2],
               const sm_motor *p, const sm_gains *g, const sm_law_config *cfg, double theta_hat,
               const double integ[2], double i_max, sm_control_output *out)
{
    sm_model_constants c;
    sm_magnetizing ms;
    sm_error_state es;
    double w, I, dm, theta, theta_dot, adapt[2] = {0.0, 0.0}, e0 = 0.0, z0 = 0.0, L11, L12, L21, L22, W;
    double q1, q2, vd, vq, rho_out, cr, sr, V;
    int st, finite, vlim;
    if (out != NULL) memset(out, 0, sizeof *out);
    if (meas == NULL || ref == NULL || p == NULL || g == NULL || cfg == NULL || out == NULL
        || (!cfg->load_estimated && load == NULL))
        return SM_ERR_ARG;
    if (integ != NULL) {
        e0 = integ[0];
        z0 = integ[1];
    }
    if (cfg->use_stator_flux)
        st = sm_from_stator_flux(meas[SM_MEAS_I_S_A], meas[SM_MEAS_I_S_B], meas[SM_MEAS_PSI_R_A],
                                 meas[SM_MEAS_PSI_R_B], meas[SM_MEAS_PSI_S_A], meas[SM_MEAS_PSI_S_B], p,
                                 &ms);
    else
        st = sm_from_rotor_flux(meas[SM_MEAS_I_S_A], meas[SM_MEAS_I_S_B], meas[SM_MEAS_PSI_R_A],
                                meas[SM_MEAS_PSI_R_B], p, &ms);
    if (st == SM_ERR_NOCONV) {
        /* every value NaN (the Python raises ArithmeticError) */
        out->v_s_alpha = out->v_s_beta = out->v_sd = out->v_sq = NAN;
        out->e1 = out->e2 = out->z1 = out->z2 = out->V = out->W = NAN;
        out->m = out->i_mu = out->Phi_rd = out->rho = out->omega_s = out->theta_hat_dot = NAN;
        out->e0_dot = out->z0_dot = NAN;
        return st;
    }
    w = meas[SM_MEAS_OMEGA_M];
    I = ms.I;
    dm = sm_curve_dm_dI(&p->curve, I);
    if (!cfg->load_estimated) {
        theta = load[0] / p->J;
        theta_dot = load[1] / p->J;
    } else {
        const double tm = cfg->theta_max;
        /* min(max(theta_hat, -tm), tm): Python's max/min keep the first argument unless the
         * second compares greater/smaller (so a NaN passes through) */
        theta = theta_hat;
        if (-tm > theta) theta = -tm;
        if (tm < theta) theta = tm;
        theta_dot = 0.0;
        adapt[0] = cfg->g_theta;
        adapt[1] = tm;
    }
    sm_model_constants_of(p, &c);
    core(&c, g, cfg->phi_min, ms.Phi_rd, ms.i_mu_d, ms.i_mu_q, w, ms.m, dm, I, ref, theta, theta_dot,
         cfg->load_estimated ? adapt : NULL, e0, z0, i_max, &es);
    L11 = es.Lambda[0][0];
    L12 = es.Lambda[0][1];
    L21 = es.Lambda[1][0];
    L22 = es.Lambda[1][1];
    W = L11 * L22 - L12 * L21;
    if (es.singular_limited) {
        double fl = SM_W_REL_FLOOR * (fabs(L11 * L22) + fabs(L12 * L21));
        if (1e-300 > fl) fl = 1e-300; /* max(fl, 1e-300) */
        if (!(fabs(W) > fl)) W = (W == W) ? copysign(fl, W) : fl;
    }
    q1 = -g->c2 * es.e2 - es.beta1 - (es.flux_limited ? 0.0 : es.e1);
    q2 = -g->d2 * es.z2 - es.beta2 - (es.torque_limited ? 0.0 : es.z1);
    vd = (L22 * q1 - L12 * q2) / W;
    vq = (L11 * q2 - L21 * q1) / W;
    rho_out = ms.rho + 0.5 * es.omega_s * cfg->Ts;
    cr = cos(rho_out);
    sr = sin(rho_out);
    vlim = sm_voltage_limit(&vd, &vq, cr, sr, cfg->V_dc, cfg->overmodulation);
    V = 0.5 * (es.e1 * es.e1 + es.e2 * es.e2 + es.z1 * es.z1 + es.z2 * es.z2 + g->c0 * e0 * e0
               + g->d0 * z0 * z0);
    out->v_s_alpha = cr * vd - sr * vq;
    out->v_s_beta = sr * vd + cr * vq;
    out->v_sd = vd;
    out->v_sq = vq;
    out->e1 = es.e1;
    out->e2 = es.e2;
    out->z1 = es.z1;
    out->z2 = es.z2;
    out->V = V;
    out->W = es.W;
    out->m = ms.m;
    out->i_mu = I;
    out->Phi_rd = ms.Phi_rd;
    out->rho = ms.rho;
    out->omega_s = es.omega_s;
    out->theta_hat_dot = (cfg->load_estimated && !vlim) ? es.theta_dot : 0.0; /* frozen at the voltage limit */
    out->voltage_limited = vlim;
    out->singular_limited = es.singular_limited;
    /* anti-windup: an integral state stops while the voltage is limited, or while its virtual
     * control is bounded and integrating would push it further */
    out->e0_dot = (vlim || es.flux_limited * es.e1 < 0.0) ? 0.0 : es.e1;
    out->z0_dot = (vlim || es.torque_limited * es.z1 < 0.0) ? 0.0 : es.z1;
    out->current_limited = es.flux_limited != 0 || es.torque_limited != 0;
    finite = st == SM_CORE_OK && isfinite(w) && all_finite(ref, 6) && isfinite(e0) && isfinite(z0)
             && (cfg->load_estimated ? isfinite(theta_hat) : (isfinite(load[0]) && isfinite(load[1])));
    return finite ? SM_CORE_OK : SM_ERR_NONFINITE;
}

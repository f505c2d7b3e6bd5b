/* satmotor/machine/plant.py, satmotor/machine/integrate.py and the PlantUnit checks of satmotor/interface.py. */
#include "sm_plant.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static int all_finite(const double *v, int n)
{
    int i;
    for (i = 0; i < n; ++i)
        if (!isfinite(v[i])) return 0;
    return 1;
}

/* thermal.resistance: R (1 + alpha (T - T_ref)) */
static double resistance(double R, double alpha, double T, double T_ref)
{
    return R * (1.0 + alpha * (T - T_ref));
}

/* ThermalParams.__post_init__ (the Boolean thermal needs no check: an int, != 0 is true) */
static int thermal_check(const sm_plant_params *pp, char *msg, size_t msg_len)
{
    const char *pos[] = {"T_amb", "T_s0", "T_r0", "T_ref", "C_th_s", "C_th_r", "R_th_s", "R_th_r", "R_th_sr"};
    const double pv[] = {pp->T_amb, pp->T_s0, pp->T_r0, pp->T_ref, pp->C_th_s, pp->C_th_r,
                         pp->R_th_s, pp->R_th_r, pp->R_th_sr};
    char v[40];
    int i;
    for (i = 0; i < 9; ++i)
        if (sm_require_number(pos[i], pv[i], 1, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("alpha_s", pp->alpha_s, 1, 0.0, 1, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("alpha_r", pp->alpha_r, 1, 0.0, 1, msg, msg_len)) return SM_ERR_PARAM;
    if (!(1.0 + pp->alpha_s * (pp->T_s0 - pp->T_ref) > 0.0))
        return sm_param_error(msg, msg_len, NULL, "T_s0", sm_repr_double(pp->T_s0, v, sizeof v),
                              "gives a resistance <= 0 (1 + alpha (T - T_ref) <= 0)");
    if (!(1.0 + pp->alpha_r * (pp->T_r0 - pp->T_ref) > 0.0))
        return sm_param_error(msg, msg_len, NULL, "T_r0", sm_repr_double(pp->T_r0, v, sizeof v),
                              "gives a resistance <= 0 (1 + alpha (T - T_ref) <= 0)");
    return SM_CORE_OK;
}

int sm_motor_init(sm_motor *p, const sm_motor_params *m, const sm_plant_params *pp, char *msg, size_t msg_len)
{
    sm_motor q;
    sm_plant_params dflt;
    int st, i;
    const char *names[] = {"R_s", "R_r", "l_s", "l_r", "k"};
    double vals[5];
    if (msg != NULL && msg_len > 0) msg[0] = '\0';
    if (p == NULL || m == NULL) {
        if (msg != NULL && msg_len > 0) snprintf(msg, msg_len, "sm_motor_init: NULL motor or parameters");
        return SM_ERR_ARG;
    }
    if (pp == NULL) { /* the controller's model of the motor: the plant-only parameters' defaults */
        sm_plant_params_default(&dflt);
        pp = &dflt;
    }
    /* interface._number over MOTOR_PARAMETERS (Real: finite; Integer: any int) */
    if (sm_motor_params_require_finite(m, msg, msg_len)) return SM_ERR_PARAM;
    /* make_curve */
    memset(&q, 0, sizeof q);
    st = sm_curve_init(&q.curve, m->curve, m->L_m0, m->L_m_inf, m->I_par, m->poly_b, m->poly_n, m->table_file, msg,
                       msg_len);
    if (st) return st;
    /* MotorParams.__post_init__ */
    vals[0] = m->R_s;
    vals[1] = m->R_r;
    vals[2] = m->l_s;
    vals[3] = m->l_r;
    vals[4] = m->k;
    for (i = 0; i < 5; ++i) /* l_s = 0 (i == 2): the Gamma-equivalent model */
        if (sm_require_number(names[i], vals[i], 1, 0.0, i == 2, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("J", m->J, 1, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_integer("n_p", m->n_p, 1, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("B", m->B, 1, 0.0, 1, msg, msg_len)) return SM_ERR_PARAM;
    /* PlantUnit: _number of the plant's own Real parameters, then the bounds */
    if (sm_plant_params_require_finite(pp, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("psi_r0", pp->psi_r0, 1, 0.0, 1, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("h_int", pp->h_int, 1, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
    /* the unit's step limit and plausibility bounds (sm_plant_unit.c uses them) */
    if (sm_require_integer("max_substeps", pp->max_substeps, 1, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("v_warn", pp->v_warn, 1, 0.0, 1, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("i_warn", pp->i_warn, 1, 0.0, 1, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("omega_warn", pp->omega_warn, 1, 0.0, 1, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("B_2", pp->B_2, 1, 0.0, 1, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("R_fe", pp->R_fe, 1, 0.0, 1, msg, msg_len)) return SM_ERR_PARAM;
    if ((st = thermal_check(pp, msg, msg_len)) != SM_CORE_OK) return st;
    if ((st = sm_losses_init(&q.lp, pp, msg, msg_len)) != SM_CORE_OK) return st; /* LossParams */
    /* thermal off: the resistances at T_s0, T_r0 (T_s0 = T_ref: exactly R_s, R_s * 1.0) */
    q.R_s = resistance(m->R_s, pp->alpha_s, pp->T_s0, pp->T_ref);
    q.R_r = resistance(m->R_r, pp->alpha_r, pp->T_r0, pp->T_ref);
    q.R_s_ref = m->R_s;
    q.R_r_ref = m->R_r;
    q.R_fe = pp->R_fe;
    q.T_amb = pp->T_amb;
    q.T_s0 = pp->T_s0;
    q.T_r0 = pp->T_r0;
    q.T_ref = pp->T_ref;
    q.alpha_s = pp->alpha_s;
    q.alpha_r = pp->alpha_r;
    q.C_th_s = pp->C_th_s;
    q.C_th_r = pp->C_th_r;
    q.R_th_s = pp->R_th_s;
    q.R_th_r = pp->R_th_r;
    q.R_th_sr = pp->R_th_sr;
    q.thermal = pp->thermal != 0;
    q.ext = q.R_fe > 0.0 || q.thermal;
    q.n_states = q.thermal ? SM_N_STATES_MAX : SM_N_STATES;
    q.l_s = m->l_s;
    q.l_r = m->l_r;
    q.k = m->k;
    q.n_p = m->n_p;
    q.J = m->J;
    q.B = m->B;
    q.B_2 = pp->B_2;
    /* Plant.__init__ */
    q.gamma = q.l_s == 0.0;
    q.inv_ls = q.gamma ? 0.0 : 1.0 / q.l_s;
    q.k_lr = q.k / q.l_r;
    q.le = q.gamma ? 0.0 : 1.0 / (1.0 / q.l_s + q.k * q.k / q.l_r); /* MotorParams.l_e */
    q.kappa = 1.5 * (double)q.n_p;
    q.inv_J = 1.0 / q.J;
    q.m0 = q.curve.m0;
    q.omega_m0 = pp->omega_m0;
    q.psi_r0 = pp->psi_r0;
    q.h_int = pp->h_int;
    st = sm_plant_initial_state(&q, q.omega_m0, 0.0, q.psi_r0, 0.0, q.x0);
    q.x0[SM_T_S] = q.T_s0; /* Plant.thermal_state (read only with the thermal model on) */
    q.x0[SM_T_R] = q.T_r0;
    if (st) {
        if (msg != NULL && msg_len > 0)
            snprintf(msg, msg_len, "the initial state (psi_r0 = %.17g Wb) could not be solved", q.psi_r0);
        return st;
    }
    memcpy(p, &q, sizeof q);
    return SM_CORE_OK;
}

void sm_solve_memo_clear(sm_solve_memo *memo)
{
    if (memo != NULL) memo->a = memo->c = memo->I = memo->psi = NAN;
}

/* curve.solve(a, cc, guess) with guess = *warm (NULL: 0.0, cold), the root left in *warm (Plant.derivatives'
 * warm list); a cold solve whose (a, cc) is the memo's returns the memo's root, and a cold solve is kept
 * in the memo: the same arguments give the same root, so the memo changes no result. */
static int plant_solve(const sm_motor *p, double a, double cc, double *warm, sm_solve_memo *memo, double *I,
                       double *psi)
{
    double guess = warm != NULL ? *warm : 0.0;
    int st;
    if (memo != NULL && guess == 0.0 && a == memo->a && cc == memo->c) {
        *I = memo->I;
        *psi = memo->psi;
    } else {
        st = sm_curve_solve_from(&p->curve, a, cc, guess, I, psi);
        if (st) return st;
        if (memo != NULL && guess == 0.0) {
            memo->a = a;
            memo->c = cc;
            memo->I = *I;
            memo->psi = *psi;
        }
    }
    if (warm != NULL) *warm = *I;
    return SM_CORE_OK;
}

/* Plant._magnetizing_gamma (l_s = 0): i_mu along psi_s, psi_m(I) = |psi_s| */
static int magnetizing_gamma(const sm_motor *p, double psa, double psb, double *warm, sm_solve_memo *memo,
                             double *ima, double *imb, double *I_out, double *psi_out, double *m_out)
{
    double pn = sm_hypot(psa, psb), I, psi, s;
    int st = plant_solve(p, 0.0, pn, warm, memo, &I, &psi);
    if (st) return st;
    if (I == 0.0) {
        *ima = 0.0;
        *imb = 0.0;
        *I_out = 0.0;
        *psi_out = 0.0;
        *m_out = p->m0;
        return SM_CORE_OK;
    }
    s = I / pn;
    *ima = s * psa;
    *imb = s * psb;
    *I_out = I;
    *psi_out = psi;
    *m_out = psi / I;
    return SM_CORE_OK;
}

/* Plant._currents_gamma: i_r = (psi_r - k psi_s) / l_r, i_s = i_mu - k i_r */
static void currents_gamma(const sm_motor *p, double psa, double psb, double pra, double prb, double ima,
                           double imb, double *isa, double *isb, double *ira, double *irb)
{
    *ira = (pra - p->k * psa) / p->l_r;
    *irb = (prb - p->k * psb) / p->l_r;
    *isa = ima - p->k * *ira;
    *isb = imb - p->k * *irb;
}

/* Plant.magnetizing: (i_mu_alpha, i_mu_beta, I, psi_m, m); warm, memo: plant_solve's */
static int magnetizing(const sm_motor *p, double psa, double psb, double pra, double prb, double *warm,
                       sm_solve_memo *memo, double *ima, double *imb, double *I_out, double *psi_out, double *m_out)
{
    double ua, ub, un, le = p->le, I, psi, s;
    int st;
    if (p->gamma) return magnetizing_gamma(p, psa, psb, warm, memo, ima, imb, I_out, psi_out, m_out);
    ua = psa * p->inv_ls + p->k_lr * pra;
    ub = psb * p->inv_ls + p->k_lr * prb;
    un = sm_hypot(ua, ub);
    st = plant_solve(p, le, le * un, warm, memo, &I, &psi);
    if (st) return st;
    if (I == 0.0) {
        *ima = 0.0;
        *imb = 0.0;
        *I_out = 0.0;
        *psi_out = 0.0;
        *m_out = p->m0;
        return SM_CORE_OK;
    }
    s = I / un;
    *ima = s * ua;
    *imb = s * ub;
    *I_out = I;
    *psi_out = psi;
    *m_out = psi / I;
    return SM_CORE_OK;
}

/* Plant.currents: i_s0 (through the leakage), i_r, i_mu, I, psi_m, m from the fluxes */
static int currents(const sm_motor *p, const double *x, double *warm, sm_solve_memo *memo, double c[9])
{
    double psa = x[SM_PSI_S_A], psb = x[SM_PSI_S_B], pra = x[SM_PSI_R_A], prb = x[SM_PSI_R_B], km;
    int st = magnetizing(p, psa, psb, pra, prb, warm, memo, &c[4], &c[5], &c[6], &c[7], &c[8]);
    if (st) return st;
    if (p->gamma) {
        currents_gamma(p, psa, psb, pra, prb, c[4], c[5], &c[0], &c[1], &c[2], &c[3]);
    } else {
        km = p->k * c[8];
        c[0] = (psa - c[8] * c[4]) * p->inv_ls;
        c[1] = (psb - c[8] * c[5]) * p->inv_ls;
        c[2] = (pra - km * c[4]) / p->l_r;
        c[3] = (prb - km * c[5]) / p->l_r;
    }
    return SM_CORE_OK;
}

/* Plant._ext_terms: the currents, R_s, R_r at x's temperatures, e_s = d psi_s/dt, i_fe */
typedef struct {
    double c[9], Rs, Rr, ea, eb, fa, fb;
} ext_terms;

static int ext_terms_of(const sm_motor *p, const double *x, double v_a, double v_b, double *warm,
                        sm_solve_memo *memo, ext_terms *e)
{
    double ua, ub, g;
    int st = currents(p, x, warm, memo, e->c);
    if (st) return st;
    if (p->thermal) {
        e->Rs = resistance(p->R_s_ref, p->alpha_s, x[SM_T_S], p->T_ref);
        e->Rr = resistance(p->R_r_ref, p->alpha_r, x[SM_T_R], p->T_ref);
    } else {
        e->Rs = p->R_s;
        e->Rr = p->R_r;
    }
    ua = v_a - e->Rs * e->c[0];
    ub = v_b - e->Rs * e->c[1];
    if (p->R_fe > 0.0) {
        g = 1.0 / (p->R_fe + e->Rs);
        e->fa = ua * g;
        e->fb = ub * g;
        e->ea = p->R_fe * e->fa;
        e->eb = p->R_fe * e->fb;
    } else {
        e->ea = ua;
        e->eb = ub;
        e->fa = 0.0;
        e->fb = 0.0;
    }
    return SM_CORE_OK;
}

/* Plant._derivatives_ext: core loss and/or the thermal model */
static int derivatives_ext(const sm_motor *p, const double *x, double v_a, double v_b, double T_load, double *dx,
                           double *warm, sm_solve_memo *memo)
{
    ext_terms e;
    double w = x[SM_OMEGA_M], we, te, Ts, Tr, ta, tb, p_s, p_r, q_sr;
    int st = ext_terms_of(p, x, v_a, v_b, warm, memo, &e), i;
    if (st) {
        for (i = 0; i < p->n_states; ++i) dx[i] = NAN;
        return st;
    }
    we = (double)p->n_p * w;
    te = p->kappa * (x[SM_PSI_S_A] * e.c[1] - x[SM_PSI_S_B] * e.c[0]);
    if (p->lp.mechanical) T_load = T_load + sm_loss_torque(&p->lp, w, e.c[0] * e.c[0] + e.c[1] * e.c[1]);
    dx[0] = e.ea;
    dx[1] = e.eb;
    dx[2] = -e.Rr * e.c[2] - we * x[SM_PSI_R_B];
    dx[3] = -e.Rr * e.c[3] + we * x[SM_PSI_R_A];
    dx[4] = (te - T_load - (p->B + p->B_2 * fabs(w)) * w) * p->inv_J;
    dx[5] = w;
    if (p->thermal) {
        Ts = x[SM_T_S];
        Tr = x[SM_T_R];
        ta = e.c[0] + e.fa;
        tb = e.c[1] + e.fb;
        p_s = 1.5 * e.Rs * (ta * ta + tb * tb) + (1.5 * (e.ea * e.fa + e.eb * e.fb));
        p_r = 1.5 * e.Rr * (e.c[2] * e.c[2] + e.c[3] * e.c[3]);
        q_sr = (Ts - Tr) / p->R_th_sr;
        dx[SM_T_S] = (p_s - (Ts - p->T_amb) / p->R_th_s - q_sr) / p->C_th_s;
        dx[SM_T_R] = (p_r - (Tr - p->T_amb) / p->R_th_r + q_sr) / p->C_th_r;
    }
    return all_finite(dx, p->n_states) ? SM_CORE_OK : SM_ERR_NONFINITE;
}

int sm_plant_derivatives(const sm_motor *p, const double *x, double v_a, double v_b, double T_load,
                         double *dx)
{
    return sm_plant_derivatives_from(p, x, v_a, v_b, T_load, dx, NULL, NULL);
}

int sm_plant_derivatives_from(const sm_motor *p, const double *x, double v_a, double v_b, double T_load,
                              double *dx, double *warm, sm_solve_memo *memo)
{
    double psa, psb, pra, prb, w, ima, imb, I, psi, m, isa, isb, km, ira, irb, we, te;
    int st, i;
    if (p == NULL || x == NULL || dx == NULL) return SM_ERR_ARG;
    if (!all_finite(x, p->n_states) || !isfinite(v_a) || !isfinite(v_b) || !isfinite(T_load)) {
        for (i = 0; i < p->n_states; ++i) dx[i] = NAN;
        return SM_ERR_NONFINITE;
    }
    if (p->ext) return derivatives_ext(p, x, v_a, v_b, T_load, dx, warm, memo);
    psa = x[SM_PSI_S_A];
    psb = x[SM_PSI_S_B];
    pra = x[SM_PSI_R_A];
    prb = x[SM_PSI_R_B];
    w = x[SM_OMEGA_M];
    st = magnetizing(p, psa, psb, pra, prb, warm, memo, &ima, &imb, &I, &psi, &m);
    if (st) {
        for (i = 0; i < 6; ++i) dx[i] = NAN;
        return st;
    }
    if (p->gamma) {
        currents_gamma(p, psa, psb, pra, prb, ima, imb, &isa, &isb, &ira, &irb);
    } else {
        isa = (psa - m * ima) * p->inv_ls;
        isb = (psb - m * imb) * p->inv_ls;
        km = p->k * m;
        ira = (pra - km * ima) / p->l_r;
        irb = (prb - km * imb) / p->l_r;
    }
    we = (double)p->n_p * w;
    te = p->kappa * (psa * isb - psb * isa);
    if (p->lp.mechanical) T_load = T_load + sm_loss_torque(&p->lp, w, isa * isa + isb * isb);
    dx[0] = v_a - p->R_s * isa;
    dx[1] = v_b - p->R_s * isb;
    dx[2] = -p->R_r * ira - we * prb;
    dx[3] = -p->R_r * irb + we * pra;
    dx[4] = (te - T_load - (p->B + p->B_2 * fabs(w)) * w) * p->inv_J;
    dx[5] = w;
    return all_finite(dx, 6) ? SM_CORE_OK : SM_ERR_NONFINITE;
}

static void outputs_nan(sm_plant_outputs *o)
{
    o->i_s_alpha = o->i_s_beta = o->i_r_alpha = o->i_r_beta = NAN;
    o->i_mu_alpha = o->i_mu_beta = o->i_mu = o->psi_m = o->m = o->T_e = NAN;
    o->P_fe = o->T_s = o->T_r = NAN;
}

int sm_plant_outputs_of(const sm_motor *p, const double *x, sm_plant_outputs *o)
{
    return sm_plant_outputs_v(p, x, 0.0, 0.0, o);
}

int sm_plant_outputs_v(const sm_motor *p, const double *x, double v_a, double v_b, sm_plant_outputs *o)
{
    return sm_plant_outputs_memo(p, NULL, x, v_a, v_b, o);
}

int sm_plant_outputs_memo(const sm_motor *p, sm_solve_memo *memo, const double *x, double v_a, double v_b,
                          sm_plant_outputs *o)
{
    double psa, psb, pra, prb, ima, imb, I, psi, m, isa, isb, km;
    ext_terms e;
    int st;
    if (p == NULL || x == NULL || o == NULL) return SM_ERR_ARG;
    if (!all_finite(x, p->n_states) || (p->ext && (!isfinite(v_a) || !isfinite(v_b)))) {
        outputs_nan(o);
        return SM_ERR_NONFINITE;
    }
    if (p->ext) { /* Plant.outputs, the general path */
        if ((st = ext_terms_of(p, x, v_a, v_b, NULL, memo, &e)) != SM_CORE_OK) {
            outputs_nan(o);
            return st;
        }
        o->i_s_alpha = e.c[0] + e.fa;
        o->i_s_beta = e.c[1] + e.fb;
        o->i_r_alpha = e.c[2];
        o->i_r_beta = e.c[3];
        o->i_mu_alpha = e.c[4];
        o->i_mu_beta = e.c[5];
        o->i_mu = e.c[6];
        o->psi_m = e.c[7];
        o->m = e.c[8];
        o->T_e = p->kappa * (x[SM_PSI_S_A] * e.c[1] - x[SM_PSI_S_B] * e.c[0]);
        o->P_fe = 1.5 * (e.ea * e.fa + e.eb * e.fb);
        o->T_s = p->thermal ? x[SM_T_S] : p->T_s0;
        o->T_r = p->thermal ? x[SM_T_R] : p->T_r0;
        return SM_CORE_OK;
    }
    o->P_fe = 0.0;
    o->T_s = p->T_s0;
    o->T_r = p->T_r0;
    psa = x[SM_PSI_S_A];
    psb = x[SM_PSI_S_B];
    pra = x[SM_PSI_R_A];
    prb = x[SM_PSI_R_B];
    st = magnetizing(p, psa, psb, pra, prb, NULL, memo, &ima, &imb, &I, &psi, &m);
    if (st) {
        outputs_nan(o);
        return st;
    }
    if (p->gamma) {
        currents_gamma(p, psa, psb, pra, prb, ima, imb, &isa, &isb, &o->i_r_alpha, &o->i_r_beta);
    } else {
        isa = (psa - m * ima) * p->inv_ls;
        isb = (psb - m * imb) * p->inv_ls;
        km = p->k * m;
        o->i_r_alpha = (pra - km * ima) / p->l_r;
        o->i_r_beta = (prb - km * imb) / p->l_r;
    }
    o->i_s_alpha = isa;
    o->i_s_beta = isb;
    o->i_mu_alpha = ima;
    o->i_mu_beta = imb;
    o->i_mu = I;
    o->psi_m = psi;
    o->m = m;
    o->T_e = p->kappa * (psa * isb - psb * isa);
    return SM_CORE_OK;
}

double sm_plant_stator_resistance(const sm_motor *p, const double *x)
{
    return p->thermal ? resistance(p->R_s_ref, p->alpha_s, x[SM_T_S], p->T_ref) : p->R_s;
}

int sm_plant_powers(const sm_motor *p, sm_solve_memo *memo, const double *x, const sm_plant_outputs *o,
                    double T_load, double out[6])
{
    double Rs, Rr, isa = o->i_s_alpha, isb = o->i_s_beta, ira = o->i_r_alpha, irb = o->i_r_beta, w, p_stray = 0.0;
    if (p->thermal) {
        Rs = resistance(p->R_s_ref, p->alpha_s, x[SM_T_S], p->T_ref);
        Rr = resistance(p->R_r_ref, p->alpha_r, x[SM_T_R], p->T_ref);
    } else {
        Rs = p->R_s;
        Rr = p->R_r;
    }
    w = x[SM_OMEGA_M];
    if (p->lp.k_stray > 0.0) {
        if (p->R_fe > 0.0) { /* the current through the leakage, as the torque takes it */
            double c[9];
            int st = currents(p, x, NULL, memo, c);
            if (st) return st;
            isa = c[0];
            isb = c[1];
        }
        p_stray = p->lp.k_stray * (isa * isa + isb * isb) * w * w;
        isa = o->i_s_alpha;
        isb = o->i_s_beta;
    }
    out[0] = 1.5 * Rs * (isa * isa + isb * isb);
    out[1] = 1.5 * Rr * (ira * ira + irb * irb);
    out[2] = o->P_fe;
    out[3] = (p->B * w + sm_friction_torque(&p->lp, w)) * w;
    out[4] = p_stray;
    out[5] = (T_load + p->B_2 * fabs(w) * w) * w;
    return SM_CORE_OK;
}

int sm_plant_step(const sm_motor *p, double *x, double v_a, double v_b, double T_load, double dt,
                  int n_sub)
{
    return sm_plant_step_memo(p, NULL, x, v_a, v_b, T_load, dt, n_sub);
}

/* integrate.rk4 with Plant.step's warm list: reset to 0.0 (cold) at each sub-step's first stage */
int sm_plant_step_memo(const sm_motor *p, sm_solve_memo *memo, double *x, double v_a, double v_b,
                       double T_load, double dt, int n_sub)
{
    double xc[SM_N_STATES_MAX], xt[SM_N_STATES_MAX], k1[SM_N_STATES_MAX], k2[SM_N_STATES_MAX],
        k3[SM_N_STATES_MAX], k4[SM_N_STATES_MAX], h, half, sixth, warm;
    int j, i, st, n;
    if (p == NULL || x == NULL || n_sub < 1) return SM_ERR_ARG;
    n = p->n_states;
    if (!isfinite(dt)) return SM_ERR_NONFINITE;
    h = dt / (double)n_sub;
    half = 0.5 * h;
    sixth = h / 6.0;
    memcpy(xc, x, (size_t)n * sizeof xc[0]);
    for (j = 0; j < n_sub; ++j) {
        warm = 0.0;
        if ((st = sm_plant_derivatives_from(p, xc, v_a, v_b, T_load, k1, &warm, memo)) != SM_CORE_OK) return st;
        for (i = 0; i < n; ++i) xt[i] = xc[i] + half * k1[i];
        if ((st = sm_plant_derivatives_from(p, xt, v_a, v_b, T_load, k2, &warm, memo)) != SM_CORE_OK) return st;
        for (i = 0; i < n; ++i) xt[i] = xc[i] + half * k2[i];
        if ((st = sm_plant_derivatives_from(p, xt, v_a, v_b, T_load, k3, &warm, memo)) != SM_CORE_OK) return st;
        for (i = 0; i < n; ++i) xt[i] = xc[i] + h * k3[i];
        if ((st = sm_plant_derivatives_from(p, xt, v_a, v_b, T_load, k4, &warm, memo)) != SM_CORE_OK) return st;
        for (i = 0; i < n; ++i) xc[i] = xc[i] + sixth * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    if (!all_finite(xc, n)) return SM_ERR_NONFINITE;
    memcpy(x, xc, (size_t)n * sizeof xc[0]);
    return SM_CORE_OK;
}

int sm_plant_initial_state(const sm_motor *p, double omega_m, double theta_m, double psi_r_alpha,
                           double psi_r_beta, double x[6])
{
    double phi, I, m, ca, sb;
    int st, i;
    if (p == NULL || x == NULL) return SM_ERR_ARG;
    if (!isfinite(omega_m) || !isfinite(theta_m) || !isfinite(psi_r_alpha) || !isfinite(psi_r_beta))
        return SM_ERR_NONFINITE;
    phi = sm_hypot(psi_r_alpha, psi_r_beta);
    for (i = 0; i < 6; ++i) x[i] = 0.0;
    x[SM_OMEGA_M] = omega_m;
    x[SM_THETA_M] = theta_m;
    if (phi == 0.0) return SM_CORE_OK;
    st = sm_curve_current(&p->curve, phi / p->k, &I);
    if (st) return st;
    m = sm_curve_m(&p->curve, I);
    ca = psi_r_alpha / phi;
    sb = psi_r_beta / phi;
    x[SM_PSI_S_A] = (p->l_s + m) * I * ca;
    x[SM_PSI_S_B] = (p->l_s + m) * I * sb;
    x[SM_PSI_R_A] = psi_r_alpha;
    x[SM_PSI_R_B] = psi_r_beta;
    return SM_CORE_OK;
}

int sm_plant_check_step(const sm_motor *p, double v_a, double v_b, double T_load, double dt,
                        int *n_sub, char *msg, size_t msg_len)
{
    double q;
    if (p == NULL || n_sub == NULL) return SM_ERR_ARG;
    if (sm_require_number("v_s_alpha", v_a, 0, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("v_s_beta", v_b, 0, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("T_load", T_load, 0, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("communicationStepSize", dt, 1, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
    q = ceil(dt / p->h_int - 1e-9);
    if (!(q < 2147483647.0)) {
        char v[40];
        return sm_param_error(msg, msg_len, NULL, "communicationStepSize", sm_repr_double(dt, v, sizeof v),
                              "needs more than 2**31 sub-steps of h_int");
    }
    *n_sub = q > 1.0 ? (int)q : 1;
    return SM_CORE_OK;
}

void sm_plant_nonfinite_message(double t, double dt, const double x[6], char *msg, size_t msg_len)
{
    char a[40], b[40], v[6][40];
    int i;
    if (msg == NULL || msg_len == 0) return;
    for (i = 0; i < 6; ++i) sm_repr_double(x != NULL ? x[i] : NAN, v[i], sizeof v[i]);
    snprintf(msg, msg_len, "the plant state became non-finite over [%s, %s] s: (%s, %s, %s, %s, %s, %s)",
             sm_repr_double(t, a, sizeof a), sm_repr_double(t + dt, b, sizeof b), v[0], v[1], v[2], v[3],
             v[4], v[5]);
}

size_t sm_motor_size(void)
{
    return sizeof(sm_motor);
}

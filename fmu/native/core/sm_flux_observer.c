/* satmotor/estimation/flux_observer.py in C: the same operations in the same order (see sm_flux_observer.h). */
#include "sm_flux_observer.h"

#include <math.h>
#include <stdio.h>

#include "sm_common.h"

static const double PSI_ADAPT_MIN = 0.2;         /* flux_observer.PSI_ADAPT_MIN [Wb] */
static const double POLE_FACTOR_MEASURED = 1.0;  /* flux_observer.POLE_FACTOR_MEASURED [1] */
static const double POLE_FACTOR_ESTIMATED = 3.0; /* flux_observer.POLE_FACTOR_ESTIMATED [1] */
static const double RS_RATE = 20.0;              /* resistance.RS_RATE [1/s] */
static const double I_ADAPT_MIN = 0.5;           /* resistance.I_ADAPT_MIN [A] */
static const double RS_MIN = 0.5, RS_MAX = 2.0;  /* resistance.RS_MIN, RS_MAX [1] */
static const double LOAD_MIN = 0.5;              /* resistance.LOAD_MIN [1] */
#define ALPHA_RATIO (4.03e-3 / 3.93e-3)          /* resistance.ALPHA_RATIO: thermal ALPHA_ALUMINIUM / ALPHA_COPPER */

/* ClosedLoopObserver._set_resistance */
static void set_resistance(sm_cl_observer *o, double R_s_hat)
{
    o->Rs = R_s_hat;
    if (o->track_rr) {
        o->Rr = o->Rr0 * (1.0 + ALPHA_RATIO * (R_s_hat / o->Rs0 - 1.0)); /* resistance.rotor_resistance */
        o->cm.Rr_lr = o->Rr / o->lr;                                     /* RotorFluxObserver.set_rotor_resistance */
    }
}

int sm_cl_observer_set_tracking(sm_cl_observer *o, int adapt_rs, int track_rr, char *msg, size_t msg_len)
{
    if (track_rr && !adapt_rs) {
        if (msg != NULL && msg_len > 0) {
            snprintf(msg, msg_len, "track_rr = True: needs adapt_rs (the temperature comes from R_s_hat)");
        }
        return SM_ERR_PARAM;
    }
    o->adapt_rs = adapt_rs ? 1 : 0;
    o->track_rr = track_rr ? 1 : 0;
    if (o->adapt_rs) {
        set_resistance(o, o->Rs0);
    }
    return SM_CORE_OK;
}

void sm_cl_observer_adapt_resistance(sm_cl_observer *o)
{
    const double *r = o->res;
    double q, x;
    int had = o->has_res;
    o->has_res = 0;
    if (!had || r[6] < PSI_ADAPT_MIN * PSI_ADAPT_MIN) {
        return;
    }
    /* resistance.adapt_stator_resistance(Rs, Rs0, Ts, da, db, pa, pb, ia, ib, n2, estimate_speed) */
    q = r[4] * r[2] + r[5] * r[3];
    if (q <= 0.0 || q * q < I_ADAPT_MIN * I_ADAPT_MIN * r[6]) {
        return;
    }
    if (o->estimate_speed && fabs(r[5] * r[2] - r[4] * r[3]) < LOAD_MIN * q) { /* loaded_only: no load */
        return;
    }
    x = o->Rs + o->Ts * RS_RATE * ((r[0] * r[2] + r[1] * r[3]) / (o->Ts * q));
    x = x < RS_MIN * o->Rs0 ? RS_MIN * o->Rs0 : x; /* max(x, lo) */
    x = x > RS_MAX * o->Rs0 ? RS_MAX * o->Rs0 : x; /* min(x, hi) */
    if (x != o->Rs) {
        set_resistance(o, x);
    }
}

size_t sm_cl_observer_size(void)
{
    return sizeof(sm_cl_observer);
}

int sm_cl_observer_init(sm_cl_observer *o, double R_s, double R_r, double l_s, double l_r, double k, int n_p,
                        double Ts, int estimate_speed, double alpha_w, char *msg, size_t msg_len)
{
    int st;
    if (o == NULL) {
        return SM_ERR_ARG;
    }
    if ((st = sm_observer_init(&o->cm, R_r, l_r, k, n_p, Ts, 1, msg, msg_len)) != SM_CORE_OK) {
        return st;
    }
    if (sm_require_number("alpha_w", alpha_w, 1, 0.0, 0, msg, msg_len) != SM_CORE_OK ||
        sm_require_number("R_s", R_s, 1, 0.0, 0, msg, msg_len) != SM_CORE_OK ||
        sm_require_number("l_s", l_s, 1, 0.0, 1, msg, msg_len) != SM_CORE_OK) { /* l_s = 0: the Gamma form */
        return SM_ERR_PARAM;
    }
    o->Ts = Ts;
    o->alpha_w = alpha_w;
    o->estimate_speed = estimate_speed ? 1 : 0;
    o->pole = o->estimate_speed ? POLE_FACTOR_ESTIMATED : POLE_FACTOR_MEASURED;
    o->k = k;
    o->ls = l_s;
    o->lr = l_r;
    o->Rs = o->Rs0 = R_s;
    o->Rr = o->Rr0 = R_r;
    o->adapt_rs = o->track_rr = 0;
    o->np = (double)n_p;
    o->lr_k = l_r / k;
    o->k_lr = k / l_r;
    o->a_solve = l_r / (k * k);
    return sm_cl_observer_reset(o, 0.0, 0.0, 0.0, msg, msg_len);
}

int sm_cl_observer_reset(sm_cl_observer *o, double psi_r_alpha, double psi_r_beta, double omega_m_hat, char *msg,
                         size_t msg_len)
{
    if (sm_require_number("psi_r_alpha", psi_r_alpha, 0, 0.0, 0, msg, msg_len) != SM_CORE_OK ||
        sm_require_number("psi_r_beta", psi_r_beta, 0, 0.0, 0, msg, msg_len) != SM_CORE_OK ||
        sm_require_number("omega_m_hat", omega_m_hat, 0, 0.0, 0, msg, msg_len) != SM_CORE_OK) {
        return SM_ERR_PARAM;
    }
    o->pa = psi_r_alpha;
    o->pb = psi_r_beta;
    o->w_hat = omega_m_hat;
    o->isa = o->isb = o->w = o->va = o->vb = 0.0;
    o->has_prev = 0;
    o->has_res = 0;
    if (o->adapt_rs) {
        set_resistance(o, o->Rs0);
    }
    return SM_CORE_OK;
}

void sm_cl_observer_applied(sm_cl_observer *o, double v_s_alpha, double v_s_beta)
{
    o->va = v_s_alpha;
    o->vb = v_s_beta;
}

void sm_cl_observer_get_state(const sm_cl_observer *o, double *s)
{
    s[0] = o->pa;
    s[1] = o->pb;
    s[2] = o->isa;
    s[3] = o->isb;
    s[4] = o->w;
    s[5] = o->va;
    s[6] = o->vb;
    s[7] = o->w_hat;
    s[8] = o->has_prev ? 1.0 : 0.0;
    s[9] = o->adapt_rs ? o->Rs : 0.0;
}

void sm_cl_observer_set_state(sm_cl_observer *o, const double *s)
{
    o->pa = s[0];
    o->pb = s[1];
    o->isa = s[2];
    o->isb = s[3];
    o->w = s[4];
    o->va = s[5];
    o->vb = s[6];
    o->w_hat = s[7];
    o->has_prev = s[8] != 0.0;
    if (o->adapt_rs) {
        set_resistance(o, s[9]);
    }
}

/* ClosedLoopObserver._stator_flux */
static int stator_flux(const sm_cl_observer *o, const sm_curve *curve, double pa, double pb, double isa, double isb,
                       double *sa, double *sb, double *I, double *psi)
{
    double wa = isa + o->k_lr * pa;
    double wb = isb + o->k_lr * pb;
    double wn = sm_hypot(wa, wb);
    double a = o->a_solve, q;
    int st = sm_curve_solve(curve, a, a * wn, I, psi);
    if (st != SM_CORE_OK) {
        return st;
    }
    q = wn > 0.0 ? *psi / wn : 0.0;
    *sa = o->ls * isa + q * wa;
    *sb = o->ls * isb + q * wb;
    return SM_CORE_OK;
}

/* ClosedLoopObserver._rotor_flux */
static int rotor_flux(const sm_cl_observer *o, const sm_curve *curve, double sa, double sb, double isa, double isb,
                      double *ra, double *rb)
{
    double ma = sa - o->ls * isa;
    double mb = sb - o->ls * isb;
    double mn = sm_hypot(ma, mb), r = 0.0, I = 0.0;
    if (mn > 0.0) {
        int st = sm_curve_current(curve, mn, &I);
        if (st != SM_CORE_OK) {
            return st;
        }
        r = I / mn;
    }
    *ra = o->k * ma + o->lr_k * (r * ma - isa);
    *rb = o->k * mb + o->lr_k * (r * mb - isb);
    return SM_CORE_OK;
}

int sm_cl_observer_update(sm_cl_observer *o, const sm_curve *curve, double i_s_alpha, double i_s_beta,
                          double omega_m, double *pa_out, double *pb_out, double *w_out)
{
    double w1 = o->estimate_speed ? o->w_hat : omega_m;
    double isa0, isb0, w0, pa, pb, ia, ib, sa, sb, I0 = 0.0, psi0 = 0.0, Ts, va, vb, da, db, m, a, b, wr, den;
    double g_re, g_im, n2;
    int st;
    if (!o->has_prev) {
        o->isa = i_s_alpha;
        o->isb = i_s_beta;
        o->w = w1;
        o->has_prev = 1;
        *pa_out = o->pa;
        *pb_out = o->pb;
        *w_out = o->estimate_speed ? o->w_hat : o->w;
        return SM_CORE_OK;
    }
    isa0 = o->isa;
    isb0 = o->isb;
    w0 = o->estimate_speed ? w1 : o->w;
    pa = o->pa;
    pb = o->pb;
    /* current model: one RK4 step from the estimate */
    o->cm.pa = pa;
    o->cm.pb = pb;
    o->cm.isa = isa0;
    o->cm.isb = isb0;
    o->cm.w = w0;
    o->cm.has_prev = 1;
    if ((st = sm_observer_update(&o->cm, curve, i_s_alpha, i_s_beta, w1, &ia, &ib)) != SM_CORE_OK ||
        (st = stator_flux(o, curve, pa, pb, isa0, isb0, &sa, &sb, &I0, &psi0)) != SM_CORE_OK) {
        return st;
    }
    /* voltage model over the interval, back to psi_r */
    Ts = o->Ts;
    sa += Ts * (o->va - o->Rs * 0.5 * (isa0 + i_s_alpha));
    sb += Ts * (o->vb - o->Rs * 0.5 * (isb0 + i_s_beta));
    if ((st = rotor_flux(o, curve, sa, sb, i_s_alpha, i_s_beta, &va, &vb)) != SM_CORE_OK) {
        return st;
    }
    da = va - ia;
    db = vb - ib;
    /* gain: the error pole at -b = -pole a at every speed */
    m = I0 > 0.0 ? psi0 / I0 : curve->m0;
    a = o->Rr / (o->lr + o->k * o->k * m);
    wr = o->np * 0.5 * (w0 + w1);
    den = a * a + wr * wr;
    b = a + (o->pole - 1.0) * a * (wr * wr / den); /* a at standstill, pole a at speed */
    g_re = ((a - b) * a + wr * wr) / den;
    g_im = -b * wr / den;
    o->pa = ia + g_re * da - g_im * db;
    o->pb = ib + g_im * da + g_re * db;
    n2 = pa * pa + pb * pb;
    if (o->estimate_speed && n2 >= PSI_ADAPT_MIN * PSI_ADAPT_MIN) { /* below: no speed information */
        double eps = (db * pa - da * pb) / (o->np * Ts * n2);
        o->w_hat = w1 + Ts * o->alpha_w * eps;
        w1 = o->w_hat;
    }
    if (o->adapt_rs) { /* this sample's residual, for sm_cl_observer_adapt_resistance */
        o->res[0] = da;
        o->res[1] = db;
        o->res[2] = pa;
        o->res[3] = pb;
        o->res[4] = 0.5 * (isa0 + i_s_alpha);
        o->res[5] = 0.5 * (isb0 + i_s_beta);
        o->res[6] = n2;
        o->has_res = 1;
    }
    o->isa = i_s_alpha;
    o->isb = i_s_beta;
    o->w = w1;
    *pa_out = o->pa;
    *pb_out = o->pb;
    *w_out = o->estimate_speed ? o->w_hat : o->w;
    return SM_CORE_OK;
}

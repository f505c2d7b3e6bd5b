/* satmotor/estimation/observer.py in C: the same operations in the same order (see sm_observer.h). */
#include "sm_observer.h"

#include <math.h>

#include "sm_common.h"

size_t sm_observer_size(void)
{
    return sizeof(sm_observer);
}

int sm_observer_init(sm_observer *o, double R_r, double l_r, double k, int n_p, double Ts, int n_sub,
                     char *msg, size_t msg_len)
{
    if (o == NULL) {
        return SM_ERR_ARG;
    }
    if (sm_require_number("Ts", Ts, 1, 0.0, 0, msg, msg_len) != SM_CORE_OK ||
        sm_require_integer("n_sub", n_sub, 1, msg, msg_len) != SM_CORE_OK ||
        sm_require_number("R_r", R_r, 1, 0.0, 0, msg, msg_len) != SM_CORE_OK ||
        sm_require_number("l_r", l_r, 1, 0.0, 0, msg, msg_len) != SM_CORE_OK ||
        sm_require_number("k", k, 1, 0.0, 0, msg, msg_len) != SM_CORE_OK ||
        sm_require_integer("n_p", n_p, 1, msg, msg_len) != SM_CORE_OK) {
        return SM_ERR_PARAM;
    }
    o->Ts = Ts;
    o->n_sub = n_sub;
    o->k = k;
    o->k_lr = k / l_r;
    o->a = l_r / (k * k);
    o->Rr_lr = R_r / l_r;
    o->np = (double)n_p;
    return sm_observer_reset(o, 0.0, 0.0, msg, msg_len);
}

int sm_observer_reset(sm_observer *o, double psi_r_alpha, double psi_r_beta, char *msg, size_t msg_len)
{
    if (sm_require_number("psi_r_alpha", psi_r_alpha, 0, 0.0, 0, msg, msg_len) != SM_CORE_OK ||
        sm_require_number("psi_r_beta", psi_r_beta, 0, 0.0, 0, msg, msg_len) != SM_CORE_OK) {
        return SM_ERR_PARAM;
    }
    o->pa = psi_r_alpha;
    o->pb = psi_r_beta;
    o->isa = o->isb = o->w = 0.0;
    o->has_prev = 0;
    return SM_CORE_OK;
}

/* phi' = R(-theta)(-R_r i_r) at phi = (fa, fb), cos/sin theta = (c, s), i_s = (isa, isb) */
static int rhs(const sm_observer *o, const sm_curve *curve, double c, double s, double fa, double fb,
               double isa, double isb, double *da, double *db)
{
    double pa = c * fa - s * fb;
    double pb = s * fa + c * fb;
    double wa = isa + o->k_lr * pa;
    double wb = isb + o->k_lr * pb;
    double wn = sm_hypot(wa, wb);
    double a = o->a, I = 0.0, psi = 0.0, q, ga, gb;
    int status = sm_curve_solve(curve, a, a * wn, &I, &psi);
    if (status != SM_CORE_OK) {
        return status;
    }
    q = wn > 0.0 ? o->k * psi / wn : 0.0;
    ga = -o->Rr_lr * (pa - q * wa);
    gb = -o->Rr_lr * (pb - q * wb);
    *da = c * ga + s * gb;
    *db = c * gb - s * ga;
    return SM_CORE_OK;
}

int sm_observer_update(sm_observer *o, const sm_curve *curve, double i_s_alpha, double i_s_beta,
                       double omega_m, double *pa, double *pb)
{
    double Ts, h, hh, isa0, isb0, w0, dia, dib, th1, th2, fa, fb, c0, s0, t0;
    int n, j, st;
    if (!o->has_prev) {
        o->isa = i_s_alpha;
        o->isb = i_s_beta;
        o->w = omega_m;
        o->has_prev = 1;
        *pa = o->pa;
        *pb = o->pb;
        return SM_CORE_OK;
    }
    Ts = o->Ts;
    n = o->n_sub;
    isa0 = o->isa;
    isb0 = o->isb;
    w0 = o->w;
    dia = (i_s_alpha - isa0) / Ts;
    dib = (i_s_beta - isb0) / Ts;
    th1 = o->np * w0;
    th2 = 0.5 * o->np * (omega_m - w0) / Ts;
    h = Ts / (double)n;
    hh = 0.5 * h;
    fa = o->pa;
    fb = o->pb;
    c0 = 1.0;
    s0 = 0.0;
    t0 = 0.0;
    for (j = 0; j < n; ++j) {
        double tm = ((double)j + 0.5) * h;
        double t1 = (double)(j + 1) * h;
        double thm = (th1 + th2 * tm) * tm;
        double th = (th1 + th2 * t1) * t1;
        double cm = cos(thm), sm = sin(thm), c1 = cos(th), s1 = sin(th);
        double iam = isa0 + dia * tm, ibm = isb0 + dib * tm;
        double k1a, k1b, k2a, k2b, k3a, k3b, k4a, k4b;
        if ((st = rhs(o, curve, c0, s0, fa, fb, isa0 + dia * t0, isb0 + dib * t0, &k1a, &k1b)) != SM_CORE_OK ||
            (st = rhs(o, curve, cm, sm, fa + hh * k1a, fb + hh * k1b, iam, ibm, &k2a, &k2b)) != SM_CORE_OK ||
            (st = rhs(o, curve, cm, sm, fa + hh * k2a, fb + hh * k2b, iam, ibm, &k3a, &k3b)) != SM_CORE_OK ||
            (st = rhs(o, curve, c1, s1, fa + h * k3a, fb + h * k3b, isa0 + dia * t1, isb0 + dib * t1, &k4a,
                      &k4b)) != SM_CORE_OK) {
            return st;
        }
        fa += h / 6.0 * (k1a + 2.0 * (k2a + k3a) + k4a);
        fb += h / 6.0 * (k1b + 2.0 * (k2b + k3b) + k4b);
        c0 = c1;
        s0 = s1;
        t0 = t1;
    }
    o->pa = c0 * fa - s0 * fb;
    o->pb = s0 * fa + c0 * fb;
    o->isa = i_s_alpha;
    o->isb = i_s_beta;
    o->w = omega_m;
    *pa = o->pa;
    *pb = o->pb;
    return SM_CORE_OK;
}

/* satmotor/control/loss_min.py in C (see sm_lossmin.h). */
#include "sm_lossmin.h"

#include <math.h>

#include "sm_common.h"

void sm_lm_init(sm_lossmin *lm, double Ts, double floor, double rate, double R_fe)
{
    lm->floor = floor;
    lm->d_max = rate * Ts;
    lm->R_fe = R_fe;
    lm->psi = 0.0;
}

int sm_lm_steady_losses(const sm_motor *p, double I, double T, double omega_m, double R_fe, double out[3])
{
    double k = p->k, l_r = p->l_r;
    double psi = sm_curve_psi(&p->curve, I);
    double c = T * l_r / (1.5 * (double)p->n_p * k * k);
    double disc = psi * psi * psi * psi - 4.0 * c * c;
    double pmd, m, Phi, imd, imq, cc, k_lr, i_sd, i_sq, i_rq, P;
    if (!(disc >= 0.0)) {
        return 0;
    }
    pmd = sqrt(0.5 * (psi * psi + sqrt(disc)));
    m = psi / I;
    Phi = k * pmd;
    imd = pmd / m;
    imq = c / pmd / m;
    cc = 1.0 + k * k * m / l_r;
    k_lr = k / l_r;
    i_sd = cc * imd - k_lr * Phi;
    i_sq = cc * imq;
    i_rq = k_lr * m * imq;
    if (R_fe > 0.0) { /* the terminal current: the core branch's e_s / R_fe beside the leakage's */
        double l_s = p->l_s;
        double sigma = 1.0 + k * k * l_s / l_r;
        double L = l_s + sigma * m;
        double psd = L * imd - l_s * k_lr * Phi, psq = L * imq;
        double ws = (double)p->n_p * omega_m + p->R_r * k * m * imq / (l_r * Phi);
        double ed = -ws * psq, eq = ws * psd;
        i_sd = i_sd + ed / R_fe;
        i_sq = i_sq + eq / R_fe;
        P = p->R_s * (i_sd * i_sd + i_sq * i_sq) + p->R_r * (i_rq * i_rq) + (ed * ed + eq * eq) / R_fe;
    } else {
        P = p->R_s * (i_sd * i_sd + i_sq * i_sq) + p->R_r * (i_rq * i_rq);
    }
    out[0] = Phi;
    out[1] = 1.5 * P;
    out[2] = sm_hypot(i_sd, i_sq);
    return 1;
}

/* LossMinimizer._loss: *f the (penalized) loss [W] (inf where no root) and *Phi [Wb] at I */
static void loss(const sm_lossmin *lm, const sm_motor *p, double I, double T, double omega, double i_lim, double *f,
                 double *Phi)
{
    double pt[3];
    if (!sm_lm_steady_losses(p, I, T, omega, lm->R_fe, pt)) {
        *f = INFINITY;
        *Phi = 0.0;
        return;
    }
    if (pt[2] > i_lim) {
        pt[1] *= 1.0 + SM_LM_PENALTY * (pt[2] / i_lim - 1.0);
    }
    *f = pt[1];
    *Phi = pt[0];
}

int sm_lm_optimum(const sm_lossmin *lm, const sm_motor *p, double T, double omega, double psi_hi, double i_lim,
                  double *psi)
{
    double floor = lm->floor, k = p->k, c, ac, pmd, a, b, g = SM_LM_GOLDEN, x1, x2, f1, f2, phi1, phi2, Phi;
    double fa, fb, phia, phib, f;
    int st, j;
    if (psi_hi <= floor) {
        *psi = psi_hi;
        return SM_CORE_OK;
    }
    c = T * p->l_r / (1.5 * (double)p->n_p * k * k);
    ac = fabs(c);
    pmd = psi_hi / k;
    if (pmd * pmd <= ac) {
        *psi = psi_hi;
        return SM_CORE_OK;
    }
    if ((st = sm_curve_current(&p->curve, sm_hypot(pmd, c / pmd), &b))) {
        return st;
    }
    pmd = floor / k;
    if ((st = sm_curve_current(&p->curve, pmd * pmd >= ac ? sm_hypot(pmd, c / pmd) : sqrt(2.0 * ac), &a))) {
        return st;
    }
    loss(lm, p, a, T, omega, i_lim, &fa, &phia); /* the ends: an optimum on a bound is found exactly */
    loss(lm, p, b, T, omega, i_lim, &fb, &phib);
    x1 = b - g * (b - a);
    x2 = a + g * (b - a);
    loss(lm, p, x1, T, omega, i_lim, &f1, &phi1);
    loss(lm, p, x2, T, omega, i_lim, &f2, &phi2);
    for (j = 0; j < SM_LM_N_GOLDEN; ++j) {
        if (f1 < f2) {
            b = x2;
            x2 = x1;
            f2 = f1;
            phi2 = phi1;
            x1 = b - g * (b - a);
            loss(lm, p, x1, T, omega, i_lim, &f1, &phi1);
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            phi1 = phi2;
            x2 = a + g * (b - a);
            loss(lm, p, x2, T, omega, i_lim, &f2, &phi2);
        }
    }
    if (f1 < f2) {
        f = f1;
        Phi = phi1;
    } else {
        f = f2;
        Phi = phi2;
    }
    if (fa < f) {
        f = fa;
        Phi = phia;
    }
    if (fb < f) {
        f = fb;
        Phi = phib;
    }
    if (!(f < INFINITY)) {
        *psi = psi_hi;
        return SM_CORE_OK;
    }
    *psi = fmin(fmax(Phi, floor), psi_hi);
    return SM_CORE_OK;
}

int sm_lm_set_point(sm_lossmin *lm, const sm_motor *p, double T, double omega, double psi_hi, double i_lim,
                    double *psi)
{
    double d = lm->d_max, s = lm->psi, opt;
    int st = sm_lm_optimum(lm, p, T, omega, psi_hi, i_lim, &opt);
    if (st) {
        return st;
    }
    s = fmin(fmax(opt, s - d), s + d);
    lm->psi = s;
    *psi = fmin(s, psi_hi);
    return SM_CORE_OK;
}

/* satmotor/control/field_weakening.py in C (see sm_fieldweak.h). */
#include "sm_fieldweak.h"

#include <math.h>

#include "sm_common.h"

static const double SLOPE = 1e-7; /* field_weakening._SLOPE */

void sm_fw_init(sm_fieldweak *fw, const sm_motor *p, double V_max, double ratio, double ref_bandwidth)
{
    fw->V_lim = V_max * ratio;
    fw->lead = 3.0 / ref_bandwidth;
    fw->kt = 1.5 * (double)p->n_p * p->k / p->l_r;
}

/* field_weakening._point */
static void point(const sm_motor *p, double m, double Phi, double pmd, double pmq, double omega_m, double out[4])
{
    double k = p->k, l_r = p->l_r, l_s = p->l_s;
    double imd = pmd / m, imq = pmq / m;
    double cc = 1.0 + k * k * m / l_r;
    double k_lr = k / l_r;
    double i_sd = cc * imd - k_lr * Phi, i_sq = cc * imq;
    double sigma = 1.0 + k * k * l_s / l_r;
    double L = l_s + sigma * m;
    double psd = L * imd - l_s * k_lr * Phi, psq = L * imq;
    double ws = (double)p->n_p * omega_m + p->R_r * k * m * imq / (l_r * Phi);
    double vd = p->R_s * i_sd - ws * psq, vq = p->R_s * i_sq + ws * psd;
    out[0] = Phi;
    out[1] = sm_hypot(vd, vq);
    out[2] = sm_hypot(i_sd, i_sq);
    out[3] = ws;
}

int sm_fw_steady_point(const sm_motor *p, double I, double T, double omega_m, double out[4])
{
    double k = p->k;
    double psi = sm_curve_psi(&p->curve, I);
    double c = T * p->l_r / (1.5 * (double)p->n_p * k * k);
    double disc = psi * psi * psi * psi - 4.0 * c * c;
    double pmd;
    if (!(disc >= 0.0)) {
        return 0;
    }
    pmd = sqrt(0.5 * (psi * psi + sqrt(disc)));
    point(p, psi / I, k * pmd, pmd, c / pmd, omega_m, out);
    return 1;
}

int sm_fw_steady_point_at_flux(const sm_motor *p, double Phi, double T, double omega_m, double *I, double out[4])
{
    double k = p->k;
    double pmd = Phi / k;
    double pmq = T * p->l_r / (1.5 * (double)p->n_p * k * k) / pmd;
    double psi = sm_hypot(pmd, pmq);
    int st = sm_curve_current(&p->curve, psi, I);
    if (st) {
        return st;
    }
    point(p, psi / *I, Phi, pmd, pmq, omega_m, out);
    return SM_CORE_OK;
}

int sm_fw_flux_at(const sm_fieldweak *fw, const sm_motor *p, double T, double omega, double psi_ref, double *psi)
{
    double V_lim = fw->V_lim, I_hi, lo, hi, mid, pt[4], up[4], phi;
    int st, j;
    if ((st = sm_fw_steady_point_at_flux(p, psi_ref, T, omega, &I_hi, pt))) {
        return st;
    }
    if (pt[1] <= V_lim) {
        *psi = psi_ref;
        return SM_CORE_OK;
    }
    lo = 0.0;
    hi = I_hi;
    for (j = 0; j < SM_FW_N_BISECT; ++j) {
        mid = 0.5 * (lo + hi);
        if (!sm_fw_steady_point(p, mid, T, omega, pt) || pt[1] <= V_lim) {
            lo = mid;
            continue;
        }
        if (sm_fw_steady_point(p, mid * (1.0 + SLOPE), T, omega, up) && up[1] < pt[1]) {
            lo = mid; /* still falling: the breakdown point is above */
        } else {
            hi = mid;
        }
    }
    phi = (lo > 0.0 && sm_fw_steady_point(p, lo, T, omega, pt)) ? pt[0] : 0.0;
    *psi = fmin(fmax(phi, SM_FW_FLOOR * psi_ref), psi_ref);
    return SM_CORE_OK;
}

int sm_fw_torque(const sm_fieldweak *fw, const sm_motor *p, const double meas[SM_MEAS_LEN], double *T)
{
    sm_magnetizing ms;
    int st = sm_from_rotor_flux(meas[SM_MEAS_I_S_A], meas[SM_MEAS_I_S_B], meas[SM_MEAS_PSI_R_A],
                                meas[SM_MEAS_PSI_R_B], p, &ms);
    *T = fw->kt * ms.m * ms.Phi_rd * ms.i_mu_q;
    return st;
}

int sm_fw_flux_reference(const sm_fieldweak *fw, const sm_motor *p, const double meas[SM_MEAS_LEN],
                         double omega_ref_rate, double psi_ref, double *psi)
{
    double T;
    int st = sm_fw_torque(fw, p, meas, &T);
    if (st) {
        return st;
    }
    return sm_fw_flux_at(fw, p, T, meas[SM_MEAS_OMEGA_M] + fw->lead * omega_ref_rate, psi_ref, psi);
}

/* satmotor/control/field_weakening.py in C (see sm_fieldweak.h). */
#include "sm_fieldweak.h"

#include <math.h>

#include "sm_common.h"

static const double SLOPE = 1e-7; /* field_weakening._SLOPE */

void sm_fw_init(sm_fieldweak *fw, const sm_motor *p, double V_max, double ratio, double ref_bandwidth)
{
    fw->V_lim = V_max * ratio;
    fw->V_bd = 0.5 * (fw->V_lim + V_max);
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

double sm_fw_search(const sm_fieldweak *fw, const sm_motor *p, double T, double omega, double I_hi, double V_lim,
                    int n)
{
    double lo = 0.0, hi = I_hi, mid, pt[4], up[4];
    int j;
    (void)fw;
    for (j = 0; j < n; ++j) {
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
    return lo;
}

int sm_fw_breakdown(const sm_fieldweak *fw, const sm_motor *p, double T, double omega, double I_hi, double V,
                    double *T_bd, double *I, double out[4])
{
    double lo = 0.0, hi = 2.0, mid, T_mid, pt[4];
    int j;
    for (j = 0; j < SM_FW_N_BREAKDOWN; ++j) {
        mid = 0.5 * (lo + hi);
        T_mid = mid * T;
        if (sm_fw_steady_point(p, sm_fw_search(fw, p, T_mid, omega, I_hi, -1.0, SM_FW_N_BREAKDOWN), T_mid, omega,
                               pt) &&
            pt[1] <= V) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    *T_bd = lo * T;
    *I = sm_fw_search(fw, p, *T_bd, omega, I_hi, -1.0, SM_FW_N_BREAKDOWN);
    return *I > 0.0 && sm_fw_steady_point(p, *I, *T_bd, omega, out);
}

int sm_fw_set_points(const sm_fieldweak *fw, const sm_motor *p, double T, double omega, double psi_ref,
                     double I_max, double *psi, double *i_max)
{
    double V_lim = fw->V_lim, I_hi, pt[4], T_bd, I_bd;
    int st;
    if ((st = sm_fw_steady_point_at_flux(p, psi_ref, T, omega, &I_hi, pt))) {
        return st;
    }
    *i_max = I_max;
    if (pt[1] <= V_lim) {
        *psi = psi_ref;
        return SM_CORE_OK;
    }
    if (!sm_fw_steady_point(p, sm_fw_search(fw, p, T, omega, I_hi, V_lim, SM_FW_N_BISECT), T, omega, pt) ||
        pt[1] > V_lim) {
        /* beyond the breakdown torque: the breakdown point */
        if (!sm_fw_breakdown(fw, p, T, omega, I_hi, fw->V_bd, &T_bd, &I_bd, pt)) {
            *psi = SM_FW_FLOOR * psi_ref;
            return SM_CORE_OK;
        }
        *i_max = fmin(I_max, pt[2]);
    }
    *psi = fmin(fmax(pt[0], SM_FW_FLOOR * psi_ref), psi_ref);
    return SM_CORE_OK;
}

int sm_fw_flux_at(const sm_fieldweak *fw, const sm_motor *p, double T, double omega, double psi_ref, double *psi)
{
    double i_max;
    return sm_fw_set_points(fw, p, T, omega, psi_ref, INFINITY, psi, &i_max);
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
                         double omega_ref_rate, double psi_ref, double I_max, double *psi, double *i_max)
{
    double T;
    int st = sm_fw_torque(fw, p, meas, &T);
    if (st) {
        return st;
    }
    return sm_fw_set_points(fw, p, T, meas[SM_MEAS_OMEGA_M] + fw->lead * omega_ref_rate, psi_ref, I_max, psi,
                            i_max);
}

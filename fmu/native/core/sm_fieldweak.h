/* Automatic field weakening on the magnetizing curve: satmotor/control/field_weakening.py in C (its
 * docstring is the specification; the same operations in the same order).  Plain struct, no global
 * state. */
#ifndef SM_FIELDWEAK_H
#define SM_FIELDWEAK_H

#include <stddef.h>

#include "sm_law.h"

/* field_weakening.N_BISECT, N_BREAKDOWN, FLOOR */
#define SM_FW_N_BISECT 24
#define SM_FW_N_BREAKDOWN 16
#define SM_FW_FLOOR 0.1

typedef struct {
    double V_lim; /* [V] ratio V_max: the voltage a steady state may use */
    double V_bd;  /* [V] (V_lim + V_max) / 2: the breakdown point's voltage */
    double lead;  /* [s] 3 / ref_bandwidth: the flux shaper's delay */
    double kt;    /* [1/H] 3/2 n_p k / l_r: T = kt m Phi_rd i_mu_q */
} sm_fieldweak;

/* FieldWeakening(params, V_max, ratio, ref_bandwidth): V_max [V] > 0, ratio in (0, 1],
 * ref_bandwidth [rad/s] > 0 (checked by the drive's configuration). */
void sm_fw_init(sm_fieldweak *fw, const sm_motor *p, double V_max, double ratio, double ref_bandwidth);

/* steady_point: out = (Phi [Wb], |v_s| [V], |i_s| [A], omega_s [rad/s]) at I [A] > 0, T [N m], omega_m [rad/s]; returns
 * 1, or 0 where no steady state has this I (Python: None; out untouched). */
int sm_fw_steady_point(const sm_motor *p, double I, double T, double omega_m, double out[4]);

/* steady_point_at_flux: *I and out at the rotor flux Phi [Wb] > 0; the curve inversion's status. */
int sm_fw_steady_point_at_flux(const sm_motor *p, double Phi, double T, double omega_m, double *I, double out[4]);

/* FieldWeakening.search: the bisection over I in (0, I_hi] [A], n steps; returns I [A]. */
double sm_fw_search(const sm_fieldweak *fw, const sm_motor *p, double T, double omega, double I_hi, double V_lim,
                    int n);

/* FieldWeakening.breakdown at the voltage V [V]: *T_bd [N m], *I [A] and out (steady_point); returns 1, or 0
 * where no point is found (Python: None). */
int sm_fw_breakdown(const sm_fieldweak *fw, const sm_motor *p, double T, double omega, double I_hi, double V,
                    double *T_bd, double *I, double out[4]);

/* FieldWeakening.set_points: *psi [Wb] and *i_max [A] for T [N m] at omega [rad/s], the nominal psi_ref [Wb]
 * and the current limit I_max [A]. */
int sm_fw_set_points(const sm_fieldweak *fw, const sm_motor *p, double T, double omega, double psi_ref,
                     double I_max, double *psi, double *i_max);

/* FieldWeakening.flux_at: set_points with I_max = inf, the flux only. */
int sm_fw_flux_at(const sm_fieldweak *fw, const sm_motor *p, double T, double omega, double psi_ref, double *psi);

/* FieldWeakening.torque: the control model's torque [N m] at meas (SM_MEAS_* order). */
int sm_fw_torque(const sm_fieldweak *fw, const sm_motor *p, const double meas[SM_MEAS_LEN], double *T);

/* FieldWeakening.flux_reference: *psi [Wb] and *i_max [A] at meas, the shaped speed reference's slope
 * [rad/s^2], the nominal psi_ref [Wb] and the current limit I_max [A]. */
int sm_fw_flux_reference(const sm_fieldweak *fw, const sm_motor *p, const double meas[SM_MEAS_LEN],
                         double omega_ref_rate, double psi_ref, double I_max, double *psi, double *i_max);

#endif

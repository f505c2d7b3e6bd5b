/* The backstepping control law of satmotor/control/backstepping.py in C99, with the control model of
 * satmotor/control/fo_model.py and the magnetizing state of satmotor/control/measurements.py.
 *
 * The same formulas in the same order as the Python (so the same floats on an IEEE-754 double
 * target without FMA contraction: gcc contracts a*b+c into an FMA by default in its GNU modes
 * (-std=gnu99, the default) on FMA targets (-march=native, aarch64), which moves the control
 * voltages by up to ~2e-11 relative; -std=c99 or -ffp-contract=off keeps them bit-identical).  math.hypot is sm_hypot of sm_common.h (CPython's algorithm, not libm's hypot); the
 * rest are libm calls Python makes as well (sqrt, atan2, cos, sin).
 *
 * No global or static mutable state: every function works on caller-owned structs.  Parameter
 * checks return SM_ERR_PARAM with the text of satmotor.errors.ParameterError in msg. */
#ifndef SM_LAW_H
#define SM_LAW_H

#include <stddef.h>

#include "sm_common.h"
#include "sm_curves.h"
#include "sm_params.h" /* generated: SM_MEAS_* */
#include "sm_plant.h"

/* Share of i_max the flux (d) current may take (backstepping.D_SHARE). */
#define SM_D_SHARE 0.9
/* A |W| below this fraction of its terms is floored (backstepping._W_REL_FLOOR). */
#define SM_W_REL_FLOOR 1e-12

/* ---- control model (fo_model.py) ------------------------------------------------------------ */

/* fo_model.ModelConstants: the parameter groups of the control model. */
typedef struct {
    double k;      /* [1] turns ratio */
    double l_s;    /* [H] */
    double R_s;    /* [Ohm] */
    int n_p;       /* [1] */
    double a;      /* R_r / l_r [1/s] */
    double ak;     /* a k [1/s] */
    double K;      /* kappa k / (J l_r): T_e / J = K m Phi_rd i_mu_q */
    double b;      /* B / J [1/s] */
    double sigma;  /* 1 + k^2 l_s / l_r [1] */
    double k_lr;   /* k / l_r [1/H] */
    double k2_lr;  /* k^2 / l_r [1/H] */
    double kls_lr; /* k l_s / l_r [1] */
} sm_model_constants;

/* ModelConstants.of(p) (no check: p comes from sm_motor_init). */
void sm_model_constants_of(const sm_motor *p, sm_model_constants *c);

/* Phi_rd' = a (k m i_mu_d - Phi_rd) [Wb/s] (fo_model.flux_rate). */
double sm_flux_rate(double a, double k, double phi, double i_mu_d, double m);

/* The tuple fo_model.vector_fields returns, by name. */
typedef struct {
    double F_phi, F_d, F_q, F_w; /* drift [Wb/s, A/s, A/s, rad/s^2] */
    double g_dd, g_dq, g_qq;     /* L^-1 [1/H] */
    double omega_s;              /* [rad/s] */
    double M_d, M_q, M_dq;       /* [H] */
    double i_sd, i_sq;           /* [A] */
    double psi_sd, psi_sq;       /* [Wb] */
    double te_J;                 /* T_e / J [rad/s^2] */
    double det_L;                /* [H^2] */
} sm_fields;

/* fo_model.vector_fields(c, phi, imd, imq, w, m, dm, I, theta, phi_ws). */
void sm_vector_fields(const sm_model_constants *c, double phi, double imd, double imq, double w,
                      double m, double dm, double I, double theta, double phi_ws, sm_fields *f);

/* ---- magnetizing state from measurements (measurements.py) --------------------------------- */

/* Layout of the measurement vector: SM_MEAS_I_S_A ... SM_MEAS_OMEGA_M, SM_MEAS_LEN, generated into
 * sm_params.h from measurements.MEAS_* (the controller's first inputs in their order); psi_s read
 * only with use_stator_flux. */

/* measurements.MagnetizingState. */
typedef struct {
    double i_mu_alpha, i_mu_beta; /* [A] */
    double I;                     /* [A] |i_mu| */
    double m;                     /* [H] psi_m / I */
    double Phi_rd;                /* [Wb] |psi_r| */
    double i_mu_d, i_mu_q;        /* [A] in the rotor-flux frame */
    double rho;                   /* [rad] rotor flux angle */
} sm_magnetizing;

/* from_rotor_flux: i_mu via the curve of p (sm_curve_solve).  SM_CORE_OK; a non-finite input gives
 * SM_ERR_NONFINITE with the state computed as far as it goes (NaN where Python has NaN); a solve
 * that does not converge SM_ERR_NOCONV (Python: ArithmeticError). */
int sm_from_rotor_flux(double i_sa, double i_sb, double psi_ra, double psi_rb, const sm_motor *p,
                       sm_magnetizing *ms);
/* from_stator_flux: i_mu by algebra, m = |psi_s - l_s i_s| / |i_mu|.  SM_CORE_OK or SM_ERR_NONFINITE. */
int sm_from_stator_flux(double i_sa, double i_sb, double psi_ra, double psi_rb, double psi_sa,
                        double psi_sb, const sm_motor *p, sm_magnetizing *ms);
/* from_magnetizing_current: a given i_mu (the plant's true one), m from the curve at |i_mu|. */
int sm_from_magnetizing_current(double i_mu_a, double i_mu_b, double psi_ra, double psi_rb,
                                const sm_motor *p, sm_magnetizing *ms);

/* ---- the law (backstepping.py) -------------------------------------------------------------- */

/* BacksteppingGains [1/s]: c1, c2, d1, d2 > 0; c0, d0 >= 0 (integral action; 0: none). */
typedef struct {
    double c1, c2, d1, d2, c0, d0;
} sm_gains;

/* The Python defaults, BacksteppingGains() (defined in the generated sm_params.c). */
void sm_gains_default(sm_gains *g);
/* BacksteppingGains.__post_init__: SM_CORE_OK or SM_ERR_PARAM ("c1 = -1.0: must be a finite number
 * > 0"). */
int sm_gains_check(const sm_gains *g, char *msg, size_t msg_len);

/* ControllerConfig without true_i_mu (a design-comparison setting of the plain Python loop).
 * load_estimated: 0 = 'known' (T_L, dT_L/dt given), 1 = 'estimated' (adaptive theta_hat);
 * overmodulation: 0 = 'linear', 1 = 'overmodulation'. */
typedef struct {
    double V_dc;         /* [V] > 0; |v_s| <= V_dc / sqrt(3) */
    double Ts;           /* [s] >= 0 (0: continuous, no mid-sample rotation) */
    double phi_min;      /* [Wb] > 0, singularity guard */
    int load_estimated;  /* 0 or 1 */
    double g_theta;      /* [1/s^2] > 0 */
    double theta_max;    /* [rad/s^2] > 0 */
    int use_stator_flux; /* 0 or 1 */
    int overmodulation;  /* modulation: 0 'linear' (|v_s| <= V_dc / sqrt(3)), 1 'overmodulation' (the
                          * hexagon, direction kept: satmotor/control/modulation.py) */
} sm_law_config;

/* modulation.limit_voltage: the command (vd, vq) [V] in the frame at angle (cos c, sin s) limited in
 * place, onto the circle V_dc / sqrt(3) (overmodulation 0) or the inverter's hexagon, its direction
 * kept (1); returns 1 where it was limited.  vd, vq not NULL. */
int sm_voltage_limit(double *vd, double *vq, double c, double s, double V_dc, int overmodulation);

/* The Python defaults, ControllerConfig() (defined in the generated sm_params.c). */
void sm_law_config_default(sm_law_config *cfg);
/* ControllerConfig.__post_init__ in the same order: SM_CORE_OK or SM_ERR_PARAM. */
int sm_law_config_check(const sm_law_config *cfg, char *msg, size_t msg_len);

/* backstepping.ErrorSystem. */
typedef struct {
    double e1, e2, z1, z2;
    double grad_e2[4], grad_z2[4]; /* de2/dx, dz2/dx */
    double dt_e2, dt_z2;           /* explicit time derivatives */
    double beta1, beta2;
    double Lambda[2][2]; /* as used (Phi_rd floored at phi_min) */
    double W;            /* det Lambda with the true Phi_rd */
    double omega_s;      /* [rad/s] */
    double theta_dot;    /* theta' used in dz2/dt */
    int singular_limited;
    int flux_limited;   /* +1 / -1: alpha1 bounded from above / below, 0 */
    int torque_limited; /* +1 / -1: gamma1 bounded, 0 */
} sm_error_state;

/* backstepping.error_system(x, ref, p, g, theta, theta_dot, phi_min, adapt, integ, i_max):
 * x = (Phi_rd, i_mu_d, i_mu_q, omega_m); ref = (psi_ref_shaped, psi_ref_shaped', psi_ref_shaped'',
 * omega_ref_shaped, omega_ref_shaped', omega_ref_shaped''); adapt NULL (theta_dot given) or (g_theta, theta_max); integ NULL
 * (0, 0) or (e0, z0); i_max [A] (INFINITY: no current limit).  m, dm/dI from p's curve at |i_mu|.
 * SM_CORE_OK, SM_ERR_ARG (NULL pointer) or SM_ERR_NONFINITE (a non-finite input; es still filled). */
int sm_error_system(const double x[4], const double ref[6], const sm_motor *p, const sm_gains *g,
                    double theta, double theta_dot, double phi_min, const double *adapt,
                    const double *integ, double i_max, sm_error_state *es);

/* backstepping.ControlOutput (flags as 0/1). */
typedef struct {
    double v_s_alpha, v_s_beta; /* [V] rotated by rho + omega_s Ts / 2 */
    double v_sd, v_sq;          /* [V] */
    double e1, e2, z1, z2, V, W;
    double m;      /* [H] */
    double i_mu;   /* [A] |i_mu| */
    double Phi_rd; /* [Wb] */
    double rho;    /* [rad] */
    double omega_s;
    double theta_hat_dot; /* 0 in the known mode */
    int voltage_limited, singular_limited;
    double e0_dot; /* [Wb] 0 while a limit holds the flux integral */
    double z0_dot; /* [rad/s] 0 while a limit holds the speed integral */
    int current_limited;
} sm_control_output;

/* backstepping.control (a pure function of its arguments).
 * meas: SM_MEAS_LEN values (psi_s read only with cfg->use_stator_flux); ref as sm_error_system;
 * load = (T_L, dT_L/dt) [N m, N m/s], read only in the known mode (may be NULL otherwise);
 * theta_hat [rad/s^2] the estimate (estimated mode; clipped to +-theta_max); integ (e0, z0) or
 * NULL; i_max [A] (INFINITY: none).  p, g, cfg are taken as checked (sm_motor_init,
 * sm_gains_check, sm_law_config_check).
 * Returns SM_CORE_OK; SM_ERR_ARG for a NULL pointer (out zeroed); SM_ERR_NOCONV when the curve solve
 * did not converge (out filled with NaN; Python raises); SM_ERR_NONFINITE when an input read is not
 * finite (out filled as Python computes it: NaN, or the voltage limit's fallback direction). */
int sm_control(const double meas[SM_MEAS_LEN], const double ref[6], const double load[2],
               const sm_motor *p, const sm_gains *g, const sm_law_config *cfg, double theta_hat,
               const double integ[2], double i_max, sm_control_output *out);

#endif

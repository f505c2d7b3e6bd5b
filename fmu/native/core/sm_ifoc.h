/* Indirect field-oriented PI control (the baseline), sampled: satmotor/control/ifoc.py in C.
 *
 * The controller's model is the unsaturated machine with a constant magnetizing inductance L_m
 * [H]; the tuning rule, the limits and the anti-windup are those of satmotor/control/ifoc.py (its module
 * docstring is the specification).  Plain struct, no pointers: an FMU state is a byte copy.
 * C99, no global mutable state. */
#ifndef SM_IFOC_H
#define SM_IFOC_H

#include <stddef.h>

typedef struct {
    double w_c;     /* [rad/s] current-loop bandwidth */
    double w_speed; /* [rad/s] speed-loop crossover (symmetric optimum) */
    double I_max;   /* [A] current vector limit */
    double V_dc;    /* [V] DC link; |v_s| <= V_dc / sqrt(3) */
} sm_ifoc_gains;

/* The Python defaults, IFOCGains() (defined in the generated sm_params.c). */
void sm_ifoc_gains_default(sm_ifoc_gains *g);

typedef struct {
    /* design constants (set by sm_ifoc_init) */
    double Ts, L_m, L_ra, sigL, R_eq, tau_r, Kp_i, Ki_i, T_sigma, a_so, Kp_w, Ki_w, V_max, V_max2;
    double kLm, inv_kLm, kT, c_fd, c_fq, I_max, I_max2, kiT_i, kiT_w, k_aw, phi_gain, half_Ts;
    double R_s, R_r, l_s, l_r, k, w_c; /* the design's inputs (sm_ifoc_set_inductance) */
    int n_p;
    /* state */
    double x_w, x_d, x_q, theta, phi;
} sm_ifoc;

typedef struct {
    double i_sd, i_sq, i_sd_ref, i_sq_ref, T_ref, omega_slip, theta_f, phi_hat, v_sd, v_sq;
    int voltage_limited, current_limited;
} sm_ifoc_diagnostics;

/* Motor data of the controller's model (R_s, R_r, l_s, l_r [Ohm, H], k [1], n_p, J [kg m2]), the
 * gains, the sample period Ts [s] and L_m [H].  0, or nonzero with a message naming the value. */
int sm_ifoc_init(sm_ifoc *c, double R_s, double R_r, double l_s, double l_r, double k, int n_p, double J,
                 const sm_ifoc_gains *g, double Ts, double L_m, char *msg, size_t msg_len);
/* Take the constant magnetizing inductance L_m [H] > 0: every constant and current-loop gain that depends
 * on it derived again (IFOCController.set_inductance), the states unchanged.  0, or nonzero with a message. */
int sm_ifoc_set_inductance(sm_ifoc *c, double L_m, char *msg, size_t msg_len);
/* Zero the integrators; the flux model at phi_r [Wb] >= 0 and the frame at theta_f [rad]. */
int sm_ifoc_reset(sm_ifoc *c, double theta_f, double phi_r, char *msg, size_t msg_len);
/* One sample: measured currents [A], speed [rad/s], speed reference [rad/s], flux reference
 * [Wb] > 0; the voltages [V] to hold over the next period and the diagnostics.  Nonzero (nothing
 * changed) for a flux reference that is not finite and > 0. */
int sm_ifoc_step(sm_ifoc *c, double i_s_alpha, double i_s_beta, double omega_m, double omega_ref_shaped,
                 double psi_ref_shaped, double *v_alpha, double *v_beta, sm_ifoc_diagnostics *d,
                 char *msg, size_t msg_len);

#endif

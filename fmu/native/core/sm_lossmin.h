/* The loss-minimizing rotor-flux set-point: satmotor/control/loss_min.py in C (its docstring is the
 * specification; the same operations in the same order).  Plain struct, no global state. */
#ifndef SM_LOSSMIN_H
#define SM_LOSSMIN_H

#include "sm_law.h"

/* loss_min.N_GOLDEN, GOLDEN, PENALTY */
#define SM_LM_N_GOLDEN 16
#define SM_LM_GOLDEN 0.6180339887498949
#define SM_LM_PENALTY 1e3

typedef struct {
    double floor; /* [Wb] flux_floor */
    double d_max; /* [Wb] flux_rate_max Ts: the most the set-point moves in a sample */
    double R_fe;  /* [Ohm] loss_R_fe, 0: copper loss only */
    double psi;   /* [Wb] the rate-limited set-point (state) */
} sm_lossmin;

/* LossMinimizer(params, Ts, floor, rate, R_fe) (checked by the drive's configuration); psi = 0. */
void sm_lm_init(sm_lossmin *lm, double Ts, double floor, double rate, double R_fe);

/* steady_losses: out = (Phi [Wb], P [W], |i_s| [A]) at I [A] > 0, T [N m], omega_m [rad/s], R_fe [Ohm];
 * returns 1, or 0 where the flux-axis root does not exist (Python: None; out untouched). */
int sm_lm_steady_losses(const sm_motor *p, double I, double T, double omega_m, double R_fe, double out[3]);

/* LossMinimizer.optimum: *psi [Wb] for T [N m], omega [rad/s], psi_hi [Wb], i_lim [A]; a curve
 * inversion's status. */
int sm_lm_optimum(const sm_lossmin *lm, const sm_motor *p, double T, double omega, double psi_hi, double i_lim,
                  double *psi);

/* LossMinimizer.set_point: the rate-limited optimum, min(., psi_hi), in *psi; advances lm->psi. */
int sm_lm_set_point(sm_lossmin *lm, const sm_motor *p, double T, double omega, double psi_hi, double i_lim,
                    double *psi);

#endif

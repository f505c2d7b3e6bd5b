/* The closed-loop rotor-flux observer (current and voltage models blended by a speed-dependent gain, the
 * magnetizing curve inside; optionally speed-adaptive) of satmotor/estimation/flux_observer.py in C.  Its module
 * docstring is the specification.  Plain struct (byte-copyable state).  C99, no global mutable state. */
#ifndef SM_FLUX_OBSERVER_H
#define SM_FLUX_OBSERVER_H

#include <stddef.h>

#include "sm_curves.h"
#include "sm_observer.h"

#define SM_CL_OBSERVER_N_STATE 10 /* flux_observer.N_STATE */

typedef struct {
    sm_observer cm; /* the current model, restarted from the estimate every sample */
    double Ts, alpha_w;
    int estimate_speed;
    double pole; /* b/a: flux_observer.POLE_FACTOR_MEASURED or _ESTIMATED */
    double k, ls, lr, Rs, Rr, np, lr_k, k_lr, a_solve;
    /* state: estimate [Wb]; previous sample's i_s [A], speed [rad/s]; applied v_s [V]; speed estimate */
    double pa, pb, isa, isb, w, va, vb, w_hat;
    int has_prev;
    /* resistance tracking (resistance.py): options, the given R_s, R_r [Ohm]; the last update's residual
     * (da, db, pa, pb, ia, ib, n2), not a state (used within its sample); R_s_hat, R_r_hat are Rs, Rr */
    int adapt_rs, track_rr;
    double Rs0, Rr0;
    int has_res;
    double res[7];
} sm_cl_observer;

/* The controller's model (R_s, R_r [Ohm] > 0, l_s [H] >= 0 (0: the Gamma form, exact), l_r [H] > 0, k, n_p), Ts [s] > 0, estimate_speed 0/1, alpha_w
 * [rad/s] > 0.  SM_CORE_OK or SM_ERR_PARAM with the message. */
int sm_cl_observer_init(sm_cl_observer *o, double R_s, double R_r, double l_s, double l_r, double k, int n_p,
                        double Ts, int estimate_speed, double alpha_w, char *msg, size_t msg_len);
/* The resistance tracking of resistance.py (after init; both 0 after init): adapt_rs 0/1, track_rr 0/1 (needs
 * adapt_rs).  SM_CORE_OK or SM_ERR_PARAM with the message. */
int sm_cl_observer_set_tracking(sm_cl_observer *o, int adapt_rs, int track_rr, char *msg, size_t msg_len);
/* ClosedLoopObserver.adapt_resistance: one step of the R_s adaptation (R_r tracking) from the last update. */
void sm_cl_observer_adapt_resistance(sm_cl_observer *o);
/* Set the estimates [Wb, Wb, rad/s]; forget the previous sample and the applied voltage. */
int sm_cl_observer_reset(sm_cl_observer *o, double psi_r_alpha, double psi_r_beta, double omega_m_hat, char *msg,
                         size_t msg_len);
/* The voltage [V] applied from this sample to the next. */
void sm_cl_observer_applied(sm_cl_observer *o, double v_s_alpha, double v_s_beta);
/* Advance to this sample: the estimate in *pa, *pb [Wb], the speed the drive uses in *w [rad/s] (the estimate
 * with estimate_speed, omega_m unread; else omega_m).  SM_CORE_OK or a curve solve's status (nothing changed). */
int sm_cl_observer_update(sm_cl_observer *o, const sm_curve *curve, double i_s_alpha, double i_s_beta,
                          double omega_m, double *pa, double *pb, double *w);
/* get_state / set_state: SM_CL_OBSERVER_N_STATE doubles, flux_observer.ClosedLoopObserver.get_state's order. */
void sm_cl_observer_get_state(const sm_cl_observer *o, double *s);
void sm_cl_observer_set_state(sm_cl_observer *o, const double *s);

size_t sm_cl_observer_size(void);

#endif

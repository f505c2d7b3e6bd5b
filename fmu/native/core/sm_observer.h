/* The rotor-flux observer (current model on the saturated machine) of satmotor/estimation/observer.py in C.
 * Its module docstring is the specification: inputs linear between samples, the rotation by the
 * integrating factor (exact), the rest by RK4 in n_sub sub-steps.  Plain struct (byte-copyable
 * state).  C99, no global mutable state. */
#ifndef SM_OBSERVER_H
#define SM_OBSERVER_H

#include <stddef.h>

#include "sm_curves.h"

typedef struct {
    double Ts;
    int n_sub;
    double k, k_lr, a, Rr_lr, np;
    double pa, pb, isa, isb, w; /* estimate [Wb]; previous sample's i_s [A], omega_m [rad/s] */
    int has_prev;
} sm_observer;

/* R_r [Ohm], l_r [H], k [1], n_p, Ts [s] > 0, n_sub >= 1 (the curve is passed to each update). */
int sm_observer_init(sm_observer *o, double R_r, double l_r, double k, int n_p, double Ts, int n_sub,
                     char *msg, size_t msg_len);
/* Set the estimate [Wb], forget the previous sample. */
int sm_observer_reset(sm_observer *o, double psi_r_alpha, double psi_r_beta, char *msg, size_t msg_len);
/* Advance to this sample; the estimate in *pa, *pb [Wb].  SM_CORE_OK, or the curve solve's status (the
 * estimate is then left as it was). */
int sm_observer_update(sm_observer *o, const sm_curve *curve, double i_s_alpha, double i_s_beta,
                       double omega_m, double *pa, double *pb);

/* sizeof(sm_observer), for hosts that allocate it without the header (ctypes). */
size_t sm_observer_size(void);

#endif

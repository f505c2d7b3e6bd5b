/* The reference shaper of satmotor/control/references.py in C99: the critically damped third-order filter
 * w_n^3 / (s + w_n)^3 with states z = (r, r', r''), stepped exactly (zero-order hold) with the
 * closed-form transition matrix Phi(h) = exp(-w h) (I + h N + h^2/2 N^2), N = A + w I.
 *
 * Phi is kept for the last step size in the caller-owned struct (the Python keeps a small dict per
 * step size; the coefficients are the same floats either way).  No global state. */
#ifndef SM_REFERENCES_H
#define SM_REFERENCES_H

#include <stddef.h>

#include "sm_common.h"

/* Index of r, r', r'' in a shaper's state and value (references.REF_VALUE, REF_RATE, REF_ACCEL). */
enum { SM_REF_VALUE = 0, SM_REF_RATE = 1, SM_REF_ACCEL = 2 };

typedef struct {
    double bandwidth; /* w_n [rad/s] */
    int has_h;        /* phi holds the coefficients for h_cached */
    double h_cached;  /* [s] */
    double phi[9];    /* Phi(h_cached), row major */
    double z[3];      /* (r, r', r'') */
} sm_shaper;

/* references.transition_matrix(bandwidth, h) into P (row major).  SM_CORE_OK or SM_ERR_PARAM
 * ("bandwidth = ...", "h = ...: must be a finite number > 0"). */
int sm_transition_matrix(double bandwidth, double h, double P[9], char *msg, size_t msg_len);

/* references.RISE_TIME_PRODUCT (w_n t_r of the 10-90 % rise), by the same bisection. */
double sm_rise_time_product(void);

/* ReferenceShaper(bandwidth, initial): SM_CORE_OK or SM_ERR_PARAM (bandwidth, then "value"). */
int sm_shaper_init(sm_shaper *s, double bandwidth, double initial, char *msg, size_t msg_len);

/* ReferenceShaper.step(u, h): advance by h [s] with u held; r = (r, r', r'') after the step (may be
 * NULL).  A bad h (SM_ERR_PARAM, "h = ...") leaves everything unchanged; a non-finite u
 * (SM_ERR_PARAM, "u = ...: must be a finite number") leaves the state unchanged (the coefficients
 * for h are kept, as the Python's cache keeps them). */
int sm_shaper_step(sm_shaper *s, double u, double h, double r[3], char *msg, size_t msg_len);

/* ReferenceShaper.reset(value): at rest at value.  SM_CORE_OK or SM_ERR_PARAM ("value = ..."). */
int sm_shaper_reset(sm_shaper *s, double value, char *msg, size_t msg_len);

/* ReferenceShaper.get_state / value: (r, r', r''). */
void sm_shaper_get_state(const sm_shaper *s, double z[3]);

/* ReferenceShaper.set_state: SM_CORE_OK or SM_ERR_PARAM ("state = (1.0, nan, 0.0): must be finite"). */
int sm_shaper_set_state(sm_shaper *s, const double z[3], char *msg, size_t msg_len);

#endif

/* The current limit on the measured stator current: satmotor/control/current_limit.py in C (its module
 * docstring is the specification; the same operations in the same order).  Plain struct (byte-copyable
 * state), no global state. */
#ifndef SM_CURRENT_LIMIT_H
#define SM_CURRENT_LIMIT_H

#include <stddef.h>

#define SM_CURRENT_FLOOR 0.1 /* current_limit.CURRENT_FLOOR */
#define SM_CURRENT_WARN 1.05 /* current_limit.CURRENT_WARN */

typedef struct {
    double I_max, gain, Ts, top; /* [A], [1/s], [s], [A] (1 - SM_CURRENT_FLOOR) I_max */
    double i_red;                /* [A] the reduction of the law's bound (state) */
    int warned;                  /* the warning was raised (state) */
} sm_current_limit;

/* CurrentLimiter(I_max, gain, Ts); the values are checked by the drive's configuration. */
void sm_current_limit_init(sm_current_limit *l, double I_max, double gain, double Ts);
void sm_current_limit_reset(sm_current_limit *l);
/* CurrentLimiter.bound: the law's current bound [A] from the measured |i_s| [A]; *warn = 1 at the sample the
 * limit is found not to be held (once per run, as the Python appends its warning), else 0. */
double sm_current_limit_bound(sm_current_limit *l, double i_meas, int *warn);
/* current_limit.current_warning: the same text into msg. */
void sm_current_warning(char *msg, size_t msg_len, double i_meas, double I_max);

#endif

/* satmotor/control/current_limit.py in C (see sm_current_limit.h). */
#include "sm_current_limit.h"

#include <math.h>
#include <stdio.h>

void sm_current_limit_init(sm_current_limit *l, double I_max, double gain, double Ts)
{
    l->I_max = I_max;
    l->gain = gain;
    l->Ts = Ts;
    l->top = (1.0 - SM_CURRENT_FLOOR) * I_max;
    sm_current_limit_reset(l);
}

void sm_current_limit_reset(sm_current_limit *l)
{
    l->i_red = 0.0;
    l->warned = 0;
}

double sm_current_limit_bound(sm_current_limit *l, double i_meas, int *warn)
{
    const double I_max = l->I_max;
    *warn = 0;
    if (l->gain > 0.0 && (l->i_red > 0.0 || i_meas > I_max)) {
        double r = l->i_red + l->Ts * l->gain * (i_meas - I_max);
        l->i_red = fmin(fmax(r, 0.0), l->top);
        if (l->i_red == l->top && i_meas > SM_CURRENT_WARN * I_max && !l->warned) {
            l->warned = 1;
            *warn = 1;
        }
    }
    return I_max - l->i_red;
}

void sm_current_warning(char *msg, size_t msg_len, double i_meas, double I_max)
{
    (void)snprintf(msg, msg_len, "the measured stator current |i_s| = %.4g A exceeds I_max = %.4g A with the law's "
                   "current bound at its floor (%.4g I_max): the current limit cannot be held (logged once per run)",
                   i_meas, I_max, SM_CURRENT_FLOOR);
}

/* The one-sample computational delay and its compensation by prediction: satmotor/control/delay.py in C
 * (its module docstring is the specification).  Plain struct (byte-copyable state). */
#ifndef SM_DELAY_H
#define SM_DELAY_H

#include <stddef.h>

#include "sm_plant.h"

#define SM_DELAY_BIAS_GAIN 0.05 /* [1] per sample: delay.DelayCompensator's default */

typedef struct {
    double Ts, bias_gain;
    double pending[2]; /* [V] the voltage applied over the current sample */
    double pred[5];    /* (i_sd, i_sq, psi_rd, psi_rq, omega) predicted for this sample, flux frame */
    int has_pred;
    double corr[5];
} sm_delay;

int sm_delay_init(sm_delay *d, double Ts, double bias_gain, char *msg, size_t msg_len);
void sm_delay_reset(sm_delay *d);
/* Store the voltage just computed; *va, *vb the one to apply now (the pending one). */
void sm_delay_swap(sm_delay *d, double v_alpha, double v_beta, double *va, double *vb);
/* The measurement vector (SM_MEAS_LEN values) predicted at the next sample under the pending
 * voltage with T_load [N m] held, by the controller's model p.  SM_CORE_OK or a solve/step status. */
int sm_delay_predict(sm_delay *d, const sm_motor *p, const double meas[SM_MEAS_LEN], double T_load,
                     double out[SM_MEAS_LEN]);

#endif

/* The computational delay and a host's coupling delay, compensated by prediction: satmotor/control/delay.py in
 * C (its module docstring is the specification).  Plain struct (byte-copyable state). */
#ifndef SM_DELAY_H
#define SM_DELAY_H

#include <stddef.h>

#include "sm_plant.h"

#define SM_DELAY_BIAS_GAIN 0.05 /* [1] per sample: delay.DelayCompensator's default */
#define SM_DELAY_MAX 4          /* most samples compensated: delay_samples (1) + drive.HOST_DELAY_MAX (3) */

typedef struct {
    double Ts, bias_gain;
    int n;                           /* samples from a voltage's computation to its effect, 1..SM_DELAY_MAX */
    double queue[2 * SM_DELAY_MAX];  /* [V] the voltages over [t_k, t_k+1), ..., [t_k+n-1, t_k+n) (alpha, beta) */
    double applied_now[2];           /* [V] the voltage over [t_k, t_k+1) at the last push */
    double pred[5];    /* (i_sd, i_sq, psi_rd, psi_rq, omega) predicted for this sample, flux frame */
    int has_pred;
    double corr[5];
} sm_delay;

/* DelayCompensator(p, Ts, bias_gain, n_samples): n_samples in 1..SM_DELAY_MAX. */
int sm_delay_init(sm_delay *d, double Ts, double bias_gain, int n_samples, char *msg, size_t msg_len);
void sm_delay_reset(sm_delay *d);
/* DelayCompensator.push: queue the voltage just computed; *va, *vb the controller's output (hold: the one
 * computed one sample earlier, else this one). */
void sm_delay_push(sm_delay *d, double v_alpha, double v_beta, int hold, double *va, double *vb);
/* The measurement vector (SM_MEAS_LEN values) predicted n samples on under the queued voltages with T_load
 * [N m] held, by the controller's model p.  SM_CORE_OK or a solve/step status. */
int sm_delay_predict(sm_delay *d, const sm_motor *p, const double meas[SM_MEAS_LEN], double T_load,
                     double out[SM_MEAS_LEN]);

#endif

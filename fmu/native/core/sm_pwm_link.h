/* The pwm inverter on the capacitor DC link (satmotor/converter/pwm_link.py, its docstring is the
 * specification), in C99: one constant switching interval integrated with the link's voltage as a state,
 * the legs' voltages sigma_j v_dc / 2 + delta_j at every RK4 stage's own v_dc.  The same floats as the
 * Python; no global mutable state. */
#ifndef SM_PWM_LINK_H
#define SM_PWM_LINK_H

#include <stddef.h>

#include "sm_dclink.h"
#include "sm_plant.h"

/* pwm_link.derivatives: dy of the p->n_states + 3 link states followed by the two applied-voltage
 * integrands (v_alpha, v_beta) [V]; sig[j] = +-1, dl[j] [V] the drop terms.  Statuses of
 * sm_plant_derivatives (dy NaN on failure). */
int sm_pwm_link_derivatives(const sm_motor *p, const sm_dclink *l, double t, const double *y, const double sig[3],
                            const double dl[3], double T_load, int chop, double *dy);

/* pwm_link.step: the interval of h [s] in n_sub RK4 sub-steps; x (p->n_states + 3 entries), *chop, *fault
 * updated only on success; *t_fault the sub-step end where the fault was set (NAN otherwise); v_int[2]
 * [V s] the integrals of the applied voltage.  Statuses of sm_plant_step. */
int sm_pwm_link_step(const sm_motor *p, const sm_dclink *l, double t, double *x, const double sig[3],
                     const double dl[3], double T_load, double h, int n_sub, int *chop, int *fault, double *t_fault,
                     double v_int[2]);

/* the link's running state over a pwm step on the capacitor link (PwmInverter.step's lk) */
typedef struct {
    const sm_dclink *l;
    int chop, fault;
    double t_fault; /* the sub-step end where the fault was set in this step (NAN: not yet) */
} sm_pwm_link_run;

/* pwm_link.interval (PwmInverter.step's call on the capacitor link): one constant interval of length L [s]
 * from t in n_sub RK4 sub-steps, the legs' signs sig and drop terms dl [V] held (the inverter's one rule,
 * sm_inverter.c's legs); lk updated on success; v_int[2] [V s] the applied voltage's integrals. */
int sm_pwm_link_interval(const sm_motor *p, sm_pwm_link_run *lk, double *x, double t, double L, const double sig[3],
                         const double dl[3], double T_load, int n_sub, double v_int[2]);

#endif

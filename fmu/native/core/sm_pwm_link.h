/* The pwm inverter on the capacitor DC link (satmotor/machine/pwm_link.py, its docstring is the
 * specification), in C99: one constant switching interval integrated with the link's voltage as a state,
 * the legs' voltages sigma_j v_dc / 2 + delta_j at every RK4 stage's own v_dc.  The same floats as the
 * Python; no global mutable state. */
#ifndef SM_PWM_LINK_H
#define SM_PWM_LINK_H

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

#endif

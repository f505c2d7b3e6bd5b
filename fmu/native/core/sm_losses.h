/* The mechanical and inverter losses of satmotor/machine/losses.py (its docstring is the specification):
 * the parameters' checks, the friction, windage and stray torques, the average inverter's switching loss.
 * The same floats as the Python.  Plain struct, no global mutable state. */
#ifndef SM_LOSSES_H
#define SM_LOSSES_H

#include <stddef.h>

#include "sm_params.h" /* generated: sm_plant_params */

typedef struct {
    double T_fric, k_wind, k_stray, E_sw, V_sw_ref, I_sw_ref; /* LossParams */
    double k_edge;  /* [J/(V A)] LossParams.k_edge: E_sw / 2 / (V_sw_ref I_sw_ref) */
    int mechanical; /* LossParams.mechanical: a friction, windage or stray torque acts */
} sm_losses;

/* LossParams(T_fric, k_wind, k_stray, E_sw, V_sw_ref, I_sw_ref) from the plant's parameters: the checks in
 * that order (>= 0, the two references > 0).  SM_CORE_OK or SM_ERR_PARAM with the ParameterError text. */
int sm_losses_init(sm_losses *lp, const sm_plant_params *pp, char *msg, size_t msg_len);

/* losses.friction_torque: T_fric sign(w) + k_wind w |w| [N m] */
double sm_friction_torque(const sm_losses *lp, double w);

/* losses.loss_torque: the friction, windage and stray torque [N m] at w [rad/s] with |i_s0|^2 = i2 [A2] */
double sm_loss_torque(const sm_losses *lp, double w, double i2);

/* losses.switching_power: 2 f_sw k_edge v_dc sum |i_j| [W] of the phase currents cur [A] */
double sm_switching_power(const sm_losses *lp, double f_sw, double v_dc, const double cur[3]);

#endif

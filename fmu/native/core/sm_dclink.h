/* The DC link inside the plant (satmotor/converter/dc_link.py), in C99: a capacitor fed by a DC source
 * or a six-pulse diode rectifier through a diode and R_src, a lossless average-value inverter whose
 * voltage is bounded by v_dc/sqrt(3), a brake chopper with hysteresis switched at sub-step ends, and a
 * latched over-voltage fault.  The state is the motor's (sm_plant.h: p->n_states, six or eight with the
 * thermal model) followed by v_dc [V], E_regen [J], E_chop [J] at sm_dclink_iv(p) = p->n_states, +1, +2
 * (SM_V_DC, SM_E_REGEN, SM_E_CHOP without the thermal model); the terminal current that sets the link's
 * current includes the core branch's with R_fe.  Caller-owned struct, no pointers inside; the same
 * floats as the Python. */
#ifndef SM_DCLINK_H
#define SM_DCLINK_H

#include <stddef.h>

#include "sm_common.h"
#include "sm_params.h" /* generated: sm_dclink_params */
#include "sm_plant.h"

enum { SM_V_DC = SM_N_STATES, SM_E_REGEN, SM_E_CHOP, SM_N_LINK_STATES };
enum { SM_N_LINK_STATES_MAX = SM_N_STATES_MAX + 3 }; /* with the thermal model: 11 */

/* DCLink.iv: v_dc's place in the state, after the motor's p->n_states */
#define sm_dclink_iv(p) ((p)->n_states)

typedef struct {
    int capacitor;    /* dc_link = capacitor (0: ideal, today's plant) */
    int src_dc;       /* dc_source = dc (0: rectifier) */
    int chop_enabled; /* R_chop > 0 */
    double V_dc, C_dc, R_src, V_grid, f_grid, V_chop_on, V_chop_off, R_chop, V_dc_max;
    /* derived, as DCLink.__init__ */
    double inv_R_src, inv_C, inv_R_chop, amp, omega_g, third, sixth;
} sm_dclink;

/* DCLinkParams(...) checks in its order (after the finiteness of every Real member): dc_link,
 * dc_source, V_dc, C_dc, R_src, V_grid, f_grid > 0, R_chop >= 0, V_dc_max >= 0, and with R_chop > 0
 * V_chop_on > 0, V_chop_off > 0, V_chop_off < V_chop_on.  SM_CORE_OK, SM_ERR_PARAM (msg: the
 * ParameterError text), SM_ERR_ARG (NULL). */
int sm_dclink_init(sm_dclink *l, const sm_dclink_params *pp, char *msg, size_t msg_len);

size_t sm_dclink_size(void);

/* DCLink.source_voltage: V_dc, or sqrt(2) V_grid cos(phi) (the six-pulse envelope) [V] */
double sm_dclink_source_voltage(const sm_dclink *l, double t);

/* DCLink.applied: the command, scaled onto |v| = v_dc/sqrt(3) beyond it; 0 for v_dc <= 0 */
void sm_dclink_applied(double v_a, double v_b, double v_dc, double *out_a, double *out_b);

/* DCLink.derivatives: dx of the p->n_states + 3 states with the chopper state chop held.  Statuses of
 * sm_plant_derivatives (dx NaN on failure). */
int sm_dclink_derivatives(const sm_motor *p, const sm_dclink *l, double t, const double *x, double v_a,
                          double v_b, double T_load, int chop, double *dx);

/* DCLink.rates: r = (d v_dc/dt, d E_regen/dt, d E_chop/dt) at link voltage v_dc [V] with the power p_inv [W]
 * drawn by the inverter (average or pwm) and the chopper state chop held */
void sm_dclink_rates(const sm_dclink *l, double t, double v_dc, double p_inv, int chop, double r[3]);

/* DCLink.switch: the chopper's state after a sub-step ending at v_dc (hysteresis) */
int sm_dclink_switch(const sm_dclink *l, double v_dc, int chop);

/* DCLink.substep_end: at a sub-step's end t_end [s], *chop switched and the over-voltage fault latched
 * (*t_fault = t_end where *fault is first set) */
void sm_dclink_substep_end(const sm_dclink *l, double v_dc, double t_end, int *chop, int *fault, double *t_fault);

/* DCLink.step: RK4 over dt in n_sub sub-steps, the chopper switching and the fault latching at the
 * sub-step ends; x (p->n_states + 3 entries), *chop, *fault updated only on success; *t_fault the
 * sub-step end where the fault was set in this call (NAN otherwise).  Statuses of sm_plant_step. */
int sm_dclink_step(const sm_motor *p, const sm_dclink *l, double t, double *x, double v_a,
                   double v_b, double T_load, double dt, int n_sub, int *chop, int *fault, double *t_fault);

/* dc_link.over_voltage_message */
void sm_dclink_over_voltage_message(double t, double v_dc, double V_dc_max, char *msg, size_t msg_len);

#endif

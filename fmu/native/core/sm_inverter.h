/* The plant's inverter of satmotor/converter/inverter.py (its docstring is the specification): average-value
 * or carrier-comparison PWM with dead time and on-state drops, integrated to the exact switching instants;
 * and the controller's dead-time compensation of satmotor/control/deadtime.py.  The same floats as the
 * Python.  Plain struct (byte-copyable: part of the FMU state), no global mutable state. */
#ifndef SM_INVERTER_H
#define SM_INVERTER_H

#include <stddef.h>

#include "sm_common.h"
#include "sm_dclink.h"
#include "sm_params.h" /* generated: sm_plant_params */
#include "sm_plant.h"

#define SM_INV_MERGE_REL 1e-6      /* inverter.MERGE_REL: events closer than this many T_h are merged */
#define SM_INV_EVENTS_PER_HALF 12  /* inverter.EVENTS_PER_HALF */
#define SM_INV_TRACE_WIDTH 7       /* a trace row: t_start, length, v_alpha, v_beta, v_a, v_b, v_c */

typedef struct {
    int pwm; /* inverter: 0 average, 1 pwm */
    double V_dc, f_sw, t_dead, v_on, T_h, eps;
    /* switching state (PwmInverter's) */
    int have;    /* the duties of half period k are held */
    long long k; /* that half period */
    double d[3];
    int s[3];    /* the legs' ideal states; -1 unknown (before the first step) */
    int dead[3];
    double dead_until[3], dead_v[3];
    /* the losses (satmotor/machine/losses.py): an edge's energy per V and A (PwmInverter.k_edge, set by the
     * plant unit from its sm_losses); the last step's E_term, E_cond, E_sw, E_cu_s, E_fe [J]
     * (PwmInverter.energies) */
    double k_edge, energies[5];
} sm_inverter;

/* InverterParams(V_dc, inverter, f_sw, t_dead, v_on) checks in their order (finiteness: the plant
 * struct's sm_plant_params_require_finite, in sm_motor_init), then the reset state.  V_dc [V]: the
 * link voltage, the dclink parameter V_dc (sm_dclink_params; one parameter for the link and the
 * inverter).  SM_CORE_OK or
 * SM_ERR_PARAM with the ParameterError text. */
int sm_inverter_init(sm_inverter *inv, const sm_plant_params *pp, double V_dc, char *msg, size_t msg_len);
void sm_inverter_reset(sm_inverter *inv);

/* The DC-link voltage [V] the inverter switches: the one place the plant reads it. */
double sm_inverter_link_voltage(const sm_inverter *inv);

/* inverter.duties: min-max zero-sequence injection, clipped to [0, 1]. */
void sm_inverter_duties(double v_alpha, double v_beta, double V_dc, double d[3]);

/* PwmInverter.intervals_bound(dt): 12 (ceil(dt / T_h) + 1) + 1, as a double. */
double sm_inverter_intervals_bound(const sm_inverter *inv, double dt);

/* PwmInverter.step: x (the plant state, p->n_states entries) advanced from t0 over dt [s] with the command (v_alpha, v_beta)
 * [V] and T_load [N m] held; v_avg the step averages [V] of the applied alpha/beta voltage.  trace
 * (may be NULL): up to trace_cap rows of SM_INV_TRACE_WIDTH doubles, one per integrated interval;
 * *trace_n (may be NULL) the number of intervals (also beyond trace_cap).  On any failure (a status
 * of sm_plant_step or sm_plant_outputs_of) x and inv are unchanged. */
int sm_inverter_step(sm_inverter *inv, const sm_motor *p, double *x, double t0, double dt, double v_alpha,
                     double v_beta, double T_load, double v_avg[2], double *trace, size_t trace_cap,
                     size_t *trace_n);

/* sm_inverter_step with the plant's solve memo (NULL: none; sm_plant_step_memo, sm_plant_outputs_memo):
 * the same results, fewer curve solves (the currents at an interval's start and its first RK4 stage). */
int sm_inverter_step_memo(sm_inverter *inv, const sm_motor *p, sm_solve_memo *memo, double *x, double t0,
                          double dt, double v_alpha, double v_beta, double T_load, double v_avg[2], double *trace,
                          size_t trace_cap, size_t *trace_n);

/* PwmInverter.step on the capacitor link l (satmotor/converter/pwm_link.py): x has p->n_states + 3 entries
 * (the link's v_dc, E_regen, E_chop last); *chop, *fault as sm_dclink_step's, *t_fault the sub-step end
 * where the fault was set in this step (NAN otherwise).  On failure nothing is changed. */
int sm_inverter_step_link(sm_inverter *inv, const sm_motor *p, const sm_dclink *l, sm_solve_memo *memo, double *x,
                          double t0, double dt, double v_alpha, double v_beta, double T_load, double v_avg[2],
                          int *chop, int *fault, double *t_fault, double *trace, size_t trace_cap, size_t *trace_n);

/* deadtime.compensate: (v_alpha, v_beta) [V] with sign(i_phase) V_comp added per phase from the measured
 * (i_alpha, i_beta) [A]; unchanged for V_comp = 0. */
void sm_deadtime_compensate(double *v_alpha, double *v_beta, double i_alpha, double i_beta, double V_comp);

size_t sm_inverter_size(void);

#endif

/* The plant as a co-simulation unit: PlantUnit of satmotor/interface.py in C (its docstrings are the
 * specification).  Its parameters by name in three generated structs (the motor's sm_motor_params, the
 * plant's own sm_plant_params, the link's sm_dclink_params: PLANT_PARAMETERS), the inputs and outputs in
 * the order of PLANT_INPUTS / PLANT_OUTPUTS (SM_PLANT_IN_* / SM_PLANT_OUT_*), a step over a communication
 * interval for every inverter (average, pwm) and link (ideal, capacitor).  Warnings (plausibility,
 * over-voltage) are returned as text in the unit for the host's log; no FMI in here.  Plain struct, no
 * pointers inside: a byte copy is a valid copy (an FMU state). */
#ifndef SM_PLANT_UNIT_H
#define SM_PLANT_UNIT_H

#include <stddef.h>

#include "sm_dclink.h"
#include "sm_inverter.h"
#include "sm_plant.h"

#include "sm_params.h" /* generated: the parameter structs, SM_PLANT_N_IN/OUT, SM_PLANT_IN_* / SM_PLANT_OUT_* */

#define SM_PLANT_MAX_WARNINGS 4 /* in one step at most: |v_s|, the over-voltage, |i_s|, |omega_m| */
#define SM_PLANT_INVERTER_STATE 17 /* PwmInverter.get_state's length */
/* PlantUnit.get_state's length at most: the states, chop and fault, the held voltage, load and step means,
 * the inverter's */
#define SM_PLANT_STATE_MAX (SM_N_LINK_STATES_MAX + 2 + 2 + 6 + SM_PLANT_INVERTER_STATE)

typedef struct {
    sm_motor p;
    sm_dclink link;  /* the DC link (satmotor/converter/dc_link.py); link.capacitor: its states in x */
    sm_inverter inv; /* the stator voltage source (average-value or pwm, with its switching state) */
    sm_solve_memo memo; /* the outputs' solve at x, reused by the next step's first stage */
    /* the motor's states (p.n_states: six, eight with the thermal model), then (capacitor) v_dc, E_regen,
     * E_chop at sm_dclink_iv(&p); n_x of them in use */
    double x[SM_N_LINK_STATES_MAX];
    int n_x;
    int chop, fault; /* the chopper's state, the latched over-voltage fault */
    double v[2];     /* [V] the stator voltage held over the last step (pwm: its step average) */
    double T_load;   /* [N m] the load held over the last step (P_mech) */
    /* [W] the last step's means (PlantUnit._means): into the terminals, the inverter's loss (pwm), the
     * chopper's; instant (the model-exchange plant): P_in and P_inv at the instant instead */
    double means[3];
    double pwm_means[2]; /* [W] pwm: the last step's means of P_cu_s, P_fe (PlantUnit._pwm_means) */
    int instant;
    int max_substeps;
    double warn[3];  /* [V, A, rad/s] v_warn, i_warn, omega_warn (0: no check) */
    int warned[3];   /* that plausibility warning was given in this run */
    /* warnings for the host's log, in their order (PlantUnit.warnings): the host logs and clears them */
    int n_warnings;
    char warnings[SM_PLANT_MAX_WARNINGS][SM_MSG_LEN];
    double out[SM_PLANT_N_OUT]; /* PlantUnit.outputs() (dc_fault as 0/1), kept current by every call */
} sm_plant_unit;

/* PlantUnit(values): every check in its order (the file of a table curve, m->table_file, already
 * resolved by the host); SM_CORE_OK, SM_ERR_PARAM (msg: the ParameterError text), SM_ERR_NOCONV,
 * SM_ERR_ARG for a NULL pointer.  The outputs at the initial state (zero held voltage) in u->out. */
int sm_plant_unit_init(sm_plant_unit *u, const sm_motor_params *m, const sm_plant_params *pp,
                       const sm_dclink_params *lp, char *msg, size_t msg_len);

/* PlantUnit.step(t, dt, inputs): advance over dt [s] with the inputs (v_s_alpha [V], v_s_beta [V],
 * T_load [N m]) held; the outputs in u->out, warnings appended to u->warnings.  A refused step (bad
 * input or step size, more than max_substeps sub-steps) and a failed one (non-finite state, a solve
 * that did not converge) return nonzero with the message and change nothing but the |v_s| warning. */
int sm_plant_unit_step(sm_plant_unit *u, double t, double dt, const double in[SM_PLANT_N_IN], char *msg,
                       size_t msg_len);

/* PlantUnit.outputs() into u->out from the state and the held voltage (PlantUnit._held: average
 * inverter on a capacitor link, the command as the link bounds it at the state's v_dc) */
void sm_plant_unit_publish(sm_plant_unit *u);

/* Model exchange: PlantUnit.plant.derivatives (ideal link) or PlantUnit._link.derivatives (capacitor,
 * the chopper state u->chop held) at t [s], x (u->n_x entries) and the inputs into dx (u->n_x).
 * Statuses of sm_plant_derivatives. */
int sm_plant_unit_derivatives(const sm_plant_unit *u, double t, const double *x, const double in[SM_PLANT_N_IN],
                              double *dx);

/* PlantUnit.get_state into s (cap entries at least sm_plant_unit_state_size); returns the length */
size_t sm_plant_unit_state_size(const sm_plant_unit *u);
size_t sm_plant_unit_get_state(const sm_plant_unit *u, double *s, size_t cap);
/* PlantUnit.set_state from n = sm_plant_unit_state_size values (SM_ERR_ARG otherwise), the outputs
 * published from it */
int sm_plant_unit_set_state(sm_plant_unit *u, const double *s, size_t n);

/* the message of quantity k (0: |v_s|, 1: |i_s|, 2: |omega_m|) above its bound (plausibility_message) */
void sm_plant_plausibility_message(int k, double t, double value, double bound, char *msg, size_t msg_len);

size_t sm_plant_unit_size(void);
/* for hosts without this header (ctypes): the byte offsets of out, n_warnings and warnings */
void sm_plant_unit_offsets(size_t off[3]);

#endif

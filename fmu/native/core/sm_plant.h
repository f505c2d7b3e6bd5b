/* The stationary-frame saturated induction motor of satmotor/machine/plant.py (flux states) and the
 * checks of satmotor/interface.py PlantUnit, in C99.  Caller-owned structs, no pointers inside
 * (a byte copy of sm_motor is a valid copy); the same floats as the Python. */
#ifndef SM_PLANT_H
#define SM_PLANT_H

#include <stddef.h>

#include "sm_common.h"
#include "sm_curves.h"
#include "sm_losses.h"
#include "sm_params.h" /* generated: sm_motor_params, sm_plant_params (orchestration/packaging/native/tables.py) */

/* state x = [psi_s_alpha, psi_s_beta, psi_r_alpha, psi_r_beta, omega_m, theta_m], with the thermal model
 * on (sm_motor.thermal) two more: [..., T_s, T_r] (SM_N_STATES_MAX; sm_motor.n_states says which) */
enum { SM_PSI_S_A, SM_PSI_S_B, SM_PSI_R_A, SM_PSI_R_B, SM_OMEGA_M, SM_THETA_M, SM_N_STATES };
enum { SM_T_S = SM_N_STATES, SM_T_R, SM_N_STATES_MAX };

typedef struct {
    double R_s, R_r, l_s, l_r, k;
    int n_p;
    double J, B, B_2;
    sm_curve curve;
    /* derived constants, as Plant.__init__ precomputes them */
    double inv_ls, k_lr, le, kappa, inv_J, m0;
    int gamma; /* l_s == 0: the Gamma-equivalent model (Plant._gamma) */
    /* PlantUnit parameters */
    double omega_m0, psi_r0, h_int;
    /* core loss and the thermal model (satmotor/machine/thermal.py; Plant.R_fe, Plant.th) */
    double R_fe, R_s_ref, R_r_ref; /* R_s, R_r above: at T_s0, T_r0; R_s_ref, R_r_ref: at T_ref */
    double T_amb, T_s0, T_r0, T_ref, alpha_s, alpha_r, C_th_s, C_th_r, R_th_s, R_th_r, R_th_sr;
    int thermal, ext; /* ext: R_fe > 0 or thermal (Plant._ext: the general path) */
    sm_losses lp;     /* the friction, windage, stray and switching losses (Plant.lp) */
    int n_states;     /* SM_N_STATES, or SM_N_STATES_MAX with the thermal model on */
    double x0[SM_N_STATES_MAX]; /* initial_state(params, omega_m0, psi_r_alpha = psi_r0) + (T_s0, T_r0) */
} sm_motor;

/* The checks of PlantUnit(values) in its order: finiteness of every flat Real parameter
 * (interface._number, in the order of PLANT_PARAMETERS), make_curve, MotorParams, psi_r0 >= 0,
 * h_int > 0, max_substeps >= 1, v_warn, i_warn, omega_warn >= 0, B_2 >= 0, R_fe >= 0, the thermal
 * parameters, then the initial state.  m: the motor parameters (MOTOR_PARAMETERS); pp: the
 * plant's own (sm_plant_params), NULL for their defaults (the controller's model of the
 * motor).  Returns SM_CORE_OK, SM_ERR_PARAM (msg: the ParameterError text), SM_ERR_NOCONV (the
 * initial state's inverse curve did not converge), SM_ERR_ARG (p or m NULL). */
int sm_motor_init(sm_motor *p, const sm_motor_params *m, const sm_plant_params *pp, char *msg, size_t msg_len);

/* sizeof(sm_motor), for hosts that allocate it without the header (ctypes). */
size_t sm_motor_size(void);

/* The arguments (a, c) and the root (I [A], psi [Wb]) of the last cold magnetizing-curve solve of a plant:
 * a cold solve with the same (a, c) returns the kept root instead of solving again (the outputs at x and
 * the first RK4 stage of the next step solve the same equation).  The same arguments give the same root,
 * so no result depends on the memo (a copy, a stale or an empty one: sm_solve_memo_clear, all NaN).  Not
 * in Python: there every solve is made. */
typedef struct {
    double a, c, I, psi;
} sm_solve_memo;

void sm_solve_memo_clear(sm_solve_memo *memo);

typedef struct {
    double i_s_alpha, i_s_beta, i_r_alpha, i_r_beta, i_mu_alpha, i_mu_beta, i_mu, psi_m, m, T_e;
    double P_fe, T_s, T_r; /* [W] core loss, [K] temperatures (PlantOutputs) */
} sm_plant_outputs;

/* Plant.derivatives (its inlined fast path; the general path with R_fe or the thermal model: x and dx
 * then have p->n_states entries).  SM_CORE_OK; SM_ERR_NONFINITE if x or an input is not
 * finite (dx is then filled with NaN); SM_ERR_NOCONV if the curve solve did not converge. */
int sm_plant_derivatives(const sm_motor *p, const double *x, double v_a, double v_b, double T_load,
                         double *dx);

/* Plant.derivatives(t, x, v_a, v_b, T_load, warm): the solve starts from *warm (NULL or 0.0: cold) and
 * leaves its root there; memo: NULL or sm_solve_memo (used by cold solves only).  x and dx have
 * p->n_states entries (every path: the fast one and the general one with R_fe or the thermal model). */
int sm_plant_derivatives_from(const sm_motor *p, const double *x, double v_a, double v_b, double T_load,
                              double *dx, double *warm, sm_solve_memo *memo);

/* Plant.outputs(x, v_a, v_b): with R_fe > 0 the terminal current and P_fe depend on the stator voltage
 * [V].  x has p->n_states entries.  Same statuses as sm_plant_derivatives. */
int sm_plant_outputs_v(const sm_motor *p, const double *x, double v_a, double v_b, sm_plant_outputs *o);

/* Plant.outputs(x) (zero voltage): sm_plant_outputs_v(p, x, 0, 0, o). */
int sm_plant_outputs_of(const sm_motor *p, const double *x, sm_plant_outputs *o);

/* sm_plant_outputs_v with a memo (NULL: none): the same results. */
int sm_plant_outputs_memo(const sm_motor *p, sm_solve_memo *memo, const double *x, double v_a, double v_b,
                          sm_plant_outputs *o);

/* Plant.step: RK4 over dt in n_sub equal sub-steps (integrate.rk4) of the p->n_states states (the solves
 * of stages 2 to 4 warm-started from the previous stage's root, as Plant.step), x updated in place only
 * on success.  SM_CORE_OK; SM_ERR_NONFINITE if the state became (or an input is) non-finite;
 * SM_ERR_NOCONV; SM_ERR_ARG for n_sub < 1 or a NULL pointer. */
int sm_plant_step(const sm_motor *p, double *x, double v_a, double v_b, double T_load, double dt,
                  int n_sub);

/* sm_plant_step with a memo (NULL: none): the same results. */
int sm_plant_step_memo(const sm_motor *p, sm_solve_memo *memo, double *x, double v_a, double v_b,
                       double T_load, double dt, int n_sub);

/* Plant.powers(x, o, T_load): out = (P_cu_s, P_cu_r, P_fe, P_fw, P_stray, P_mech) [W] at x with its outputs
 * o (sm_plant_outputs_memo at the voltage applied); memo as there.  Statuses of sm_plant_outputs_v. */
int sm_plant_powers(const sm_motor *p, sm_solve_memo *memo, const double *x, const sm_plant_outputs *o,
                    double T_load, double out[6]);

/* Plant._resistances(x)[0]: R_s [Ohm] at x's stator temperature (thermal on), else the constant one */
double sm_plant_stator_resistance(const sm_motor *p, const double *x);

/* plant.initial_state(params, omega_m, theta_m, psi_r_alpha, psi_r_beta) into x.  SM_CORE_OK,
 * SM_ERR_NONFINITE, SM_ERR_NOCONV. */
int sm_plant_initial_state(const sm_motor *p, double omega_m, double theta_m, double psi_r_alpha,
                           double psi_r_beta, double x[6]);

/* PlantUnit.step's per-step checks: finite inputs (msg "v_s_alpha = nan: must be a finite
 * number"), dt > 0 ("communicationStepSize = ..."); *n_sub = max(1, ceil(dt / h_int - 1e-9)). */
int sm_plant_check_step(const sm_motor *p, double v_a, double v_b, double T_load, double dt,
                        int *n_sub, char *msg, size_t msg_len);

/* PlantUnit.step's message for a non-finite state after a step over [t, t + dt]:
 * "the plant state became non-finite over [t, t+dt] s: (x0, ..., x5)". */
void sm_plant_nonfinite_message(double t, double dt, const double x[6], char *msg, size_t msg_len);

#endif

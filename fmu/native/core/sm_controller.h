/* The controller as a co-simulation unit: ControllerUnit of satmotor/interface.py in C.  Its
 * parameters by name in two generated structs (the controller's own, sm_controller_params, and the
 * motor's, sm_motor_params: the CONTROLLER_PARAMETERS table), the inputs and outputs in the order of
 * CONTROLLER_INPUTS / CONTROLLER_OUTPUTS, n samples per step of length n Ts (sm_controller_samples).
 * Plain struct. */
#ifndef SM_CONTROLLER_H
#define SM_CONTROLLER_H

#include <stddef.h>

#include "sm_drive.h"
#include "sm_inverter.h" /* sm_deadtime_compensate */

#include "sm_params.h" /* generated: sm_controller_params, sm_motor_params, SM_CONTROLLER_N_IN/OUT */

/* the communication step rule (ControllerUnit.samples, the same constants as satmotor/interface.py) */
#define SM_STEP_ULPS 8.0          /* |dt - n Ts| <= SM_STEP_ULPS eps max(n Ts, |t|, |t + dt|) */
#define SM_MAX_SAMPLES 1e9        /* at most this many samples in one step */
#define SM_STOP_REMAINDER 1e-6    /* zero samples: a step of at most this many Ts that ends at the stop time */

typedef struct {
    sm_drive drive;
    int has_warning;  /* a warning for the host's log is in warning (the FMU logs it and clears the flag) */
    char warning[256];
    double V_dc, link; /* [V] the parameter V_dc; the link voltage the drive now uses (the v_dc input) */
    double Ts;
    double deadtime_comp; /* [V] deadtime_comp_voltage (0: off) */
    long max_samples; /* the parameter max_samples: most samples one step may run (a longer step: refused) */
    double stop_time; /* the host's stop time [s], +inf when it gave none (set after sm_controller_init);
                       * the tests find it just before out */
    double out[SM_CONTROLLER_N_OUT]; /* Integer and Boolean outputs as 0/1 values */
} sm_controller;

/* ControllerUnit(values) from its parameters v and the motor's m (defaults of both:
 * sm_controller_params_default, sm_motor_params_default): every check in its order; SM_CORE_OK,
 * SM_ERR_PARAM with the message, SM_ERR_ARG for a NULL pointer. */
int sm_controller_init(sm_controller *u, const sm_controller_params *v, const sm_motor_params *m, char *msg,
                       size_t msg_len);
/* ControllerUnit.samples(t, dt): the number of samples a communication step from t of length dt
 * [s] runs: n >= 1 when dt is n Ts to a few ulps (SM_STEP_ULPS of the largest of n Ts, |t|, |t + dt|),
 * 0 for a remainder of at most SM_STOP_REMAINDER Ts that ends at stop_time (a host's time that
 * accumulated in floating point, clipped to its stop time), -1 for any other step (refused). */
long sm_controller_samples(const sm_controller *u, double t, double dt);
/* ControllerUnit.step(t, dt, inputs): sm_controller_samples(t, dt) samples with the same inputs (held
 * over the step); a refused step (also one of more than max_samples samples, refused before any work),
 * non-finite inputs and bad set-points give SM_ERR_PARAM with the message and change nothing. */
int sm_controller_step(sm_controller *u, double t, double dt, const double in[SM_CONTROLLER_N_IN], char *msg,
                       size_t msg_len);
size_t sm_controller_size(void);

/* Generated (sm_params.c, from satmotor/interface.py's tables): the settings structs from the flat
 * parameters v, each its defaults (sm_gains_default, ...) and then every member a parameter fills
 * (Variable.fills) its value (a Boolean as 0/1, a coded String as its flag); no check (v is checked
 * first).  And one sample's outputs in the order of CONTROLLER_OUTPUTS, each the member of its name of
 * the drive's output d (flags as 0/1). */
void sm_controller_settings(const sm_controller_params *v, sm_gains *gains, sm_law_config *law_config,
                            sm_drive_config *drive_config, sm_ifoc_gains *ifoc_gains);
void sm_controller_outputs_of(const sm_drive_output *d, double out[SM_CONTROLLER_N_OUT]);

#endif

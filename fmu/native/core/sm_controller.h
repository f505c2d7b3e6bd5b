/* The controller as a co-simulation unit: ControllerUnit of satmotor/interface.py in C.  Its
 * parameters by name in two generated structs (the controller's own, sm_controller_params, and the
 * motor's, sm_motor_params: the CONTROLLER_PARAMETERS table), the inputs and outputs in the order of
 * CONTROLLER_INPUTS / CONTROLLER_OUTPUTS, one sample per step of length Ts.  Plain struct. */
#ifndef SM_CONTROLLER_H
#define SM_CONTROLLER_H

#include <stddef.h>

#include "sm_drive.h"

#include "sm_params.h" /* generated: sm_controller_params, sm_motor_params, SM_CONTROLLER_N_IN/OUT */

typedef struct {
    sm_drive drive;
    double Ts;
    double out[SM_CONTROLLER_N_OUT]; /* Integer and Boolean outputs as 0/1 values */
} sm_controller;

/* ControllerUnit(values) from its parameters v and the motor's m (defaults of both:
 * sm_controller_params_default, sm_motor_params_default): every check in its order; SM_CORE_OK,
 * SM_ERR_PARAM with the message, SM_ERR_ARG for a NULL pointer. */
int sm_controller_init(sm_controller *u, const sm_controller_params *v, const sm_motor_params *m, char *msg,
                       size_t msg_len);
/* ControllerUnit.step(t, dt, inputs): dt must equal Ts; non-finite inputs and bad set-points give
 * SM_ERR_PARAM with the message and change nothing. */
int sm_controller_step(sm_controller *u, double t, double dt, const double in[SM_CONTROLLER_N_IN], char *msg,
                       size_t msg_len);
size_t sm_controller_size(void);

#endif

/* The controller as a co-simulation unit: ControllerUnit of satmotor/interface.py in C.  Its
 * parameters by name (the CONTROLLER_PARAMETERS table), the inputs and outputs in the order of
 * CONTROLLER_INPUTS / CONTROLLER_OUTPUTS, one sample per step of length Ts.  Plain struct. */
#ifndef SM_CONTROLLER_H
#define SM_CONTROLLER_H

#include <stddef.h>

#include "sm_drive.h"

#define SM_CTRL_N_IN 10
#define SM_CTRL_N_OUT 18
#define SM_STR_MAX 1024

/* Every parameter of CONTROLLER_PARAMETERS (motor ones under the plant's names). */
typedef struct {
    double c1, c2, d1, d2, c0, d0, Ts, V_dc, ref_bandwidth, g_theta, theta_max, I_max;
    int delay_samples, use_stator_flux;
    char mode[SM_STR_MAX], load_mode[SM_STR_MAX], flux_source[SM_STR_MAX];
    double R_s, R_r, l_s, l_r, k, J, B, L_m0, L_m_inf, I_par, poly_b;
    int n_p, poly_n;
    char curve[SM_STR_MAX], table_file[SM_STR_MAX];
} sm_controller_params;

typedef struct {
    sm_drive drive;
    double Ts;
    double out[SM_CTRL_N_OUT]; /* Integer and Boolean outputs as 0/1 values */
} sm_controller;

/* The defaults of the interface tables. */
void sm_controller_params_default(sm_controller_params *v);
/* ControllerUnit(values): every check in its order; SM_CORE_OK or SM_ERR_PARAM with the message. */
int sm_controller_init(sm_controller *u, const sm_controller_params *v, char *msg, size_t msg_len);
/* ControllerUnit.step(t, dt, inputs): dt must equal Ts; non-finite inputs and bad set-points give
 * SM_ERR_PARAM with the message and change nothing. */
int sm_controller_step(sm_controller *u, double t, double dt, const double in[SM_CTRL_N_IN], char *msg,
                       size_t msg_len);
size_t sm_controller_size(void);
size_t sm_controller_params_size(void);

#endif

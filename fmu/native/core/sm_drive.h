/* The sampled drive around the control law, and the controller unit: satmotor/control/drive.py and the
 * ControllerUnit of satmotor/interface.py in C (their docstrings are the specification).  Modes:
 * saturated (the backstepping law with the curve), constant_m (the same law, m = m(0)), pi (the IFOC
 * baseline).  Plain struct (byte-copyable: the FMU state).  C99, no global mutable state. */
#ifndef SM_DRIVE_H
#define SM_DRIVE_H

#include <stddef.h>

#include "sm_current_limit.h"
#include "sm_delay.h"
#include "sm_flux_observer.h"
#include "sm_fieldweak.h"
#include "sm_ifoc.h"
#include "sm_law.h"
#include "sm_lossmin.h"
#include "sm_observer.h"
#include "sm_params.h" /* generated: sm_mode_choice */
#include "sm_references.h"

typedef sm_mode_choice sm_mode; /* the controller's parameter mode: SM_CHOICE_mode_saturated, ... */
enum { SM_PREMAG = 0, SM_RUN = 1 };

/* drive.DriveConfig */
typedef struct {
    double ref_bandwidth, I_max, premag_fraction, premag_boost, premag_gain, premag_time_max;
    double premag_min_fraction, premag_speed_tol;
    int observer;      /* flux_source: 0 measured, 1 observer */
    int delay_samples; /* 0 or 1 */
    int closed_loop;     /* observer: 1 closed_loop, 0 current_model */
    int speed_estimated; /* speed_source: 0 measured, 1 estimated */
    double speed_bandwidth; /* [rad/s] the speed estimate's adaptation */
    int field_weakening;     /* 0/1: the flux set-point of sm_fieldweak.h, or psi_ref as it is */
    double fw_voltage_ratio; /* [1] in (0, 1] */
    double current_limit_gain; /* [1/s] of the measured-current limiter (sm_current_limit.h), >= 0; 0: off */
    int host_delay_samples;    /* 0..SM_HOST_DELAY_MAX: the host's coupling delay, compensated with delay_samples */
    int loss_minimizing;       /* flux_mode: 0 nominal, 1 loss_minimizing (sm_lossmin.h) */
    double flux_floor;         /* [Wb] loss_minimizing: the lowest set-point, > 0 */
    double flux_rate_max;      /* [V s/s] loss_minimizing: the set-point's largest rate, > 0 */
    double loss_R_fe;          /* [Ohm] loss_minimizing: the loss model's core-loss resistance, >= 0 */
    int rs_adaptation; /* 0/1: the closed-loop observer adapts R_s, the law uses it (resistance.py) */
    int rr_tracking;   /* 0/1: R_r from the temperature R_s_hat implies (needs rs_adaptation) */
} sm_drive_config;

#define SM_HOST_DELAY_MAX 3 /* drive.HOST_DELAY_MAX */

/* The Python defaults, DriveConfig() (defined in the generated sm_params.c). */
void sm_drive_config_default(sm_drive_config *dc);

/* drive.DriveOutput (flags 0/1). */
typedef struct {
    double v_s_alpha, v_s_beta, v_sd, v_sq, e1, e2, z1, z2, V, W, T_load_est;
    double omega_ref_shaped, psi_ref_shaped; /* the shaped references (pre-magnetization: the shapers at rest) */
    int phase, voltage_limited, singular_limited, current_limited;
    double psi_r_hat_alpha, psi_r_hat_beta;
    double omega_m_hat; /* [rad/s] the speed the drive used (the estimate, or the measurement); Python:
                         * the drive's property omega_m_hat */
    int current_warning; /* 1 at the sample the current limit is found not to be held (Python: the drive's
                          * warnings list gets sm_current_warning's text, with i_s_meas) */
    double i_s_meas;     /* [A] the measured |i_s| of the run phase (0 before the law runs) */
    double R_s_hat, R_r_hat; /* [Ohm] the law's model after the sample; Python: the drive's property resistances */
} sm_drive_output;

typedef struct {
    sm_mode mode;
    sm_motor p; /* the controller's model (constant_m: its curve replaced by the line m(0)) */
    sm_gains g;
    sm_law_config cfg;
    sm_ifoc ifoc;
    sm_drive_config dc;
    double Ts, V_max;
    long n_switch;
    int has_checked;
    double checked_psi, checked_I;
    sm_shaper flux, speed;
    sm_observer obs;
    sm_cl_observer clo; /* the closed-loop observer (dc.observer && dc.closed_loop) */
    sm_delay delay; /* dc.delay_samples + dc.host_delay_samples > 0 */
    sm_fieldweak fw; /* dc.field_weakening or dc.loss_minimizing (its torque and speed) */
    sm_lossmin lm;   /* dc.loss_minimizing */
    sm_current_limit limiter;
    double i_lim; /* [A] the law's current bound this sample (below I_max beyond the breakdown torque) */
    /* state */
    int phase;
    long n;
    double theta_hat, e0, z0;
} sm_drive;

/* The drive of one mode around the motor model p (copied), gains, law config (Ts > 0: a sampled
 * drive), IFOC gains (pi mode) and the drive config.  SM_CORE_OK or SM_ERR_PARAM with the message. */
int sm_drive_init(sm_drive *d, sm_mode mode, const sm_motor *p, const sm_gains *g, const sm_law_config *cfg,
                  const sm_ifoc_gains *ig, const sm_drive_config *dc, char *msg, size_t msg_len);
void sm_drive_reset(sm_drive *d);
/* _Drive.set_link_voltage: V_max = V_dc / sqrt(3) [V] from a measured link voltage V_dc > 0 for the
 * pre-magnetization, the law (cfg.V_dc, or the IFOC's bound) and the field weakening. */
void sm_drive_set_link_voltage(sm_drive *d, double V_dc);
/* One sample (drive._Drive.step): meas[SM_MEAS_LEN] = (i_s_alpha, i_s_beta, psi_r_alpha, psi_r_beta,
 * psi_s_alpha, psi_s_beta, omega_m), the controller's first inputs in their order; the raw set-points
 * omega_ref [rad/s], psi_ref [Wb] (shaped inside: omega_ref_shaped, psi_ref_shaped); load torque [N m].
 * SM_CORE_OK; on SM_ERR_PARAM (a bad or unreachable set-point) nothing changed; other statuses: a solve
 * failed. */
int sm_drive_step(sm_drive *d, const double meas[SM_MEAS_LEN], double omega_ref, double psi_ref, double T_load,
                  sm_drive_output *out, char *msg, size_t msg_len);

size_t sm_drive_size(void);

#endif

/* ControllerUnit of satmotor/interface.py in C (see sm_controller.h). */
#include "sm_controller.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "sm_common.h"

size_t sm_controller_size(void)
{
    return sizeof(sm_controller);
}

int sm_controller_init(sm_controller *u, const sm_controller_params *v, const sm_motor_params *m, char *msg,
                       size_t msg_len)
{
    sm_motor p;
    sm_gains g;
    sm_law_config cfg;
    sm_ifoc_gains ig;
    sm_drive_config dc;
    sm_mode mode;
    int st, j, k, flux_source;
    if (u == NULL || v == NULL || m == NULL) {
        return SM_ERR_ARG;
    }
    memset(u, 0, sizeof *u);
    /* motor_params(values): the motor parameters and their curve (PlantUnit-style checks) */
    if ((st = sm_motor_init(&p, m, NULL, msg, msg_len))) { /* NULL: no plant parameters, their defaults */
        return st;
    }
    if ((st = sm_controller_params_require_finite(v, msg, msg_len))) { /* interface._number: finite */
        return st;
    }
    /* the String parameters by the generated parser (sm_params.h: their choices in satmotor/interface.py) */
    if ((st = sm_choice_parse(SM_CHOICE_PARAM_mode, v->mode, &k, msg, msg_len))) {
        return st;
    }
    mode = (sm_mode)k;
    if ((st = sm_choice_parse(SM_CHOICE_PARAM_flux_source, v->flux_source, &flux_source, msg, msg_len))) {
        return st;
    }
    if ((st = sm_choice_parse(SM_CHOICE_PARAM_observer, v->observer, &k, msg, msg_len))) {
        return st;
    }
    if ((st = sm_choice_parse(SM_CHOICE_PARAM_speed_source, v->speed_source, &k, msg, msg_len))) {
        return st;
    }
    if ((st = sm_choice_parse(SM_CHOICE_PARAM_flux_mode, v->flux_mode, &k, msg, msg_len))) {
        return st;
    }
    if (flux_source == SM_CHOICE_flux_source_observer && v->use_stator_flux) {
        return sm_param_error(msg, msg_len, NULL, "use_stator_flux", "True",
                              "needs measured fluxes: not with flux_source = observer");
    }
    if (v->delay_samples != 0 && v->delay_samples != 1) {
        char repr[24];
        (void)snprintf(repr, sizeof repr, "%d", v->delay_samples);
        return sm_param_error(msg, msg_len, NULL, "delay_samples", repr, "must be 0 or 1");
    }
    /* load_mode is the law's: mode pi takes any text (as ControllerUnit, which builds no ControllerConfig;
     * any other than estimated is known, the default) */
    if (sm_choice_parse(SM_CHOICE_PARAM_load_mode, v->load_mode, &k, msg, msg_len) != SM_CORE_OK) {
        if (mode != SM_CHOICE_mode_pi) {
            return SM_ERR_PARAM;
        }
        if (msg != NULL && msg_len > 0) {
            msg[0] = '\0';
        }
    }
    /* modulation likewise (the backstepping law's; the pi baseline keeps the linear limit) */
    if (sm_choice_parse(SM_CHOICE_PARAM_modulation, v->modulation, &k, msg, msg_len) != SM_CORE_OK) {
        if (mode != SM_CHOICE_mode_pi) {
            return SM_ERR_PARAM;
        }
        if (msg != NULL && msg_len > 0) {
            msg[0] = '\0';
        }
    }
    /* the settings from the parameters (generated from Variable.fills: as ControllerUnit's dataclasses) */
    sm_controller_settings(v, &g, &cfg, &dc, &ig);
    if ((st = sm_drive_init(&u->drive, mode, &p, &g, &cfg, &ig, &dc, msg, msg_len))) {
        return st;
    }
    u->Ts = v->Ts;
    if ((st = sm_require_number("deadtime_comp_voltage", v->deadtime_comp_voltage, 1, 0.0, 1, msg, msg_len))) {
        return st;
    }
    u->deadtime_comp = v->deadtime_comp_voltage;
    if ((st = sm_require_integer("max_samples", v->max_samples, 1, msg, msg_len))) {
        return st;
    }
    u->max_samples = v->max_samples;
    u->stop_time = INFINITY;
    u->V_dc = u->link = v->V_dc;
    for (j = 0; j < SM_CONTROLLER_N_OUT; ++j) {
        u->out[j] = 0.0;
    }
    return SM_CORE_OK;
}

long sm_controller_samples(const sm_controller *u, double t, double dt)
{
    const double x = dt / u->Ts + 0.5;
    double n, tol;
    if (dt == u->Ts) { /* the common step: the rule below gives 1 too */
        return 1;
    }
    if (!(x >= 0.0 && x < SM_MAX_SAMPLES + 1.0)) { /* also NaN */
        return -1;
    }
    n = floor(x); /* the nearest whole number of samples */
    tol = SM_STEP_ULPS * DBL_EPSILON * fmax(n * u->Ts, fmax(fabs(t), fabs(t + dt)));
    if (n >= 1.0 && fabs(dt - n * u->Ts) <= tol) {
        return (long)n;
    }
    if (n == 0.0 && dt <= SM_STOP_REMAINDER * u->Ts &&
        (isinf(u->stop_time) || fabs(t + dt - u->stop_time) <= tol)) { /* no stop time declared: any */
        return 0;
    }
    return -1;
}

/* one sample from the inputs in; the outputs in u->out */
static int sample(sm_controller *u, const double in[SM_CONTROLLER_N_IN], char *msg, size_t msg_len)
{
    sm_drive_output d;
    int st;
    /* the first SM_MEAS_LEN inputs are the drive's measurement vector, in its order */
    if ((st = sm_drive_step(&u->drive, in, in[SM_CONTROLLER_IN_omega_ref], in[SM_CONTROLLER_IN_psi_ref],
                            in[SM_CONTROLLER_IN_T_load], &d, msg, msg_len))) {
        return st;
    }
    if (u->deadtime_comp > 0.0) { /* dead-time compensation from the measured currents (0: off, as before) */
        sm_deadtime_compensate(&d.v_s_alpha, &d.v_s_beta, in[SM_MEAS_I_S_A], in[SM_MEAS_I_S_B], u->deadtime_comp);
    }
    sm_controller_outputs_of(&d, u->out); /* generated: CONTROLLER_OUTPUTS' order */
    if (d.current_warning) { /* the drive's warning (Python: appended to ControllerUnit.warnings) */
        sm_current_warning(u->warning, sizeof u->warning, d.i_s_meas, u->drive.dc.I_max);
        u->has_warning = 1;
    }
    return SM_CORE_OK;
}

static int step_samples(sm_controller *u, double t, double dt, const double in[SM_CONTROLLER_N_IN], char *msg,
                        size_t msg_len);

/* a failing status whose computation wrote no message (e.g. a curve solve in the field weakening at a
 * diverging plant's state) still gets one: the host never reads an uninitialized buffer */
static void status_message(int st, char *msg, size_t msg_len)
{
    const char *what = st == SM_ERR_NOCONV ? "an iteration did not converge"
                       : st == SM_ERR_NONFINITE ? "a value became non-finite"
                       : st == SM_ERR_PARAM ? "a value is out of range" : "an internal error";
    (void)snprintf(msg, msg_len, "the control computation failed at the measured state: %s", what);
}

int sm_controller_step(sm_controller *u, double t, double dt, const double in[SM_CONTROLLER_N_IN], char *msg,
                       size_t msg_len)
{
    int st;
    if (msg != NULL && msg_len > 0) {
        msg[0] = '\0';
    }
    st = step_samples(u, t, dt, in, msg, msg_len);
    if (st != SM_CORE_OK && msg != NULL && msg_len > 0 && msg[0] == '\0') {
        status_message(st, msg, msg_len);
    }
    return st;
}

static int step_samples(sm_controller *u, double t, double dt, const double in[SM_CONTROLLER_N_IN], char *msg,
                        size_t msg_len)
{
    double sum = 0.0;
    long n, k;
    int st, j;
    n = sm_controller_samples(u, t, dt);
    if (n > u->max_samples || (n < 0 && dt / u->Ts >= (double)u->max_samples + 0.5 && dt / u->Ts < INFINITY)) {
        char reason[160], repr[32], drepr[32]; /* bounded work per call: as ControllerUnit.step */
        (void)snprintf(reason, sizeof reason, "needs %.17g samples of Ts = %s s, more than max_samples = %ld: "
                       "take shorter communication steps or raise max_samples", floor(dt / u->Ts + 0.5),
                       sm_repr_double(u->Ts, repr, sizeof repr), u->max_samples);
        return sm_param_error(msg, msg_len, NULL, "communicationStepSize", sm_repr_double(dt, drepr, sizeof drepr),
                              reason);
    }
    if (n < 0) {
        char reason[112], repr[32], drepr[32];
        (void)snprintf(reason, sizeof reason, "must be a whole multiple of the sample period Ts = %s s",
                       sm_repr_double(u->Ts, repr, sizeof repr));
        return sm_param_error(msg, msg_len, NULL, "communicationStepSize", sm_repr_double(dt, drepr, sizeof drepr),
                              reason);
    }
    for (j = 0; j < SM_CONTROLLER_N_IN; ++j) {
        if (j != SM_CONTROLLER_IN_omega_m || !u->drive.dc.speed_estimated) { /* estimated: omega_m is not read */
            sum += in[j];
        }
    }
    if (!isfinite(sum)) {
        for (j = 0; j < SM_CONTROLLER_N_IN; ++j) {
            if (j == SM_CONTROLLER_IN_omega_m && u->drive.dc.speed_estimated) {
                continue;
            }
            if ((st = sm_require_number(SM_CONTROLLER_INPUT_NAMES[j], in[j], 0, 0.0, 0, msg, msg_len))) {
                return st;
            }
        }
    }
    { /* the link voltage (ControllerUnit.step): held over the step, so set once per step */
        double v_dc = in[SM_CONTROLLER_IN_v_dc], link;
        if (v_dc < 0.0) {
            char repr[32];
            return sm_param_error(msg, msg_len, NULL, "v_dc", sm_repr_double(v_dc, repr, sizeof repr),
                                  "must be >= 0 (0: not connected, the parameter V_dc is used)");
        }
        link = v_dc > 0.0 ? v_dc : u->V_dc;
        if (link != u->link) {
            sm_drive_set_link_voltage(&u->drive, link);
            u->link = link;
        }
    }
    if (n == 1) {
        return sample(u, in, msg, msg_len); /* changes nothing when it fails */
    }
    if (n > 1) {
        sm_controller before = *u; /* a failed sample leaves the controller as it was before the step */
        for (k = 0; k < n; ++k) {
            if ((st = sample(u, in, msg, msg_len))) {
                *u = before;
                return st;
            }
        }
    }
    return SM_CORE_OK;
}

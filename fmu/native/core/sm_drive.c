/* satmotor/control/drive.py in C: the same operations in the same order (see sm_drive.h). */
#include "sm_drive.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "sm_common.h"

static const double FRAME_MIN = 1e-3; /* drive._FRAME_MIN */

size_t sm_drive_size(void)
{
    return sizeof(sm_drive);
}

static const char *curve_name(const sm_curve *c)
{
    switch (c->kind) {
    case SM_CURVE_LINEAR: return "linear";
    case SM_CURVE_ARCTAN: return "arctan";
    case SM_CURVE_EXPONENTIAL: return "exponential";
    case SM_CURVE_POLYNOMIAL: return "polynomial";
    default: return "table";
    }
}

static int range_error(char *msg, size_t len, const char *field, double value, const char *reason)
{
    char repr[32];
    return sm_param_error(msg, len, NULL, field, sm_repr_double(value, repr, sizeof repr), reason);
}

/* DriveConfig.__post_init__ */
static int check_config(const sm_drive_config *c, char *msg, size_t len)
{
    char reason[96], repr[32];
    if (sm_require_number("ref_bandwidth", c->ref_bandwidth, 1, 0.0, 0, msg, len) ||
        sm_require_number("I_max", c->I_max, 1, 0.0, 0, msg, len)) {
        return SM_ERR_PARAM;
    }
    if (!(c->premag_fraction > 0.0 && c->premag_fraction <= 1.0)) {
        return range_error(msg, len, "premag_fraction", c->premag_fraction, "must be a finite number > 0 and <= 1");
    }
    if (!(c->premag_min_fraction > 0.0 && c->premag_min_fraction <= c->premag_fraction)) {
        (void)snprintf(reason, sizeof reason, "must be a finite number > 0 and <= %s",
                       sm_repr_double(c->premag_fraction, repr, sizeof repr));
        return range_error(msg, len, "premag_min_fraction", c->premag_min_fraction, reason);
    }
    if (sm_require_number("premag_boost", c->premag_boost, 1, 1.0, 1, msg, len) ||
        sm_require_number("premag_gain", c->premag_gain, 1, 0.0, 0, msg, len) ||
        sm_require_number("premag_time_max", c->premag_time_max, 1, 0.0, 0, msg, len) ||
        sm_require_number("premag_speed_tol", c->premag_speed_tol, 1, 0.0, 0, msg, len) ||
        sm_require_number("speed_bandwidth", c->speed_bandwidth, 1, 0.0, 0, msg, len)) {
        return SM_ERR_PARAM;
    }
    if (c->observer != 0 && c->observer != 1) {
        return range_error(msg, len, "flux_source", (double)c->observer, "must be one of measured, observer");
    }
    if (c->delay_samples != 0 && c->delay_samples != 1) {
        (void)snprintf(repr, sizeof repr, "%d", c->delay_samples);
        return sm_param_error(msg, len, NULL, "delay_samples", repr, "must be 0 or 1");
    }
    if (c->speed_estimated && !(c->observer && c->closed_loop)) {
        return sm_param_error(msg, len, NULL, "speed_source", "'estimated'", "needs flux_source = observer and "
                              "observer = closed_loop (the speed estimate is the closed-loop observer's)");
    }
    if (c->rs_adaptation != 0 && c->rs_adaptation != 1) {
        return range_error(msg, len, "rs_adaptation", (double)c->rs_adaptation, "must be a bool");
    }
    if (c->rr_tracking != 0 && c->rr_tracking != 1) {
        return range_error(msg, len, "rr_tracking", (double)c->rr_tracking, "must be a bool");
    }
    if (c->rs_adaptation && !(c->observer && c->closed_loop)) {
        return sm_param_error(msg, len, NULL, "rs_adaptation", "True", "needs flux_source = observer and "
                              "observer = closed_loop (the estimate is the closed-loop observer's)");
    }
    if (c->rr_tracking && !c->rs_adaptation) {
        return sm_param_error(msg, len, NULL, "rr_tracking", "True",
                              "needs rs_adaptation (the temperature comes from R_s_hat)");
    }
    if (c->field_weakening != 0 && c->field_weakening != 1) {
        return range_error(msg, len, "field_weakening", (double)c->field_weakening, "must be a bool");
    }
    if (!(c->fw_voltage_ratio > 0.0 && c->fw_voltage_ratio <= 1.0)) {
        return range_error(msg, len, "fw_voltage_ratio", c->fw_voltage_ratio, "must be a finite number > 0 and <= 1");
    }
    if (sm_require_number("current_limit_gain", c->current_limit_gain, 1, 0.0, 1, msg, len)) {
        return SM_ERR_PARAM;
    }
    if (c->host_delay_samples < 0 || c->host_delay_samples > SM_HOST_DELAY_MAX) {
        (void)snprintf(repr, sizeof repr, "%d", c->host_delay_samples);
        (void)snprintf(reason, sizeof reason, "must be an integer from 0 to %d", SM_HOST_DELAY_MAX);
        return sm_param_error(msg, len, NULL, "host_delay_samples", repr, reason);
    }
    if (c->loss_minimizing != 0 && c->loss_minimizing != 1) {
        return range_error(msg, len, "flux_mode", (double)c->loss_minimizing,
                           "must be one of nominal, loss_minimizing");
    }
    if (sm_require_number("flux_floor", c->flux_floor, 1, 0.0, 0, msg, len) ||
        sm_require_number("flux_rate_max", c->flux_rate_max, 1, 0.0, 0, msg, len) ||
        sm_require_number("loss_R_fe", c->loss_R_fe, 1, 0.0, 1, msg, len)) {
        return SM_ERR_PARAM;
    }
    return SM_CORE_OK;
}

/* the delay compensation is configured: the drive's own delay or the host's */
static int has_delay(const sm_drive *d)
{
    return d->dc.delay_samples + d->dc.host_delay_samples > 0;
}

int sm_drive_init(sm_drive *d, sm_mode mode, const sm_motor *p, const sm_gains *g, const sm_law_config *cfg,
                  const sm_ifoc_gains *ig, const sm_drive_config *dc, char *msg, size_t msg_len)
{
    int st;
    double V_dc;
    if (d == NULL || p == NULL || g == NULL || cfg == NULL || ig == NULL || dc == NULL) {
        return SM_ERR_ARG;
    }
    memset(d, 0, sizeof *d);
    d->mode = mode;
    d->p = *p;
    d->g = *g;
    d->cfg = *cfg;
    d->dc = *dc;
    if (mode == SM_CHOICE_mode_constant_m) { /* the same law with the line m = m(0) */
        if ((st = sm_curve_init(&d->p.curve, "linear", p->curve.m0, 0.01, 3.31, 2.46, 7, "", msg, msg_len))) {
            return st;
        }
        d->p.m0 = d->p.curve.m0;
    }
    if (mode == SM_CHOICE_mode_pi) {
        double L_m = sm_curve_m(&p->curve, 5.7); /* RatedData().I_mu_n, until the switch (IFOCDrive) */
        if ((st = sm_ifoc_init(&d->ifoc, p->R_s, p->R_r, p->l_s, p->l_r, p->k, p->n_p, p->J, ig, cfg->Ts, L_m,
                               msg, msg_len))) {
            return SM_ERR_PARAM;
        }
        V_dc = ig->V_dc;
    } else {
        if ((st = sm_gains_check(g, msg, msg_len)) || (st = sm_law_config_check(cfg, msg, msg_len))) {
            return st;
        }
        if (cfg->Ts <= 0.0) {
            return range_error(msg, msg_len, "Ts", cfg->Ts, "must be > 0 for a sampled drive");
        }
        V_dc = cfg->V_dc;
    }
    if ((st = check_config(dc, msg, msg_len))) {
        return st;
    }
    if ((st = sm_require_number("Ts", cfg->Ts, 1, 0.0, 0, msg, msg_len))) {
        return st;
    }
    d->Ts = cfg->Ts;
    d->V_max = V_dc / sqrt(3.0);
    if ((st = sm_shaper_init(&d->flux, dc->ref_bandwidth, 0.0, msg, msg_len)) ||
        (st = sm_shaper_init(&d->speed, dc->ref_bandwidth, 0.0, msg, msg_len))) {
        return st;
    }
    d->n_switch = (long)nearbyint(dc->premag_time_max / d->Ts); /* Python round(): half to even */
    if (dc->observer && dc->closed_loop &&
        (st = sm_cl_observer_init(&d->clo, d->p.R_s, d->p.R_r, d->p.l_s, d->p.l_r, d->p.k, d->p.n_p, d->Ts,
                                  dc->speed_estimated, dc->speed_bandwidth, msg, msg_len))) {
        return st;
    }
    if (dc->observer && dc->closed_loop &&
        (st = sm_cl_observer_set_tracking(&d->clo, dc->rs_adaptation, dc->rr_tracking, msg, msg_len))) {
        return st;
    }
    if (dc->observer && !dc->closed_loop &&
        (st = sm_observer_init(&d->obs, d->p.R_r, d->p.l_r, d->p.k, d->p.n_p, d->Ts, 1, msg, msg_len))) {
        return st;
    }
    if (has_delay(d) && (st = sm_delay_init(&d->delay, d->Ts, SM_DELAY_BIAS_GAIN,
                                            dc->delay_samples + dc->host_delay_samples, msg, msg_len))) {
        return st;
    }
    sm_current_limit_init(&d->limiter, dc->I_max, dc->current_limit_gain, d->Ts);
    if (dc->field_weakening || dc->loss_minimizing) {
        sm_fw_init(&d->fw, &d->p, d->V_max, dc->fw_voltage_ratio, dc->ref_bandwidth);
    }
    if (dc->loss_minimizing) {
        sm_lm_init(&d->lm, d->Ts, dc->flux_floor, dc->flux_rate_max, dc->loss_R_fe);
    }
    sm_drive_reset(d);
    return SM_CORE_OK;
}

void sm_drive_set_link_voltage(sm_drive *d, double V_dc)
{
    d->V_max = V_dc / sqrt(3.0);
    if (d->dc.field_weakening) { /* as sm_fw_init */
        d->fw.V_lim = d->V_max * d->dc.fw_voltage_ratio;
        d->fw.V_bd = 0.5 * (d->fw.V_lim + d->V_max);
    }
    if (d->mode == SM_CHOICE_mode_pi) { /* IFOCController.set_link_voltage */
        d->ifoc.V_max = V_dc / sqrt(3.0);
        d->ifoc.V_max2 = d->ifoc.V_max * d->ifoc.V_max;
    } else {
        d->cfg.V_dc = V_dc;
    }
}

void sm_drive_reset(sm_drive *d)
{
    d->phase = SM_PREMAG;
    d->n = 0;
    (void)sm_shaper_reset(&d->flux, 0.0, NULL, 0);
    (void)sm_shaper_reset(&d->speed, 0.0, NULL, 0);
    if (d->dc.observer && d->dc.closed_loop) {
        (void)sm_cl_observer_reset(&d->clo, 0.0, 0.0, 0.0, NULL, 0);
    } else if (d->dc.observer) {
        (void)sm_observer_reset(&d->obs, 0.0, 0.0, NULL, 0);
    }
    if (has_delay(d)) {
        sm_delay_reset(&d->delay);
    }
    sm_current_limit_reset(&d->limiter);
    d->lm.psi = 0.0;
    d->theta_hat = d->e0 = d->z0 = 0.0;
    if (d->mode == SM_CHOICE_mode_pi) {
        (void)sm_ifoc_reset(&d->ifoc, 0.0, 0.0, NULL, 0);
    }
}

/* _Drive.magnetizing_current */
static int magnetizing_current(sm_drive *d, double psi_ref, double *I, char *msg, size_t len)
{
    int st;
    char reason[160], repr[32];
    if (d->has_checked && psi_ref == d->checked_psi) {
        *I = d->checked_I;
        return SM_CORE_OK;
    }
    if ((st = sm_require_number("psi_ref", psi_ref, 1, 0.0, 0, msg, len))) {
        return st;
    }
    if ((st = sm_curve_current(&d->p.curve, psi_ref / d->p.k, I))) {
        return st;
    }
    if (*I > d->dc.I_max) {
        (void)snprintf(reason, sizeof reason, "needs a magnetizing current of %.4g A on the '%s' curve, more than "
                       "I_max = %s A", *I, curve_name(&d->p.curve), sm_repr_double(d->dc.I_max, repr, sizeof repr));
        return range_error(msg, len, "psi_ref", psi_ref, reason);
    }
    d->has_checked = 1;
    d->checked_psi = psi_ref;
    d->checked_I = *I;
    return SM_CORE_OK;
}

static int switch_now(const sm_drive *d, double phi, double psi_ref, double omega_m)
{
    const sm_drive_config *c = &d->dc;
    if (phi >= c->premag_fraction * psi_ref) {
        return 1;
    }
    return phi >= c->premag_min_fraction * psi_ref && (d->n >= d->n_switch || fabs(omega_m) > c->premag_speed_tol);
}

static void premag(const sm_drive *d, const double meas[SM_MEAS_LEN], double I_set, double phi, double psi_ref,
                   sm_drive_output *o)
{
    const sm_drive_config *cfg = &d->dc;
    double K = cfg->premag_gain, i_ref, c = 1.0, s = 0.0;
    double pa = meas[SM_MEAS_PSI_R_A], pb = meas[SM_MEAS_PSI_R_B], ia = meas[SM_MEAS_I_S_A], ib = meas[SM_MEAS_I_S_B];
    double vd, vq, vn;
    double z_flux[3], z_speed[3];
    int bounded = cfg->premag_boost * I_set > cfg->I_max, lim;
    i_ref = fmin(cfg->premag_boost * I_set, cfg->I_max);
    if (fabs(meas[SM_MEAS_OMEGA_M]) > cfg->premag_speed_tol) {
        i_ref = fmax(i_ref, SM_D_SHARE * cfg->I_max);
    }
    if (phi > FRAME_MIN * psi_ref) {
        c = pa / phi;
        s = pb / phi;
    }
    vd = d->p.R_s * i_ref + K * (i_ref - (c * ia + s * ib));
    vq = -K * (c * ib - s * ia);
    vn = sm_hypot(vd, vq);
    lim = vn > d->V_max;
    if (lim) {
        vd = vd * d->V_max / vn;
        vq = vq * d->V_max / vn;
    }
    memset(o, 0, sizeof *o);
    o->v_s_alpha = c * vd - s * vq;
    o->v_s_beta = s * vd + c * vq;
    o->v_sd = vd;
    o->v_sq = vq;
    o->e1 = phi - psi_ref;
    /* the shapers' values: at rest until the law runs (drive._Drive._premag) */
    sm_shaper_get_state(&d->speed, z_speed);
    sm_shaper_get_state(&d->flux, z_flux);
    o->omega_ref_shaped = z_speed[0];
    o->psi_ref_shaped = z_flux[0];
    o->phase = SM_PREMAG;
    o->voltage_limited = lim;
    o->singular_limited = 0;
    o->current_limited = bounded;
    o->psi_r_hat_alpha = pa;
    o->psi_r_hat_beta = pb;
}

static int do_switch(sm_drive *d, const double meas[SM_MEAS_LEN])
{
    sm_magnetizing ms;
    sm_model_constants mc;
    double z[3];
    int st = sm_from_rotor_flux(meas[SM_MEAS_I_S_A], meas[SM_MEAS_I_S_B], meas[SM_MEAS_PSI_R_A],
                                meas[SM_MEAS_PSI_R_B], &d->p, &ms);
    if (st) {
        return st;
    }
    sm_model_constants_of(&d->p, &mc);
    z[0] = ms.Phi_rd;
    z[1] = sm_flux_rate(mc.a, mc.k, ms.Phi_rd, ms.i_mu_d, ms.m);
    z[2] = 0.0;
    if ((st = sm_shaper_set_state(&d->flux, z, NULL, 0)) ||
        (st = sm_shaper_reset(&d->speed, meas[SM_MEAS_OMEGA_M], NULL, 0))) {
        return st;
    }
    d->phase = SM_RUN;
    d->lm.psi = z[0]; /* the loss minimizer's rate limit starts at the measured flux */
    if (d->mode == SM_CHOICE_mode_pi) { /* IFOCDrive._on_switch: L_m at the raw set-point of this sample */
        if (sm_ifoc_set_inductance(&d->ifoc, d->checked_psi / d->p.k / d->checked_I, NULL, 0)) {
            return SM_ERR_PARAM;
        }
        return sm_ifoc_reset(&d->ifoc, ms.rho, ms.Phi_rd, NULL, 0);
    }
    return SM_CORE_OK;
}

static double model_load(const sm_drive *d, double T_load)
{
    if (d->mode == SM_CHOICE_mode_pi) {
        return 0.0;
    }
    return d->cfg.load_estimated ? d->theta_hat * d->p.J : T_load;
}

static int run(sm_drive *d, const double meas[SM_MEAS_LEN], const double psi_ref_shaped[3],
               const double omega_ref_shaped[3], double T_load, sm_drive_output *o, char *msg, size_t len)
{
    memset(o, 0, sizeof *o);
    if (d->mode == SM_CHOICE_mode_pi) {
        double w = meas[SM_MEAS_OMEGA_M], va, vb;
        sm_ifoc_diagnostics dg;
        int st = sm_ifoc_step(&d->ifoc, meas[SM_MEAS_I_S_A], meas[SM_MEAS_I_S_B], w, omega_ref_shaped[0],
                              psi_ref_shaped[0], &va, &vb, &dg, msg, len);
        if (st) {
            return SM_ERR_PARAM;
        }
        o->v_s_alpha = va;
        o->v_s_beta = vb;
        o->v_sd = dg.v_sd;
        o->v_sq = dg.v_sq;
        o->e1 = sm_hypot(meas[SM_MEAS_PSI_R_A], meas[SM_MEAS_PSI_R_B]) - psi_ref_shaped[0]; /* diagnostics only */
        o->z1 = w - omega_ref_shaped[0];
        o->omega_ref_shaped = omega_ref_shaped[0];
        o->psi_ref_shaped = psi_ref_shaped[0];
        o->voltage_limited = dg.voltage_limited;
        o->current_limited = dg.current_limited;
    } else {
        double ref[6], load[2], integ[2], t_load;
        const double R_s = d->p.R_s, R_r = d->p.R_r;
        sm_control_output c;
        int st;
        ref[0] = psi_ref_shaped[0];
        ref[1] = psi_ref_shaped[1];
        ref[2] = psi_ref_shaped[2];
        ref[3] = omega_ref_shaped[0];
        ref[4] = omega_ref_shaped[1];
        ref[5] = omega_ref_shaped[2];
        load[0] = T_load;
        load[1] = 0.0;
        integ[0] = d->e0;
        integ[1] = d->z0;
        if (d->dc.rs_adaptation) { /* _Drive._law_params: the law's model with the tracked resistances */
            d->p.R_s = d->clo.Rs;
            d->p.R_r = d->clo.Rr;
        }
        st = sm_control(meas, ref, load, &d->p, &d->g, &d->cfg, d->theta_hat, integ, d->i_lim, &c);
        d->p.R_s = R_s; /* the given model again (the rest of the drive keeps it) */
        d->p.R_r = R_r;
        if (st != SM_CORE_OK && st != SM_ERR_NONFINITE) {
            return st;
        }
        if (d->cfg.load_estimated) {
            double th;
            t_load = d->theta_hat * d->p.J;
            th = d->theta_hat + d->cfg.Ts * c.theta_hat_dot;
            d->theta_hat = fmin(fmax(th, -d->cfg.theta_max), d->cfg.theta_max);
        } else {
            t_load = T_load;
        }
        d->e0 += d->cfg.Ts * c.e0_dot;
        d->z0 += d->cfg.Ts * c.z0_dot;
        o->v_s_alpha = c.v_s_alpha;
        o->v_s_beta = c.v_s_beta;
        o->v_sd = c.v_sd;
        o->v_sq = c.v_sq;
        o->e1 = c.e1;
        o->e2 = c.e2;
        o->z1 = c.z1;
        o->z2 = c.z2;
        o->V = c.V;
        o->W = c.W;
        o->T_load_est = t_load;
        o->omega_ref_shaped = omega_ref_shaped[0];
        o->psi_ref_shaped = psi_ref_shaped[0];
        o->voltage_limited = c.voltage_limited;
        o->singular_limited = c.singular_limited;
        o->current_limited = c.current_limited;
    }
    o->phase = SM_RUN;
    o->psi_r_hat_alpha = meas[SM_MEAS_PSI_R_A];
    o->psi_r_hat_beta = meas[SM_MEAS_PSI_R_B];
    return SM_CORE_OK;
}

static void delayed(sm_drive *d, sm_drive_output *o)
{
    if (has_delay(d)) {
        double va, vb;
        sm_delay_push(&d->delay, o->v_s_alpha, o->v_s_beta, d->dc.delay_samples == 1, &va, &vb);
        o->v_s_alpha = va;
        o->v_s_beta = vb;
    }
}

static int step(sm_drive *d, const double meas_in[SM_MEAS_LEN], double omega_ref, double psi_ref, double T_load,
                sm_drive_output *out, double *w_used, char *msg, size_t msg_len);

/* _Drive._ahead: the shaper's (r, r', r'') n - 1 samples after its present state (u held), the shaper untouched */
static void ahead(const sm_drive *d, const sm_shaper *s, double u, double z[3])
{
    sm_shaper copy = *s;
    int k;
    for (k = 1; k < d->delay.n; ++k) {
        (void)sm_shaper_step(&copy, u, d->Ts, NULL, NULL, 0);
    }
    sm_shaper_get_state(&copy, z);
}

int sm_drive_step(sm_drive *d, const double meas_in[SM_MEAS_LEN], double omega_ref, double psi_ref, double T_load,
                  sm_drive_output *out, char *msg, size_t msg_len)
{
    double w_used = 0.0;
    int st;
    if (d == NULL || meas_in == NULL || out == NULL) {
        return SM_ERR_ARG;
    }
    if ((st = step(d, meas_in, omega_ref, psi_ref, T_load, out, &w_used, msg, msg_len))) {
        return st;
    }
    if (d->dc.observer && d->dc.closed_loop) { /* the voltage over the coming sample (delay: the queue's first) */
        if (has_delay(d)) {
            sm_cl_observer_applied(&d->clo, d->delay.applied_now[0], d->delay.applied_now[1]);
        } else {
            sm_cl_observer_applied(&d->clo, out->v_s_alpha, out->v_s_beta);
        }
    }
    if (d->dc.rs_adaptation && !(out->phase != SM_RUN || out->voltage_limited || out->current_limited)) {
        sm_cl_observer_adapt_resistance(&d->clo); /* held while a limit is active or before the law runs */
    }
    out->omega_m_hat = w_used;
    out->R_s_hat = d->dc.observer && d->dc.closed_loop ? d->clo.Rs : d->p.R_s; /* _Drive.resistances */
    out->R_r_hat = d->dc.observer && d->dc.closed_loop ? d->clo.Rr : d->p.R_r;
    return SM_CORE_OK;
}

/* _Drive._step */
static int step(sm_drive *d, const double meas_in[SM_MEAS_LEN], double omega_ref, double psi_ref, double T_load,
                sm_drive_output *out, double *w_used, char *msg, size_t msg_len)
{
    double I_set, meas[SM_MEAS_LEN], psi_ref_shaped[3], omega_ref_shaped[3], i_meas;
    int st, j, warn;
    if ((st = magnetizing_current(d, psi_ref, &I_set, msg, msg_len)) ||
        (st = sm_require_number("omega_ref", omega_ref, 0, 0.0, 0, msg, msg_len))) {
        return st;
    }
    for (j = 0; j < SM_MEAS_LEN; ++j) {
        meas[j] = meas_in[j];
    }
    if (d->dc.observer && d->dc.closed_loop) { /* the psi inputs (speed estimated: omega_m too) are ignored */
        double pa, pb, w;
        if ((st = sm_cl_observer_update(&d->clo, &d->p.curve, meas[SM_MEAS_I_S_A], meas[SM_MEAS_I_S_B],
                                        meas[SM_MEAS_OMEGA_M], &pa, &pb, &w))) {
            return st;
        }
        meas[SM_MEAS_PSI_R_A] = pa;
        meas[SM_MEAS_PSI_R_B] = pb;
        meas[SM_MEAS_PSI_S_A] = meas[SM_MEAS_PSI_S_B] = 0.0;
        meas[SM_MEAS_OMEGA_M] = w;
    } else if (d->dc.observer) { /* the psi inputs are ignored: the estimate replaces them */
        double pa, pb;
        if ((st = sm_observer_update(&d->obs, &d->p.curve, meas[SM_MEAS_I_S_A], meas[SM_MEAS_I_S_B],
                                     meas[SM_MEAS_OMEGA_M], &pa, &pb))) {
            return st;
        }
        meas[SM_MEAS_PSI_R_A] = pa;
        meas[SM_MEAS_PSI_R_B] = pb;
        meas[SM_MEAS_PSI_S_A] = meas[SM_MEAS_PSI_S_B] = 0.0;
    }
    *w_used = meas[SM_MEAS_OMEGA_M];
    if (d->phase == SM_PREMAG) {
        double phi = sm_hypot(meas[SM_MEAS_PSI_R_A], meas[SM_MEAS_PSI_R_B]);
        if (!switch_now(d, phi, psi_ref, meas[SM_MEAS_OMEGA_M])) {
            d->n += 1;
            premag(d, meas, I_set, phi, psi_ref, out);
            delayed(d, out);
            return SM_CORE_OK;
        }
        if ((st = do_switch(d, meas))) {
            return st;
        }
    }
    i_meas = sm_hypot(meas[SM_MEAS_I_S_A], meas[SM_MEAS_I_S_B]); /* the measured current (never predicted) */
    d->i_lim = sm_current_limit_bound(&d->limiter, i_meas, &warn);
    if (d->dc.loss_minimizing) { /* the least loss within the nominal (or field-weakening) flux */
        double z[3], T, w;
        sm_shaper_get_state(&d->speed, z);
        if ((st = sm_fw_torque(&d->fw, &d->p, meas, &T))) {
            return st;
        }
        w = meas[SM_MEAS_OMEGA_M] + d->fw.lead * z[1];
        if (d->dc.field_weakening &&
            (st = sm_fw_set_points(&d->fw, &d->p, T, w, psi_ref, d->i_lim, &psi_ref, &d->i_lim))) {
            return st;
        }
        if ((st = sm_lm_set_point(&d->lm, &d->p, T, w, psi_ref, d->i_lim, &psi_ref))) {
            return st;
        }
    } else if (d->dc.field_weakening) { /* the nominal flux, or lower where the voltage does not suffice */
        double z[3];
        sm_shaper_get_state(&d->speed, z);
        if ((st = sm_fw_flux_reference(&d->fw, &d->p, meas, z[1], psi_ref, d->i_lim, &psi_ref, &d->i_lim))) {
            return st;
        }
    }
    if (!has_delay(d)) {
        sm_shaper_get_state(&d->flux, psi_ref_shaped);
        sm_shaper_get_state(&d->speed, omega_ref_shaped);
        if ((st = run(d, meas, psi_ref_shaped, omega_ref_shaped, T_load, out, msg, msg_len))) {
            return st;
        }
        (void)sm_shaper_step(&d->flux, psi_ref, d->Ts, NULL, NULL, 0);
        (void)sm_shaper_step(&d->speed, omega_ref, d->Ts, NULL, NULL, 0);
    } else { /* the command takes effect n samples on: the state and the references there */
        double pred[SM_MEAS_LEN];
        if ((st = sm_delay_predict(&d->delay, &d->p, meas, model_load(d, T_load), pred))) {
            return st;
        }
        (void)sm_shaper_step(&d->flux, psi_ref, d->Ts, NULL, NULL, 0);
        (void)sm_shaper_step(&d->speed, omega_ref, d->Ts, NULL, NULL, 0);
        ahead(d, &d->flux, psi_ref, psi_ref_shaped);
        ahead(d, &d->speed, omega_ref, omega_ref_shaped);
        if ((st = run(d, pred, psi_ref_shaped, omega_ref_shaped, T_load, out, msg, msg_len))) {
            return st;
        }
        delayed(d, out);
    }
    if (i_meas > d->dc.I_max) { /* the measured current is over its limit */
        out->current_limited = 1;
    }
    out->current_warning = warn;
    out->i_s_meas = i_meas;
    return SM_CORE_OK;
}

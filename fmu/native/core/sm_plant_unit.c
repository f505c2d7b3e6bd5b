/* PlantUnit of satmotor/interface.py in C (see sm_plant_unit.h). */
#include "sm_plant_unit.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include "sm_common.h"
#include "sm_phases.h"

/* the plausibility warnings (PlantUnit.step, interface.plausibility_message): quantity k above its
 * bound v_warn / i_warn / omega_warn (> 0) is reported once per run; nothing else changes */
static const char *const WARN_NAME[3] = {"v_warn", "i_warn", "omega_warn"};
static const char *const WARN_WHAT[3][3] = {
    {"|v_s|", "V", "input"}, {"|i_s|", "A", "output"}, {"|omega_m|", "rad/s", "output"}};

size_t sm_plant_unit_size(void)
{
    return sizeof(sm_plant_unit);
}

void sm_plant_unit_offsets(size_t off[3])
{
    off[0] = offsetof(sm_plant_unit, out);
    off[1] = offsetof(sm_plant_unit, n_warnings);
    off[2] = offsetof(sm_plant_unit, warnings);
}

void sm_plant_plausibility_message(int k, double t, double value, double bound, char *msg, size_t msg_len)
{
    char a[40], b[40], c[40];
    (void)snprintf(msg, msg_len, "SaturatedInductionMotor: implausible %s at t = %s s: %s = %s %s exceeds %s = %s "
                   "%s; the step is computed as given (logged once per run)", WARN_WHAT[k][2],
                   sm_repr_double(t, a, sizeof a), WARN_WHAT[k][0], sm_repr_double(value, b, sizeof b),
                   WARN_WHAT[k][1], WARN_NAME[k], sm_repr_double(bound, c, sizeof c), WARN_WHAT[k][1]);
}

static char *next_warning(sm_plant_unit *u)
{
    /* never more than SM_PLANT_MAX_WARNINGS per step; a host that does not clear them keeps the first */
    return u->n_warnings < SM_PLANT_MAX_WARNINGS ? u->warnings[u->n_warnings++] : NULL;
}

/* PlantUnit._plausible: |(a, b)| above bound k, the squares compared first (cheap), the magnitude for the
 * message only */
static void plausible(sm_plant_unit *u, int k, double t, double a, double b)
{
    const double bound = u->warn[k];
    char *w;
    if (u->warned[k] || !(bound > 0.0) || !(a * a + b * b > bound * bound)) return;
    u->warned[k] = 1;
    if ((w = next_warning(u)) != NULL) sm_plant_plausibility_message(k, t, sm_hypot(a, b), bound, w, SM_MSG_LEN);
}

int sm_plant_unit_init(sm_plant_unit *u, const sm_motor_params *m, const sm_plant_params *pp,
                       const sm_dclink_params *lp, char *msg, size_t msg_len)
{
    int st, j;
    if (u == NULL || m == NULL || pp == NULL || lp == NULL) {
        return SM_ERR_ARG;
    }
    memset(u, 0, sizeof *u);
    /* the motor's checks, the plant's (psi_r0, h_int, max_substeps, the bounds, B_2, R_fe, the thermal
     * model: sm_motor_init in PlantUnit's order), the initial state */
    if ((st = sm_motor_init(&u->p, m, pp, msg, msg_len))) return st;
    if ((st = sm_dclink_init(&u->link, lp, msg, msg_len))) return st;
    /* the inverter switches the link's V_dc (one parameter; a capacitor link: its voltage, a state) */
    if ((st = sm_inverter_init(&u->inv, pp, u->link.V_dc, msg, msg_len))) return st;
    u->inv.k_edge = u->p.lp.k_edge; /* PwmInverter(inv, plant.lp) */
    u->max_substeps = pp->max_substeps;
    u->warn[0] = pp->v_warn;
    u->warn[1] = pp->i_warn;
    u->warn[2] = pp->omega_warn;
    u->n_x = u->p.n_states;
    for (j = 0; j < u->n_x; ++j) {
        u->x[j] = u->p.x0[j];
    }
    if (u->link.capacitor) { /* DCLink.initial_state: after the motor's states (with the thermal ones) */
        int iv = sm_dclink_iv(&u->p);
        u->x[iv] = u->link.V_dc;
        u->x[iv + 1] = 0.0;
        u->x[iv + 2] = 0.0;
        u->n_x = iv + 3;
    }
    sm_solve_memo_clear(&u->memo);
    sm_plant_unit_publish(u);
    return SM_CORE_OK;
}

/* the refusals of a step before it is taken (PlantUnit.step): the inputs, the step size, max_substeps */
static int check_step(const sm_plant_unit *u, double dt, const double in[SM_PLANT_N_IN], int *n_sub, char *msg,
                      size_t msg_len)
{
    char v[40], w[40];
    double n_pwm;
    int st = sm_plant_check_step(&u->p, in[SM_PLANT_IN_v_s_alpha], in[SM_PLANT_IN_v_s_beta],
                                 in[SM_PLANT_IN_T_load], dt, n_sub, msg, msg_len);
    if (st) return st;
    if (*n_sub > u->max_substeps) { /* bounded work per call (interface.substeps_reason) */
        (void)snprintf(msg, msg_len, "communicationStepSize = %s: needs %d RK4 sub-steps of h_int = %s s, more "
                       "than max_substeps = %d: take shorter communication steps or raise max_substeps",
                       sm_repr_double(dt, v, sizeof v), *n_sub, sm_repr_double(u->p.h_int, w, sizeof w),
                       u->max_substeps);
        return SM_ERR_PARAM;
    }
    if (!u->inv.pwm) return SM_CORE_OK;
    n_pwm = (double)*n_sub + sm_inverter_intervals_bound(&u->inv, dt); /* the switching intervals too */
    if (n_pwm > (double)u->max_substeps) { /* interface.pwm_substeps_reason */
        (void)snprintf(msg, msg_len, "communicationStepSize = %s: needs up to %.0f RK4 sub-steps with the pwm "
                       "inverter (f_sw = %s Hz), more than max_substeps = %d: take shorter communication steps "
                       "or raise max_substeps", sm_repr_double(dt, v, sizeof v), n_pwm,
                       sm_repr_double(u->inv.f_sw, w, sizeof w), u->max_substeps);
        return SM_ERR_PARAM;
    }
    return SM_CORE_OK;
}

/* PlantUnit._step_means: u->means over the step from u->x to x1 of dt [s] (v_avg: the held voltage to be) */
static void step_means(sm_plant_unit *u, const double *x1, double dt, const double v_avg[2])
{
    const double *x0 = u->x;
    if (u->inv.pwm) {
        u->means[0] = u->inv.energies[0] / dt;
        u->means[1] = (u->inv.energies[1] + u->inv.energies[2]) / dt;
        u->pwm_means[0] = u->inv.energies[3] / dt;
        u->pwm_means[1] = u->inv.energies[4] / dt;
    } else {
        double va = v_avg[0], vb = v_avg[1], Rs, qa, qb;
        if (u->link.capacitor) sm_dclink_applied(v_avg[0], v_avg[1], x1[sm_dclink_iv(&u->p)], &va, &vb);
        Rs = sm_plant_stator_resistance(&u->p, x0);
        qa = (va * dt - (x1[SM_PSI_S_A] - x0[SM_PSI_S_A])) / Rs;
        qb = (vb * dt - (x1[SM_PSI_S_B] - x0[SM_PSI_S_B])) / Rs;
        u->means[0] = 1.5 * (va * qa + vb * qb) / dt;
        u->means[1] = 0.0;
    }
    u->means[2] = u->link.capacitor ? (x1[sm_dclink_iv(&u->p) + 2] - x0[sm_dclink_iv(&u->p) + 2]) / dt : 0.0;
}

int sm_plant_unit_step(sm_plant_unit *u, double t, double dt, const double in[SM_PLANT_N_IN], char *msg,
                       size_t msg_len)
{
    const double v_a = in[SM_PLANT_IN_v_s_alpha], v_b = in[SM_PLANT_IN_v_s_beta], T_load = in[SM_PLANT_IN_T_load];
    double x[SM_N_LINK_STATES_MAX], v_avg[2], t_fault = NAN;
    int n_sub = 1, st, j, chop = u->chop, fault = u->fault;
    if (msg != NULL && msg_len > 0) msg[0] = '\0';
    if ((st = check_step(u, dt, in, &n_sub, msg, msg_len))) return st;
    plausible(u, 0, t, v_a, v_b);
    memcpy(x, u->x, sizeof x);
    if (u->inv.pwm && u->link.capacitor) { /* the switched stage on the link (satmotor/converter/pwm_link.py) */
        st = sm_inverter_step_link(&u->inv, &u->p, &u->link, &u->memo, x, t, dt, v_a, v_b, T_load, v_avg, &chop,
                                   &fault, &t_fault, NULL, 0, NULL);
    } else if (u->inv.pwm) { /* the switched voltages to the switching instants; u->inv changes only on success */
        st = sm_inverter_step_memo(&u->inv, &u->p, &u->memo, x, t, dt, v_a, v_b, T_load, v_avg, NULL, 0, NULL);
    } else if (u->link.capacitor) { /* (the memo is for the motor's step alone: publish refills it) */
        st = sm_dclink_step(&u->p, &u->link, t, x, v_a, v_b, T_load, dt, n_sub, &chop, &fault, &t_fault);
    } else {
        st = sm_plant_step_memo(&u->p, &u->memo, x, v_a, v_b, T_load, dt, n_sub);
    }
    if (st != 0) {
        double y[SM_N_STATES];
        for (j = 0; j < SM_N_STATES; ++j) {
            y[j] = NAN;
        }
        sm_plant_nonfinite_message(t, dt, y, msg, msg_len);
        return st;
    }
    if (!u->inv.pwm) { /* the command (the outputs' voltage: publish bounds it on a capacitor link) */
        v_avg[0] = v_a;
        v_avg[1] = v_b;
    }
    step_means(u, x, dt, v_avg);
    u->T_load = T_load;
    memcpy(u->x, x, sizeof x);
    u->chop = chop;
    u->fault = fault;
    if (!isnan(t_fault)) { /* set in this step: once per run (the fault is latched) */
        char *w = next_warning(u);
        if (w != NULL) sm_dclink_over_voltage_message(t_fault, x[sm_dclink_iv(&u->p)], u->link.V_dc_max, w, SM_MSG_LEN);
    }
    u->v[0] = v_avg[0];
    u->v[1] = v_avg[1];
    sm_plant_unit_publish(u);
    plausible(u, 1, t + dt, u->out[SM_PLANT_OUT_i_s_alpha], u->out[SM_PLANT_OUT_i_s_beta]);
    if (!u->warned[2] && u->warn[2] > 0.0 && fabs(x[SM_OMEGA_M]) > u->warn[2]) {
        char *w;
        u->warned[2] = 1;
        if ((w = next_warning(u)) != NULL) {
            sm_plant_plausibility_message(2, t + dt, fabs(x[SM_OMEGA_M]), u->warn[2], w, SM_MSG_LEN);
        }
    }
    return SM_CORE_OK;
}

void sm_plant_unit_publish(sm_plant_unit *u)
{
    sm_plant_outputs o;
    double *r = u->out, v_a = u->v[0], v_b = u->v[1];
    if (u->link.capacitor && !u->inv.pwm) /* PlantUnit._held: the command as the link bounds it */
        sm_dclink_applied(u->v[0], u->v[1], u->x[sm_dclink_iv(&u->p)], &v_a, &v_b);
    double pw[6], p_term = u->means[0], p_inv = u->means[1];
    int j;
    if (sm_plant_outputs_memo(&u->p, &u->memo, u->x, v_a, v_b, &o) != 0) {
        o.i_s_alpha = o.i_s_beta = o.T_e = o.i_mu = o.P_fe = o.T_s = o.T_r = NAN;
        for (j = 0; j < 6; ++j) pw[j] = NAN;
    } else if (sm_plant_powers(&u->p, &u->memo, u->x, &o, u->T_load, pw) != 0) {
        for (j = 0; j < 6; ++j) pw[j] = NAN;
    }
    if (u->instant) { /* model exchange: the power into the terminals at the instant */
        p_term = 1.5 * (v_a * o.i_s_alpha + v_b * o.i_s_beta);
        p_inv = 0.0;
    }
    if (!u->inv.pwm && u->p.lp.E_sw > 0.0) { /* the average inverter's switching loss (PlantUnit.powers) */
        double cur[3];
        sm_phase_currents(o.i_s_alpha, o.i_s_beta, cur);
        p_inv = sm_switching_power(&u->p.lp, u->inv.f_sw, u->link.capacitor ? u->x[sm_dclink_iv(&u->p)]
                                                                             : u->link.V_dc, cur);
    }
    r[SM_PLANT_OUT_i_s_alpha] = o.i_s_alpha;
    r[SM_PLANT_OUT_i_s_beta] = o.i_s_beta;
    r[SM_PLANT_OUT_psi_s_alpha] = u->x[SM_PSI_S_A];
    r[SM_PLANT_OUT_psi_s_beta] = u->x[SM_PSI_S_B];
    r[SM_PLANT_OUT_psi_r_alpha] = u->x[SM_PSI_R_A];
    r[SM_PLANT_OUT_psi_r_beta] = u->x[SM_PSI_R_B];
    r[SM_PLANT_OUT_omega_m] = u->x[SM_OMEGA_M];
    r[SM_PLANT_OUT_theta_m] = u->x[SM_THETA_M];
    r[SM_PLANT_OUT_T_e] = o.T_e;
    r[SM_PLANT_OUT_i_mu] = o.i_mu;
    if (u->link.capacitor) { /* V_DC, E_REGEN, E_CHOP, or two places later with the thermal model */
        int iv = sm_dclink_iv(&u->p);
        r[SM_PLANT_OUT_v_dc] = u->x[iv];
        r[SM_PLANT_OUT_E_regen] = u->x[iv + 1];
        r[SM_PLANT_OUT_E_chop] = u->x[iv + 2];
    } else {
        r[SM_PLANT_OUT_v_dc] = u->link.V_dc;
        r[SM_PLANT_OUT_E_regen] = 0.0;
        r[SM_PLANT_OUT_E_chop] = 0.0;
    }
    r[SM_PLANT_OUT_dc_fault] = u->fault ? 1.0 : 0.0;
    r[SM_PLANT_OUT_P_fe] = u->inv.pwm ? u->pwm_means[1] : o.P_fe; /* pwm: its mean over the step (or 0) */
    r[SM_PLANT_OUT_T_s] = o.T_s;
    r[SM_PLANT_OUT_T_r] = o.T_r;
    r[SM_PLANT_OUT_v_avg_alpha] = u->v[0];
    r[SM_PLANT_OUT_v_avg_beta] = u->v[1];
    r[SM_PLANT_OUT_P_cu_s] = u->inv.pwm && u->p.R_fe > 0.0 ? u->pwm_means[0] : pw[0]; /* pwm, core loss: mean */
    r[SM_PLANT_OUT_P_cu_r] = pw[1];
    r[SM_PLANT_OUT_P_fw] = pw[3];
    r[SM_PLANT_OUT_P_stray] = pw[4];
    r[SM_PLANT_OUT_P_inv] = p_inv;
    r[SM_PLANT_OUT_P_chop] = u->instant ? 0.0 : u->means[2];
    r[SM_PLANT_OUT_P_in] = p_term + p_inv;
    r[SM_PLANT_OUT_P_mech] = pw[5];
}

int sm_plant_unit_derivatives(const sm_plant_unit *u, double t, const double *x, const double in[SM_PLANT_N_IN],
                              double *dx)
{
    const double v_a = in[SM_PLANT_IN_v_s_alpha], v_b = in[SM_PLANT_IN_v_s_beta], T_load = in[SM_PLANT_IN_T_load];
    if (u->link.capacitor) {
        return sm_dclink_derivatives(&u->p, &u->link, t, x, v_a, v_b, T_load, u->chop, dx);
    }
    return sm_plant_derivatives(&u->p, x, v_a, v_b, T_load, dx);
}

size_t sm_plant_unit_state_size(const sm_plant_unit *u)
{
    return (size_t)u->n_x + (u->link.capacitor ? 2u : 0u) + 8u + (u->inv.pwm ? SM_PLANT_INVERTER_STATE : 0u);
}

size_t sm_plant_unit_get_state(const sm_plant_unit *u, double *s, size_t cap)
{
    const sm_inverter *q = &u->inv;
    size_t n = 0, want = sm_plant_unit_state_size(u);
    int j;
    if (cap < want) return 0;
    for (j = 0; j < u->n_x; ++j) s[n++] = u->x[j];
    if (u->link.capacitor) {
        s[n++] = (double)u->chop;
        s[n++] = (double)u->fault;
    }
    s[n++] = u->v[0];
    s[n++] = u->v[1];
    s[n++] = u->T_load;
    for (j = 0; j < 3; ++j) s[n++] = u->means[j];
    for (j = 0; j < 2; ++j) s[n++] = u->pwm_means[j];
    if (q->pwm) { /* PwmInverter.get_state */
        s[n++] = (double)q->have;
        s[n++] = (double)q->k;
        for (j = 0; j < 3; ++j) s[n++] = q->d[j];
        for (j = 0; j < 3; ++j) s[n++] = (double)q->s[j];
        for (j = 0; j < 3; ++j) s[n++] = (double)q->dead[j];
        for (j = 0; j < 3; ++j) s[n++] = q->dead_until[j];
        for (j = 0; j < 3; ++j) s[n++] = q->dead_v[j];
    }
    return n;
}

int sm_plant_unit_set_state(sm_plant_unit *u, const double *s, size_t n)
{
    sm_inverter *q = &u->inv;
    size_t i = 0;
    int j;
    if (u == NULL || s == NULL || n != sm_plant_unit_state_size(u)) return SM_ERR_ARG;
    if (q->pwm) { /* the inverter's whole numbers (half period, leg states) must be numbers to convert */
        size_t base = n - SM_PLANT_INVERTER_STATE;
        for (j = 1; j < 8; ++j) {
            if (!(fabs(s[base + (size_t)j]) < 9007199254740992.0)) return SM_ERR_ARG;
        }
    }
    for (j = 0; j < u->n_x; ++j) u->x[j] = s[i++];
    if (u->link.capacitor) {
        u->chop = s[i++] != 0.0;
        u->fault = s[i++] != 0.0;
    }
    u->v[0] = s[i++];
    u->v[1] = s[i++];
    u->T_load = s[i++];
    for (j = 0; j < 3; ++j) u->means[j] = s[i++];
    for (j = 0; j < 2; ++j) u->pwm_means[j] = s[i++];
    if (q->pwm) { /* PwmInverter.set_state */
        q->have = s[i++] != 0.0;
        q->k = (long long)s[i++];
        for (j = 0; j < 3; ++j) q->d[j] = s[i++];
        for (j = 0; j < 3; ++j) q->s[j] = (int)s[i++];
        for (j = 0; j < 3; ++j) q->dead[j] = s[i++] != 0.0;
        for (j = 0; j < 3; ++j) q->dead_until[j] = s[i++];
        for (j = 0; j < 3; ++j) q->dead_v[j] = s[i++];
    }
    sm_plant_unit_publish(u);
    return SM_CORE_OK;
}

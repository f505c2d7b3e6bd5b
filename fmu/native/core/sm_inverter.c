/* satmotor/converter/inverter.py (InverterParams, duties, half_edges, PwmInverter) and
 * satmotor/control/deadtime.py in C99: the same operations in the same order. */
#include "sm_inverter.h"

#include "sm_phases.h"
#include "sm_pwm_link.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

int sm_inverter_init(sm_inverter *inv, const sm_plant_params *pp, double V_dc, char *msg, size_t msg_len)
{
    sm_inverter q;
    char v[40], b[40], r[128];
    int k;
    if (msg != NULL && msg_len > 0) msg[0] = '\0';
    if (inv == NULL || pp == NULL) return SM_ERR_ARG;
    memset(&q, 0, sizeof q);
    if (sm_choice_parse(SM_CHOICE_PARAM_inverter, pp->inverter, &k, msg, msg_len)) return SM_ERR_PARAM;
    q.pwm = k == SM_CHOICE_inverter_pwm;
    if (sm_require_number("V_dc", V_dc, 1, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("f_sw", pp->f_sw, 1, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("t_dead", pp->t_dead, 1, 0.0, 1, msg, msg_len)) return SM_ERR_PARAM;
    if (!(pp->t_dead < 0.5 / pp->f_sw)) {
        snprintf(r, sizeof r, "must be less than half the carrier period 1/(2 f_sw) = %s s",
                 sm_repr_double(0.5 / pp->f_sw, b, sizeof b));
        return sm_param_error(msg, msg_len, NULL, "t_dead", sm_repr_double(pp->t_dead, v, sizeof v), r);
    }
    if (sm_require_number("v_on", pp->v_on, 1, 0.0, 1, msg, msg_len)) return SM_ERR_PARAM;
    if (!(pp->v_on < 0.5 * V_dc)) {
        snprintf(r, sizeof r, "must be less than V_dc/2 = %s V", sm_repr_double(0.5 * V_dc, b, sizeof b));
        return sm_param_error(msg, msg_len, NULL, "v_on", sm_repr_double(pp->v_on, v, sizeof v), r);
    }
    q.V_dc = V_dc;
    q.f_sw = pp->f_sw;
    q.t_dead = pp->t_dead;
    q.v_on = pp->v_on;
    q.T_h = 0.5 / pp->f_sw;
    q.eps = SM_INV_MERGE_REL * q.T_h;
    sm_inverter_reset(&q);
    memcpy(inv, &q, sizeof q);
    return SM_CORE_OK;
}

void sm_inverter_reset(sm_inverter *inv)
{
    int j;
    if (inv == NULL) return;
    inv->have = 0;
    inv->k = 0;
    for (j = 0; j < 3; ++j) {
        inv->d[j] = 0.5;
        inv->s[j] = -1;
        inv->dead[j] = 0;
        inv->dead_until[j] = 0.0;
        inv->dead_v[j] = 0.0;
    }
}

double sm_inverter_link_voltage(const sm_inverter *inv)
{
    return inv->V_dc;
}

static const double SQRT3_2_FACTOR = 0.5; /* _SQRT3_2 = 0.5 * sqrt(3.0) */

void sm_inverter_duties(double v_alpha, double v_beta, double V_dc, double d[3])
{
    double s32 = SQRT3_2_FACTOR * sqrt(3.0), v[3], hi, lo, z, dx;
    int j;
    v[0] = v_alpha;
    v[1] = -0.5 * v_alpha + s32 * v_beta;
    v[2] = -0.5 * v_alpha - s32 * v_beta;
    hi = v[0] > v[1] ? v[0] : v[1];
    hi = hi > v[2] ? hi : v[2];
    lo = v[0] < v[1] ? v[0] : v[1];
    lo = lo < v[2] ? lo : v[2];
    z = -0.5 * (hi + lo);
    for (j = 0; j < 3; ++j) {
        dx = 0.5 + (v[j] + z) / V_dc;
        d[j] = dx < 0.0 ? 0.0 : dx > 1.0 ? 1.0 : dx;
    }
}

double sm_inverter_intervals_bound(const sm_inverter *inv, double dt)
{
    return (double)SM_INV_EVENTS_PER_HALF * (ceil(dt / inv->T_h) + 1.0) + 1.0;
}

typedef struct {
    double t;
    int order, phase, state;
} edge;

/* half_edges: the ideal edges of half period k, sorted by (time, order); returns their number */
static int half_edges(long long k, double T_h, const double d[3], edge ev[6])
{
    double ts = (double)k * T_h;
    int n = 0, even = k % 2 == 0, x, i, j;
    edge e;
    for (x = 0; x < 3; ++x) {
        double dx = d[x];
        ev[n].t = ts;
        ev[n].order = x;
        ev[n].phase = x;
        ev[n].state = even ? (dx > 0.0 ? 1 : 0) : (dx < 1.0 ? 0 : 1);
        ++n;
        if (0.0 < dx && dx < 1.0) {
            ev[n].t = even ? ts + dx * T_h : ts + (1.0 - dx) * T_h;
            ev[n].order = 3 + x;
            ev[n].phase = x;
            ev[n].state = even ? 0 : 1;
            ++n;
        }
    }
    for (i = 1; i < n; ++i) { /* insertion sort by (t, order): the order of Python's tuple sort */
        e = ev[i];
        j = i - 1;
        while (j >= 0 && (ev[j].t > e.t || (ev[j].t == e.t && ev[j].order > e.order))) {
            ev[j + 1] = ev[j];
            --j;
        }
        ev[j + 1] = e;
    }
    return n;
}

/* PwmInverter._legs, the one rule of either link: each leg's sign sig[j] (+1 the upper device or diode
 * conducts, -1 the lower; a dead leg's diode by the sign of its dead voltage) and on-state drop term dl[j] [V]
 * (-v_on for a positive phase current, +v_on for a negative one, 0 for none or without drops); cur (have_cur)
 * the phase currents [A] at x, computed here when the drops need them */
static int legs(const sm_inverter *q, const sm_motor *p, sm_solve_memo *memo, const double *x, double cur[3],
                int *have_cur, double sig[3], double dl[3])
{
    int j, st;
    for (j = 0; j < 3; ++j) {
        sig[j] = (q->dead[j] ? q->dead_v[j] > 0.0 : q->s[j] == 1) ? 1.0 : -1.0;
        dl[j] = 0.0;
    }
    if (q->v_on > 0.0) {
        if (!*have_cur) {
            sm_plant_outputs o;
            if ((st = sm_plant_outputs_memo(p, memo, x, 0.0, 0.0, &o)) != SM_CORE_OK) return st;
            sm_phase_currents(o.i_s_alpha, o.i_s_beta, cur);
            *have_cur = 1;
        }
        for (j = 0; j < 3; ++j) dl[j] = cur[j] > 0.0 ? -q->v_on : cur[j] < 0.0 ? q->v_on : 0.0;
    }
    return SM_CORE_OK;
}

/* inverter.leg_volts: out = (v_alpha, v_beta, v_a, v_b, v_c) [V] of the legs with half [V] half the link's
 * voltage: phase voltages sig[j] half + dl[j], the star point floating */
static void leg_volts(const double sig[3], const double dl[3], double half, double out[5])
{
    int j;
    for (j = 0; j < 3; ++j) out[2 + j] = sig[j] * half + dl[j];
    sm_alpha_beta(out[2], out[3], out[4], &out[0], &out[1]);
}

/* PwmInverter._advance: one constant interval of L [s] from t with the legs (sig, dl) on the ideal link (lk
 * NULL; half [V] half its voltage) or integrated with the capacitor link lk (the trace row at the link's
 * voltage at t); v_int [V s] the integrals of the applied alpha/beta voltage */
static int advance(const sm_motor *p, sm_solve_memo *memo, sm_pwm_link_run *lk, double *x, double t, double L,
                   const double sig[3], const double dl[3], double half, double T_load, double *trace,
                   size_t trace_cap, size_t *trace_n, double v_int[2])
{
    double qn = ceil(L / p->h_int - 1e-9), vo[5];
    int n = qn > 1.0 ? (int)qn : 1, st, row_kept = trace != NULL && *trace_n < trace_cap;
    if (lk == NULL || row_kept) leg_volts(sig, dl, lk == NULL ? half : 0.5 * x[sm_dclink_iv(p)], vo);
    if (row_kept) {
        double *row = trace + *trace_n * SM_INV_TRACE_WIDTH;
        row[0] = t;
        row[1] = L;
        memcpy(row + 2, vo, sizeof vo);
    }
    ++*trace_n;
    if (lk != NULL) return sm_pwm_link_interval(p, lk, x, t, L, sig, dl, T_load, n, v_int);
    if ((st = sm_plant_step_memo(p, memo, x, vo[0], vo[1], T_load, L, n)) != SM_CORE_OK) return st;
    v_int[0] = vo[0] * L;
    v_int[1] = vo[1] * L;
    return SM_CORE_OK;
}

/* PwmInverter._account: one interval's energies into en = [E_term, E_cond, E_sw, E_cu_s, E_fe] [J] from its
 * states x0 -> x1, the integrals v_int [V s] of the applied voltage over L [s] and the drops dl */
static int account(const sm_motor *p, sm_solve_memo *memo, const double *x0, const double *x1, const double v_int[2],
                   double L, const double dl[3], double en[5])
{
    const double Rs = sm_plant_stator_resistance(p, x0);
    const double qa = (v_int[0] - (x1[0] - x0[0])) / Rs, qb = (v_int[1] - (x1[1] - x0[1])) / Rs;
    double va, vb, Rs1;
    sm_plant_outputs o0, o1;
    int st;
    en[0] += 1.5 * (v_int[0] * qa + v_int[1] * qb) / L;
    if (dl[0] != 0.0 || dl[1] != 0.0 || dl[2] != 0.0) {
        double da, db;
        sm_alpha_beta(dl[0], dl[1], dl[2], &da, &db);
        en[1] -= 1.5 * (da * qa + db * qb);
    }
    if (!(p->R_fe > 0.0)) return SM_CORE_OK;
    va = v_int[0] / L;
    vb = v_int[1] / L;
    if ((st = sm_plant_outputs_memo(p, memo, x0, va, vb, &o0)) != SM_CORE_OK) return st;
    if ((st = sm_plant_outputs_memo(p, memo, x1, va, vb, &o1)) != SM_CORE_OK) return st;
    Rs1 = sm_plant_stator_resistance(p, x1);
    en[3] += 0.75 * L * (Rs * (o0.i_s_alpha * o0.i_s_alpha + o0.i_s_beta * o0.i_s_beta) +
                         Rs1 * (o1.i_s_alpha * o1.i_s_alpha + o1.i_s_beta * o1.i_s_beta));
    en[4] += 0.5 * L * (o0.P_fe + o1.P_fe);
    return SM_CORE_OK;
}

/* PwmInverter.step on the ideal link (l NULL) or the capacitor link l (x then has p->n_states + 3 entries;
 * *chop, *fault, *t_fault: DCLink.step's) */
static int step_any(sm_inverter *inv, const sm_motor *p, const sm_dclink *l, sm_solve_memo *memo, double *x,
                    double t0, double dt, double v_alpha, double v_beta, double T_load, double v_avg[2], int *chop,
                    int *fault, double *t_fault, double *trace, size_t trace_cap, size_t *trace_n)
{
    sm_inverter q;
    edge evs[6];
    sm_pwm_link_run lk;
    double xs[SM_N_LINK_STATES_MAX], T_h, eps, V, half, t1, end, start, tp, sa = 0.0, sb = 0.0;
    double cur[3] = {0.0, 0.0, 0.0}, sig[3] = {0.0, 0.0, 0.0}, dl[3] = {0.0, 0.0, 0.0}, vi[2], te, tn;
    double x0[SM_N_LINK_STATES_MAX], en[5] = {0.0, 0.0, 0.0, 0.0, 0.0};
    long long k;
    int n_ev = 0, ei = 0, have_cur = 0, have_legs = 0, st, j, xd, nx;
    size_t n_local = 0;
    if (inv == NULL || p == NULL || x == NULL || v_avg == NULL) return SM_ERR_ARG;
    if (l != NULL && (chop == NULL || fault == NULL || t_fault == NULL)) return SM_ERR_ARG;
    if (!isfinite(t0) || !isfinite(dt) || !isfinite(v_alpha) || !isfinite(v_beta)) return SM_ERR_NONFINITE;
    if (trace_n == NULL) trace_n = &n_local;
    *trace_n = 0;
    nx = p->n_states + (l != NULL ? 3 : 0);
    memcpy(&q, inv, sizeof q);
    memcpy(xs, x, (size_t)nx * sizeof xs[0]);
    lk.l = l;
    lk.chop = l != NULL ? *chop : 0;
    lk.fault = l != NULL ? *fault : 0;
    lk.t_fault = NAN;
    T_h = q.T_h;
    eps = q.eps;
    V = l == NULL ? sm_inverter_link_voltage(&q) : xs[sm_dclink_iv(p)]; /* the modulator's link voltage */
    if (!(V > 0.0)) V = sm_inverter_link_voltage(&q);                  /* a collapsed link: V_dc */
    half = 0.5 * V;
    t1 = t0 + dt;
    end = t1 - eps;
    start = t0 - eps;
    k = (long long)floor(start / T_h);
    tp = t0;
    for (;;) {
        while (ei == n_ev && (double)k * T_h < end) {
            if (!q.have || k != q.k) {
                sm_inverter_duties(v_alpha, v_beta, V, q.d);
                q.k = k;
                q.have = 1;
            }
            n_ev = half_edges(k, T_h, q.d, evs);
            ei = 0;
            ++k;
        }
        te = ei < n_ev ? evs[ei].t : INFINITY;
        tn = INFINITY;
        xd = -1;
        for (j = 0; j < 3; ++j) {
            if (q.dead[j] && q.dead_until[j] < tn) {
                tn = q.dead_until[j];
                xd = j;
            }
        }
        if (tn > te) { /* dead-interval ends first at a tie */
            tn = te;
            xd = -1;
        }
        if (!(tn < end)) break;
        if (xd < 0 && q.s[evs[ei].phase] == evs[ei].state && tn >= start) { /* an edge that changes nothing */
            ++ei;
            continue;
        }
        if (tn - tp >= eps) {
            if (!have_legs) {
                if ((st = legs(&q, p, memo, xs, cur, &have_cur, sig, dl)) != SM_CORE_OK) return st;
                have_legs = 1;
            }
            memcpy(x0, xs, (size_t)nx * sizeof xs[0]);
            st = advance(p, memo, l == NULL ? NULL : &lk, xs, tp, tn - tp, sig, dl, half, T_load, trace, trace_cap,
                         trace_n, vi);
            if (st != SM_CORE_OK) return st;
            if ((st = account(p, memo, x0, xs, vi, tn - tp, dl, en)) != SM_CORE_OK) return st;
            sa += vi[0];
            sb += vi[1];
            tp = tn;
            have_cur = 0;
            have_legs = 0;
        }
        if (xd >= 0) {
            q.dead[xd] = 0;
            have_legs = 0;
            continue;
        }
        {
            double e = evs[ei].t;
            int jj = evs[ei].phase, nw = evs[ei].state;
            ++ei;
            if (q.k_edge > 0.0 && q.s[jj] >= 0 && nw != q.s[jj] && e >= start) { /* a switching edge's energy */
                if (!have_cur) {
                    sm_plant_outputs o;
                    if ((st = sm_plant_outputs_memo(p, memo, xs, 0.0, 0.0, &o)) != SM_CORE_OK) return st;
                    sm_phase_currents(o.i_s_alpha, o.i_s_beta, cur);
                    have_cur = 1;
                }
                en[2] += q.k_edge * (l == NULL ? V : xs[sm_dclink_iv(p)]) * fabs(cur[jj]);
            }
            if (q.s[jj] < 0 || e < start) { /* unknown state, or an edge of the last step: no dead interval */
                q.s[jj] = nw;
                have_legs = 0;
                continue;
            }
            if (nw == q.s[jj]) continue;
            q.s[jj] = nw;
            have_legs = 0;
            if (q.t_dead > 0.0) {
                double i;
                if (!have_cur) {
                    sm_plant_outputs o;
                    if ((st = sm_plant_outputs_memo(p, memo, xs, 0.0, 0.0, &o)) != SM_CORE_OK) return st;
                    sm_phase_currents(o.i_s_alpha, o.i_s_beta, cur);
                    have_cur = 1;
                }
                i = cur[jj];
                q.dead[jj] = 1;
                q.dead_until[jj] = e + q.t_dead;
                q.dead_v[jj] = i > 0.0 ? -half : i < 0.0 ? half : (nw ? half : -half);
            }
        }
    }
    if (!have_legs) {
        if ((st = legs(&q, p, memo, xs, cur, &have_cur, sig, dl)) != SM_CORE_OK) return st;
    }
    memcpy(x0, xs, (size_t)nx * sizeof xs[0]);
    st = advance(p, memo, l == NULL ? NULL : &lk, xs, tp, t1 - tp, sig, dl, half, T_load, trace, trace_cap, trace_n,
                 vi);
    if (st != SM_CORE_OK) return st;
    if ((st = account(p, memo, x0, xs, vi, t1 - tp, dl, en)) != SM_CORE_OK) return st;
    sa += vi[0];
    sb += vi[1];
    memcpy(q.energies, en, sizeof en);
    if (l != NULL) {
        *chop = lk.chop;
        *fault = lk.fault;
        *t_fault = lk.t_fault;
    }
    v_avg[0] = sa / dt;
    v_avg[1] = sb / dt;
    memcpy(x, xs, (size_t)nx * sizeof xs[0]);
    memcpy(inv, &q, sizeof q);
    return SM_CORE_OK;
}

int sm_inverter_step(sm_inverter *inv, const sm_motor *p, double *x, double t0, double dt, double v_alpha,
                     double v_beta, double T_load, double v_avg[2], double *trace, size_t trace_cap,
                     size_t *trace_n)
{
    return step_any(inv, p, NULL, NULL, x, t0, dt, v_alpha, v_beta, T_load, v_avg, NULL, NULL, NULL, trace,
                    trace_cap, trace_n);
}

int sm_inverter_step_memo(sm_inverter *inv, const sm_motor *p, sm_solve_memo *memo, double *x, double t0,
                          double dt, double v_alpha, double v_beta, double T_load, double v_avg[2], double *trace,
                          size_t trace_cap, size_t *trace_n)
{
    return step_any(inv, p, NULL, memo, x, t0, dt, v_alpha, v_beta, T_load, v_avg, NULL, NULL, NULL, trace,
                    trace_cap, trace_n);
}

int sm_inverter_step_link(sm_inverter *inv, const sm_motor *p, const sm_dclink *l, sm_solve_memo *memo, double *x,
                          double t0, double dt, double v_alpha, double v_beta, double T_load, double v_avg[2],
                          int *chop, int *fault, double *t_fault, double *trace, size_t trace_cap, size_t *trace_n)
{
    if (l == NULL) return SM_ERR_ARG;
    return step_any(inv, p, l, memo, x, t0, dt, v_alpha, v_beta, T_load, v_avg, chop, fault, t_fault, trace,
                    trace_cap, trace_n);
}

static double sign_times(double i, double v)
{
    return i > 0.0 ? v : i < 0.0 ? -v : 0.0;
}

void sm_deadtime_compensate(double *v_alpha, double *v_beta, double i_alpha, double i_beta, double V_comp)
{
    double c[3], ca, cb;
    if (V_comp == 0.0) return;
    sm_phase_currents(i_alpha, i_beta, c);
    sm_alpha_beta(sign_times(c[0], V_comp), sign_times(c[1], V_comp), sign_times(c[2], V_comp), &ca, &cb);
    *v_alpha = *v_alpha + ca;
    *v_beta = *v_beta + cb;
}

size_t sm_inverter_size(void)
{
    return sizeof(sm_inverter);
}

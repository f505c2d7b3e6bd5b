/* Magnetizing curves: satmotor/machine/magnetics.py and satmotor/machine/table_curve.py transcribed to C99
 * (the table file's reading: sm_table_file.c; messages: sm_common.c).  No global mutable state. */
#include "sm_curves.h"
#include "sm_params.h" /* generated: sm_choice_parse */

#include "sm_atan.h"
#include "sm_table_file.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* ------------------------------------------------------------------ analytic curves */

#define SM_REL_TOL 4.0e-16
#define SM_MAX_ITER 200

/* (psi, dpsi/dI) of every curve but the polynomial one (which goes through its own Newton). */
static void psi_dpsi(const sm_curve *c, double I, double *psi, double *dpsi);

static int table_locate(const sm_curve *c, double I)
{
    /* bisect.bisect_right(x, I) - 1, floored at 0 (NaN goes to the last segment, as in Python) */
    int lo = 0, hi = c->n;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (I < c->x[mid]) hi = mid;
        else lo = mid + 1;
    }
    lo -= 1;
    return lo >= 0 ? lo : 0;
}

/* PolynomialCurve._psi_of_current; NaN if no convergence */
static double poly_psi_of_current(const sm_curve *c, double I)
{
    double inv_l, b, y, yn1, step, prev, older = NAN;
    int n, it;
    if (I <= 0.0) return 0.0;
    if (!isfinite(I)) return NAN;
    inv_l = 1.0 / c->L_m0;
    b = c->poly_b;
    n = c->poly_n;
    y = c->L_m0 * I;
    for (it = 0; it < SM_MAX_ITER; ++it) {
        yn1 = pow(y, (double)(n - 1));
        step = (y * inv_l + b * yn1 * y - I) / (inv_l + (double)n * b * yn1);
        prev = y;
        y -= step;
        if (fabs(step) <= SM_REL_TOL * y) return y;
        if (y == older) return fmin(y, prev); /* a two-cycle of the rounding (the Python's comment) */
        older = prev;
    }
    return NAN;
}

static double poly_m_of_psi(const sm_curve *c, double y)
{
    return 1.0 / (1.0 / c->L_m0 + c->poly_b * pow(y, (double)(c->poly_n - 1)));
}

static double poly_ldyn_of_psi(const sm_curve *c, double y)
{
    return 1.0 / (1.0 / c->L_m0 + (double)c->poly_n * c->poly_b * pow(y, (double)(c->poly_n - 1)));
}

static void psi_dpsi(const sm_curve *c, double I, double *psi, double *dpsi)
{
    double x, d, t;
    int k;
    switch (c->kind) {
    case SM_CURVE_LINEAR:
        *psi = c->L_m0 * I;
        *dpsi = c->L_m0;
        return;
    case SM_CURVE_ARCTAN:
        x = I / c->I_par;
        d = c->L_m0 - c->L_m_inf;
        *psi = c->L_m_inf * I + d * c->I_par * sm_atan(x);
        *dpsi = c->L_m_inf + d / (1.0 + x * x);
        return;
    case SM_CURVE_EXPONENTIAL:
        x = I / c->I_par;
        d = c->L_m0 - c->L_m_inf;
        *psi = c->L_m_inf * I - d * c->I_par * expm1(-x);
        *dpsi = c->L_m_inf + d * exp(-x);
        return;
    case SM_CURVE_POLYNOMIAL:
        t = poly_psi_of_current(c, I);
        *psi = t;
        *dpsi = poly_ldyn_of_psi(c, t);
        return;
    case SM_CURVE_TABLE:
        k = table_locate(c, I);
        t = I - c->x[k];
        *psi = c->y0[k] + t * (c->d0[k] + t * (c->c2[k] + t * c->c3[k]));
        *dpsi = c->d0[k] + t * (2.0 * c->c2[k] + 3.0 * t * c->c3[k]);
        return;
    }
    *psi = NAN;
    *dpsi = NAN;
}

double sm_curve_psi(const sm_curve *c, double I)
{
    double psi, dpsi;
    if (c == NULL) return NAN;
    if (c->kind == SM_CURVE_POLYNOMIAL) return poly_psi_of_current(c, I);
    psi_dpsi(c, I, &psi, &dpsi);
    return psi;
}

double sm_curve_L_dyn(const sm_curve *c, double I)
{
    double psi, dpsi;
    if (c == NULL) return NAN;
    psi_dpsi(c, I, &psi, &dpsi);
    return dpsi;
}

double sm_curve_m(const sm_curve *c, double I)
{
    double x, g, x2, psi, dpsi;
    if (c == NULL) return NAN;
    switch (c->kind) {
    case SM_CURVE_LINEAR:
        return c->L_m0;
    case SM_CURVE_ARCTAN:
        x = I / c->I_par;
        if (x < 1e-2) {
            x2 = x * x;
            g = 1.0 - x2 * (1.0 / 3.0 - x2 * (1.0 / 5.0 - x2 * (1.0 / 7.0 - x2 / 9.0)));
        } else {
            g = sm_atan(x) / x;
        }
        return c->L_m_inf + (c->L_m0 - c->L_m_inf) * g;
    case SM_CURVE_EXPONENTIAL:
        x = I / c->I_par;
        g = (x == 0.0) ? 1.0 - x / 2.0 : -expm1(-x) / x;
        return c->L_m_inf + (c->L_m0 - c->L_m_inf) * g;
    case SM_CURVE_POLYNOMIAL:
        return poly_m_of_psi(c, poly_psi_of_current(c, I));
    case SM_CURVE_TABLE:
        if (I < c->x[1]) return c->d0[0] + I * (c->c2[0] + I * c->c3[0]);
        psi_dpsi(c, I, &psi, &dpsi);
        return psi / I;
    }
    return NAN;
}

double sm_curve_dm_dI(const sm_curve *c, double I)
{
    double x, x2, dg, y, m, ldyn, psi;
    int n;
    if (c == NULL) return NAN;
    switch (c->kind) {
    case SM_CURVE_LINEAR:
        return 0.0;
    case SM_CURVE_ARCTAN:
        x = I / c->I_par;
        if (x < 1e-2) {
            x2 = x * x;
            dg = -x * (2.0 / 3.0 - x2 * (4.0 / 5.0 - x2 * (6.0 / 7.0 - x2 * 8.0 / 9.0)));
        } else {
            dg = (x / (1.0 + x * x) - sm_atan(x)) / (x * x);
        }
        return (c->L_m0 - c->L_m_inf) * dg / c->I_par;
    case SM_CURVE_EXPONENTIAL:
        x = I / c->I_par;
        if (x < 2e-2) {
            dg = -0.5 + x * (1.0 / 3.0 - x * (1.0 / 8.0 - x * (1.0 / 30.0 - x * (1.0 / 144.0
                 - x * (1.0 / 840.0 - x / 5760.0)))));
        } else {
            dg = (exp(-x) * (1.0 + x) - 1.0) / (x * x);
        }
        return (c->L_m0 - c->L_m_inf) * dg / c->I_par;
    case SM_CURVE_POLYNOMIAL:
        y = poly_psi_of_current(c, I);
        n = c->poly_n;
        m = poly_m_of_psi(c, y);
        ldyn = poly_ldyn_of_psi(c, y);
        return -m * m * c->poly_b * (double)(n - 1) * pow(y, (double)(n - 2)) * ldyn;
    case SM_CURVE_TABLE:
        if (I < c->x[1]) return c->c2[0] + 2.0 * c->c3[0] * I;
        psi_dpsi(c, I, &psi, &ldyn);
        return (ldyn - psi / I) / I;
    }
    return NAN;
}

void sm_curve_evaluate(const sm_curve *c, double I, double *psi, double *m, double *dm, double *L_dyn)
{
    double p, l, mm, d;
    if (c == NULL) {
        p = l = mm = d = NAN;
    } else if (c->kind == SM_CURVE_POLYNOMIAL) {
        int n = c->poly_n;
        p = poly_psi_of_current(c, I);
        mm = poly_m_of_psi(c, p);
        l = poly_ldyn_of_psi(c, p);
        d = -mm * mm * c->poly_b * (double)(n - 1) * pow(p, (double)(n - 2)) * l;
    } else if (c->kind == SM_CURVE_ARCTAN) {
        /* ArctanCurve.evaluate: one atan for psi, m and dm_dI, the same floats as the three apart */
        double x = I / c->I_par, dd = c->L_m0 - c->L_m_inf, at = sm_atan(x), g, dg, x2;
        p = c->L_m_inf * I + dd * c->I_par * at;
        l = c->L_m_inf + dd / (1.0 + x * x);
        if (x < 1e-2) {
            x2 = x * x;
            g = 1.0 - x2 * (1.0 / 3.0 - x2 * (1.0 / 5.0 - x2 * (1.0 / 7.0 - x2 / 9.0)));
            dg = -x * (2.0 / 3.0 - x2 * (4.0 / 5.0 - x2 * (6.0 / 7.0 - x2 * 8.0 / 9.0)));
        } else {
            g = at / x;
            dg = (x / (1.0 + x * x) - at) / (x * x);
        }
        mm = c->L_m_inf + dd * g;
        d = dd * dg / c->I_par;
    } else {
        psi_dpsi(c, I, &p, &l);
        mm = sm_curve_m(c, I);
        d = sm_curve_dm_dI(c, I);
    }
    if (psi != NULL) *psi = p;
    if (m != NULL) *m = mm;
    if (dm != NULL) *dm = d;
    if (L_dyn != NULL) *L_dyn = l;
}

/* _Curve.solve: safeguarded Newton from c / (a + m0), or from guess when it lies between that bound
 * and infinity (a warm start).  For the arctan curve the Python runs an inlined copy with the same
 * operations in the same order, i.e. this same iteration. */
static int generic_solve(const sm_curve *c, double a, double cc, double guess, double *I, double *psi_out)
{
    double lo = 0.0, hi = INFINITY, x, psi, dpsi, g, x_new, step;
    int it;
    x = cc / (a + c->m0);
    if (x < guess && guess < hi) x = guess;
    psi_dpsi(c, x, &psi, &dpsi);
    for (it = 0; it < SM_MAX_ITER; ++it) {
        g = a * x + psi - cc;
        if (g > 0.0) hi = x;
        else if (g < 0.0) lo = x;
        else {
            *I = x;
            *psi_out = psi;
            return SM_CORE_OK;
        }
        x_new = x - g / (a + dpsi);
        if (!(lo < x_new && x_new < hi)) x_new = (hi < INFINITY) ? 0.5 * (lo + hi) : 2.0 * x;
        step = x_new - x;
        x = x_new;
        psi_dpsi(c, x, &psi, &dpsi);
        if (fabs(step) <= SM_REL_TOL * x) {
            *I = x;
            *psi_out = psi;
            return SM_CORE_OK;
        }
    }
    *I = NAN;
    *psi_out = NAN;
    return SM_ERR_NOCONV;
}

/* PolynomialCurve._flux: root psi of a I(psi) + psi = c (Newton from above) */
static int poly_flux(const sm_curve *c, double a, double cc, double *y_out)
{
    double inv_l = 1.0 / c->L_m0, b = c->poly_b, y, yn1, h, step, prev, older = NAN;
    int n = c->poly_n, it;
    if (cc <= 0.0) {
        *y_out = 0.0;
        return SM_CORE_OK;
    }
    y = cc / (1.0 + a * inv_l);
    for (it = 0; it < SM_MAX_ITER; ++it) {
        yn1 = pow(y, (double)(n - 1));
        h = a * (y * inv_l + b * yn1 * y) + y - cc;
        step = h / (a * (inv_l + (double)n * b * yn1) + 1.0);
        prev = y;
        y -= step;
        if (fabs(step) <= SM_REL_TOL * y) {
            *y_out = y;
            return SM_CORE_OK;
        }
        if (y == older) { /* a two-cycle of the rounding (poly_psi_of_current) */
            *y_out = fmin(y, prev);
            return SM_CORE_OK;
        }
        older = prev;
    }
    *y_out = NAN;
    return SM_ERR_NOCONV;
}

static double poly_current(const sm_curve *c, double psi)
{
    return psi / c->L_m0 + c->poly_b * pow(psi, (double)c->poly_n);
}

int sm_curve_solve(const sm_curve *c, double a, double cc, double *I, double *psi)
{
    return sm_curve_solve_from(c, a, cc, 0.0, I, psi);
}

int sm_curve_solve_from(const sm_curve *c, double a, double cc, double guess, double *I, double *psi)
{
    double Iv = NAN, pv = NAN;
    int st = SM_CORE_OK;
    if (c == NULL) return SM_ERR_ARG;
    if (!isfinite(a) || !isfinite(cc)) {
        st = SM_ERR_NONFINITE;
    } else if (c->kind == SM_CURVE_POLYNOMIAL) {
        st = poly_flux(c, a, cc, &pv);
        if (st == SM_CORE_OK) Iv = poly_current(c, pv);
    } else if (cc <= 0.0) {
        Iv = 0.0;
        pv = 0.0;
    } else if (c->kind == SM_CURVE_LINEAR) {
        Iv = cc / (a + c->L_m0);
        pv = c->L_m0 * Iv;
    } else {
        st = generic_solve(c, a, cc, guess, &Iv, &pv);
    }
    if (I != NULL) *I = Iv;
    if (psi != NULL) *psi = pv;
    return st;
}

int sm_curve_current(const sm_curve *c, double psi, double *I)
{
    double p;
    if (c == NULL) return SM_ERR_ARG;
    if (!isfinite(psi)) {
        if (I != NULL) *I = NAN;
        return SM_ERR_NONFINITE;
    }
    if (c->kind == SM_CURVE_POLYNOMIAL) {
        if (I != NULL) *I = poly_current(c, psi);
        return SM_CORE_OK;
    }
    return sm_curve_solve(c, 0.0, psi, I, &p);
}

void sm_inductance_matrix(double m, double dm, double i_d, double i_q, double I, double *Md,
                          double *Mq, double *Mdq)
{
    double s = (I > 0.0) ? dm / I : 0.0;
    if (Md != NULL) *Md = m + s * i_d * i_d;
    if (Mq != NULL) *Mq = m + s * i_q * i_q;
    if (Mdq != NULL) *Mdq = s * i_d * i_q;
}

/* ------------------------------------------------------------------ construction and checks */

static int check_saturating(double L_m0, double L_m_inf, double I_par, char *msg, size_t msg_len)
{
    char v[40], r[96], b[40];
    if (sm_require_number("L_m0", L_m0, 1, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("L_m_inf", L_m_inf, 1, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
    if (sm_require_number("I_par", I_par, 1, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
    if (L_m_inf >= L_m0) {
        snprintf(r, sizeof r, "must be < L_m0 = %s for a saturating curve",
                 sm_repr_double(L_m0, b, sizeof b));
        return sm_param_error(msg, msg_len, NULL, "L_m_inf", sm_repr_double(L_m_inf, v, sizeof v), r);
    }
    return SM_CORE_OK;
}

/* numpy.sign of a double: -1, 0, 1, NaN for NaN */
static double sgn(double v)
{
    if (v > 0.0) return 1.0;
    if (v < 0.0) return -1.0;
    if (v == 0.0) return 0.0;
    return v;
}

static double pchip_edge(double h0, double h1, double s0, double s1)
{
    double e = ((2.0 * h0 + h1) * s0 - h0 * s1) / (h0 + h1);
    if (sgn(e) != sgn(s0)) return 0.0;
    if (sgn(s0) != sgn(s1) && fabs(e) > 3.0 * fabs(s0)) return 3.0 * s0;
    return e;
}

/* "(v0, v1, ...)": Python repr of a tuple of floats (truncated to buf_len) */
static char *repr_tuple(const double *v, int n, char *buf, size_t buf_len)
{
    size_t o = 0;
    int i;
    char one[40];
    if (buf_len == 0) return buf;
    buf[0] = '\0';
#define SM_APPEND(s) do { size_t l_ = strlen(s); if (o + l_ < buf_len) { memcpy(buf + o, (s), l_); o += l_; buf[o] = '\0'; } } while (0)
    SM_APPEND("(");
    for (i = 0; i < n; ++i) {
        if (i > 0) SM_APPEND(", ");
        sm_repr_double(v[i], one, sizeof one);
        SM_APPEND(one);
    }
    if (n == 1) SM_APPEND(",");
    SM_APPEND(")");
#undef SM_APPEND
    return buf;
}

typedef struct {
    const double *raw_x; /* the given points, before the origin is added */
    int n_raw;
    const int *lines;    /* file line of each given point, or NULL */
    const char *source;  /* file name, or NULL */
} table_origin;

/* TableCurve._where(k) */
static void where(const table_origin *o, int k, char *buf, size_t n)
{
    int j = k - ((o->n_raw > 0 && o->raw_x[0] == 0.0) ? 0 : 1);
    if (o->lines != NULL && j >= 0 && j < o->n_raw) snprintf(buf, n, " on line %d", o->lines[j]);
    else if (j >= 0) snprintf(buf, n, " %d", j + 1);
    else snprintf(buf, n, " 0 (the origin, added)");
}

/* TableCurve.__init__/_validated/__post_init__ from the given points */
static int table_build(sm_curve *c, const double *xi, const double *yi, int n_in, const int *lines,
                       const char *source, char *msg, size_t msg_len)
{
    double x[SM_TABLE_MAX], y[SM_TABLE_MAX];
    double xm[2 * SM_TABLE_MAX], ym[2 * SM_TABLE_MAX], hm[2 * SM_TABLE_MAX], sm[2 * SM_TABLE_MAX];
    double dm[2 * SM_TABLE_MAX];
    char tup[1024], reason[1400], field[32], v1[40];
    table_origin org;
    int n, i, k, N, pass;
    org.raw_x = xi;
    org.n_raw = n_in;
    org.lines = lines;
    org.source = source;
    for (pass = 0; pass < 2; ++pass) {
        const double *v = pass == 0 ? xi : yi;
        const char *name = pass == 0 ? "i_mu" : "psi_m";
        for (i = 0; i < n_in; ++i)
            if (!isfinite(v[i]))
                return sm_param_error(msg, msg_len, source, name, repr_tuple(v, n_in, tup, sizeof tup),
                                      "must be finite numbers");
        for (i = 0; i < n_in; ++i)
            if (v[i] < 0)
                return sm_param_error(msg, msg_len, source, name, repr_tuple(v, n_in, tup, sizeof tup),
                                      "must be >= 0");
    }
    n = 0;
    if (n_in > 0 && xi[0] == 0.0) {
        if (yi[0] != 0.0)
            return sm_param_error(msg, msg_len, source, "psi_m", repr_tuple(yi, n_in, tup, sizeof tup),
                                  "must be 0 at i_mu = 0");
    } else {
        x[0] = 0.0;
        y[0] = 0.0;
        n = 1;
    }
    if (n + n_in > SM_TABLE_MAX) {
        snprintf(reason, sizeof reason, "has %d points, more than the native limit SM_TABLE_MAX = %d",
                 n + n_in, SM_TABLE_MAX);
        snprintf(v1, sizeof v1, "(%d points)", n_in);
        return sm_param_error(msg, msg_len, source, "i_mu", v1, reason);
    }
    for (i = 0; i < n_in; ++i) {
        x[n + i] = xi[i];
        y[n + i] = yi[i];
    }
    n += n_in;
    if (n < 3)
        return sm_param_error(msg, msg_len, source, "i_mu", repr_tuple(x, n, tup, sizeof tup),
                              "needs at least two points with i_mu > 0");
    for (pass = 0; pass < 2; ++pass) {
        const double *v = pass == 0 ? x : y;
        for (k = 1; k < n; ++k) {
            if (!(v[k] - v[k - 1] <= 0)) continue;
            {
                char w1[48], w0[48], a[40], b[40], cx[40], d[40];
                where(&org, k, w1, sizeof w1);
                where(&org, k - 1, w0, sizeof w0);
                snprintf(reason, sizeof reason,
                         "%s: point%s (i_mu = %s, psi_m = %s) is not above the previous one%s (i_mu = %s, "
                         "psi_m = %s); noisy no-load points? make them monotone (satmotor-cosim fit-curve "
                         "writes such a table)",
                         pass == 0 ? "i_mu must increase from point to point (sorted, no repeats)"
                                   : "psi_m must increase with i_mu",
                         w1, sm_repr_double(x[k], a, sizeof a), sm_repr_double(y[k], b, sizeof b), w0,
                         sm_repr_double(x[k - 1], cx, sizeof cx), sm_repr_double(y[k - 1], d, sizeof d));
                snprintf(field, sizeof field, "%s[%d]", pass == 0 ? "i_mu" : "psi_m", k);
                return sm_param_error(msg, msg_len, source, field, sm_repr_double(v[k], v1, sizeof v1),
                                      reason);
            }
        }
    }
    /* mirror to make the data odd, PCHIP slopes (scipy's algorithm, as _pchip_slopes) */
    N = 2 * n - 1;
    for (i = 0; i < n - 1; ++i) {
        xm[i] = -x[n - 1 - i];
        ym[i] = -y[n - 1 - i];
    }
    for (i = 0; i < n; ++i) {
        xm[n - 1 + i] = x[i];
        ym[n - 1 + i] = y[i];
    }
    for (i = 0; i < N - 1; ++i) {
        hm[i] = xm[i + 1] - xm[i];
        sm[i] = (ym[i + 1] - ym[i]) / hm[i];
    }
    for (i = 1; i < N - 1; ++i) {
        double w1 = 2.0 * hm[i] + hm[i - 1], w2 = hm[i] + 2.0 * hm[i - 1];
        int same = sgn(sm[i]) == sgn(sm[i - 1]) && sm[i] != 0 && sm[i - 1] != 0;
        dm[i] = same ? (w1 + w2) / (w1 / sm[i - 1] + w2 / sm[i]) : 0.0;
    }
    dm[0] = pchip_edge(hm[0], hm[1], sm[0], sm[1]);
    dm[N - 1] = pchip_edge(hm[N - 2], hm[N - 3], sm[N - 2], sm[N - 3]);
    {
        const double *d = dm + (n - 1);
        if (!(d[n - 1] > 0.0)) {
            double s_last = (y[n - 1] - y[n - 2]) / (x[n - 1] - x[n - 2]);
            double s_prev = (y[n - 2] - y[n - 3]) / (x[n - 2] - x[n - 3]);
            char w[48], a[40], b[40];
            where(&org, n - 1, w, sizeof w);
            snprintf(reason, sizeof reason,
                     "the monotone interpolation ends flat (end slope %s H, must be > 0): the last point%s "
                     "(i_mu = %s) rises with slope %.4g H, less than about a third of the slope %.4g H of "
                     "the segment before; noisy points in saturation? smooth them (satmotor-cosim fit-curve "
                     "writes a table that loads) or drop the last point",
                     sm_repr_double(d[n - 1], a, sizeof a), w, sm_repr_double(x[n - 1], b, sizeof b),
                     s_last, s_prev);
            snprintf(field, sizeof field, "psi_m[%d]", n - 1);
            return sm_param_error(msg, msg_len, source, field, sm_repr_double(y[n - 1], v1, sizeof v1),
                                  reason);
        }
        memset(c, 0, sizeof *c);
        c->kind = SM_CURVE_TABLE;
        c->n = n;
        for (k = 0; k < n - 1; ++k) {
            double h = x[k + 1] - x[k];
            double s = (y[k + 1] - y[k]) / h;
            c->x[k] = x[k];
            c->y0[k] = y[k];
            c->d0[k] = d[k];
            c->c2[k] = (3.0 * s - 2.0 * d[k] - d[k + 1]) / h;
            c->c3[k] = (d[k] + d[k + 1] - 2.0 * s) / (h * h);
        }
        c->x[n - 1] = x[n - 1];
        c->y0[n - 1] = y[n - 1];
        c->d0[n - 1] = d[n - 1];
        c->c2[n - 1] = 0.0;
        c->c3[n - 1] = 0.0;
        c->m0 = c->d0[0];
        c->L_m0 = c->m0;
    }
    return SM_CORE_OK;
}

int sm_curve_init_table(sm_curve *c, const double *i_mu, const double *psi_m, int n_points, char *msg,
                        size_t msg_len)
{
    if (c == NULL || (n_points > 0 && (i_mu == NULL || psi_m == NULL)) || n_points < 0) {
        if (msg != NULL && msg_len > 0) snprintf(msg, msg_len, "sm_curve_init_table: bad arguments");
        return SM_ERR_ARG;
    }
    return table_build(c, i_mu, psi_m, n_points, NULL, NULL, msg, msg_len);
}

/* TableCurve.from_csv: the file's points (sm_table_file.c) made a curve, messages naming the file's lines */
static int table_from_file(sm_curve *c, const char *path, char *msg, size_t msg_len)
{
    double xs[SM_TABLE_MAX + 1], ys[SM_TABLE_MAX + 1];
    int lines[SM_TABLE_MAX + 1], rows, st;
    if ((st = sm_table_file_read(path, SM_TABLE_MAX, xs, ys, lines, &rows, msg, msg_len)) != SM_CORE_OK) return st;
    return table_build(c, xs, ys, rows, lines, path, msg, msg_len);
}

int sm_curve_init(sm_curve *c, const char *name, double L_m0, double L_m_inf, double I_par,
                  double poly_b, int poly_n, const char *table_path, char *msg, size_t msg_len)
{
    char v[1200];
    int st, k;
    if (msg != NULL && msg_len > 0) msg[0] = '\0';
    if (c == NULL) {
        if (msg != NULL && msg_len > 0) snprintf(msg, msg_len, "sm_curve_init: NULL curve");
        return SM_ERR_ARG;
    }
    if (name == NULL) name = "";
    /* the generated parser (sm_params.h: the choices of the parameter curve in satmotor/interface.py) */
    if ((st = sm_choice_parse(SM_CHOICE_PARAM_curve, name, &k, msg, msg_len))) return st;
    switch ((sm_curve_choice)k) {
    case SM_CHOICE_curve_table:
        if (table_path == NULL || table_path[0] == '\0')
            return sm_param_error(msg, msg_len, NULL, "table_file", sm_repr_str(table_path, v, sizeof v),
                                  "is required when curve = 'table'");
        return table_from_file(c, table_path, msg, msg_len);
    case SM_CHOICE_curve_arctan:
    case SM_CHOICE_curve_exponential:
        st = check_saturating(L_m0, L_m_inf, I_par, msg, msg_len);
        if (st) return st;
        memset(c, 0, sizeof *c);
        c->kind = k == SM_CHOICE_curve_arctan ? SM_CURVE_ARCTAN : SM_CURVE_EXPONENTIAL;
        c->L_m0 = L_m0;
        c->L_m_inf = L_m_inf;
        c->I_par = I_par;
        c->m0 = L_m0;
        return SM_CORE_OK;
    case SM_CHOICE_curve_polynomial:
        if (sm_require_number("L_m0", L_m0, 1, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
        if (sm_require_number("poly_b", poly_b, 1, 0.0, 1, msg, msg_len)) return SM_ERR_PARAM;
        if (sm_require_integer("poly_n", poly_n, 2, msg, msg_len)) return SM_ERR_PARAM;
        memset(c, 0, sizeof *c);
        c->kind = SM_CURVE_POLYNOMIAL;
        c->L_m0 = L_m0;
        c->poly_b = poly_b;
        c->poly_n = poly_n;
        c->m0 = L_m0;
        return SM_CORE_OK;
    case SM_CHOICE_curve_linear:
        if (sm_require_number("L_m0", L_m0, 1, 0.0, 0, msg, msg_len)) return SM_ERR_PARAM;
        memset(c, 0, sizeof *c);
        c->kind = SM_CURVE_LINEAR;
        c->L_m0 = L_m0;
        c->m0 = L_m0;
        return SM_CORE_OK;
    }
    return SM_ERR_ARG; /* not reached: sm_choice_parse returned one of the choices */
}

size_t sm_curve_size(void)
{
    return sizeof(sm_curve);
}

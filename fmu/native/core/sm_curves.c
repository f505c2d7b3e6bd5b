/* Magnetizing curves: satmotor/machine/magnetics.py and satmotor/machine/table_curve.py transcribed to C99.
 * Also the helpers of sm_common.h (Python-style messages).  No global mutable state. */
#include "sm_curves.h"
#include "sm_params.h" /* generated: sm_choice_parse */

#include "sm_atan.h"

#include <errno.h>
#include <float.h>
#include <locale.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------ sm_common.h helpers */

char *sm_repr_double(double v, char *buf, size_t buf_len)
{
    char e[40], digits[24];
    int p, decpt, nd = 0, i, neg;
    size_t o = 0;
    char out[64];
    if (buf == NULL || buf_len == 0) return buf;
    if (isnan(v)) { snprintf(buf, buf_len, "nan"); return buf; }
    if (isinf(v)) { snprintf(buf, buf_len, "%s", v < 0 ? "-inf" : "inf"); return buf; }
    if (v == 0.0) { snprintf(buf, buf_len, "%s", signbit(v) ? "-0.0" : "0.0"); return buf; }
    neg = v < 0;
    /* shortest correctly rounded digit string that reads back to v */
    for (p = 1; p <= 17; ++p) {
        snprintf(e, sizeof e, "%.*e", p - 1, fabs(v));
        if (strtod(e, NULL) == fabs(v)) break;
    }
    /* e = d[.ddd]e[+-]XX */
    for (i = 0; e[i] != 'e' && e[i] != '\0'; ++i)
        if (e[i] >= '0' && e[i] <= '9' && nd < 20) digits[nd++] = e[i];
    digits[nd] = '\0';
    decpt = (e[i] == 'e') ? atoi(e + i + 1) + 1 : 1;
    while (nd > 1 && digits[nd - 1] == '0') digits[--nd] = '\0';
    if (neg) out[o++] = '-';
    if (decpt <= -4 || decpt > 16) {
        int ex = decpt - 1;
        out[o++] = digits[0];
        if (nd > 1) {
            out[o++] = '.';
            for (i = 1; i < nd; ++i) out[o++] = digits[i];
        }
        o += (size_t)snprintf(out + o, sizeof out - o, "e%c%02d", ex < 0 ? '-' : '+', ex < 0 ? -ex : ex);
    } else if (decpt <= 0) {
        out[o++] = '0';
        out[o++] = '.';
        for (i = 0; i < -decpt; ++i) out[o++] = '0';
        for (i = 0; i < nd; ++i) out[o++] = digits[i];
    } else if (decpt >= nd) {
        for (i = 0; i < nd; ++i) out[o++] = digits[i];
        for (i = nd; i < decpt; ++i) out[o++] = '0';
        out[o++] = '.';
        out[o++] = '0';
    } else {
        for (i = 0; i < decpt; ++i) out[o++] = digits[i];
        out[o++] = '.';
        for (i = decpt; i < nd; ++i) out[o++] = digits[i];
    }
    if (o >= sizeof out) o = sizeof out - 1;
    out[o] = '\0';
    snprintf(buf, buf_len, "%s", out);
    return buf;
}

char *sm_repr_str(const char *s, char *buf, size_t buf_len)
{
    size_t o = 0;
    char q;
    const char *c;
    if (buf == NULL || buf_len == 0) return buf;
    if (s == NULL) s = "";
    q = (strchr(s, '\'') != NULL && strchr(s, '"') == NULL) ? '"' : '\'';
#define SM_PUT(ch) do { if (o + 1 < buf_len) buf[o++] = (ch); } while (0)
    SM_PUT(q);
    for (c = s; *c != '\0'; ++c) {
        unsigned char u = (unsigned char)*c;
        if (u == '\\' || u == (unsigned char)q) { SM_PUT('\\'); SM_PUT((char)u); }
        else if (u == '\n') { SM_PUT('\\'); SM_PUT('n'); }
        else if (u == '\r') { SM_PUT('\\'); SM_PUT('r'); }
        else if (u == '\t') { SM_PUT('\\'); SM_PUT('t'); }
        else if (u < 0x20 || u == 0x7f) {
            const char *hex = "0123456789abcdef";
            SM_PUT('\\'); SM_PUT('x'); SM_PUT(hex[u >> 4]); SM_PUT(hex[u & 15u]);
        } else SM_PUT((char)u);
    }
    SM_PUT(q);
#undef SM_PUT
    buf[o] = '\0';
    return buf;
}

int sm_param_error(char *msg, size_t msg_len, const char *source, const char *field,
                   const char *value_repr, const char *reason)
{
    if (msg != NULL && msg_len > 0) {
        if (source != NULL)
            snprintf(msg, msg_len, "%s: %s = %s: %s", source, field, value_repr, reason);
        else
            snprintf(msg, msg_len, "%s = %s: %s", field, value_repr, reason);
    }
    return SM_ERR_PARAM;
}

/* Python str() of a bound given as float or int: the Python calls pass ints (0) */
static void bound_str(double b, char *buf, size_t n)
{
    if (b == floor(b) && fabs(b) < 1e15) snprintf(buf, n, "%.0f", b);
    else sm_repr_double(b, buf, n);
}

int sm_require_number(const char *field, double value, int has_lower, double lower, int inclusive,
                      char *msg, size_t msg_len)
{
    int ok = isfinite(value);
    char v[40], b[40], reason[96];
    if (ok && has_lower) ok = inclusive ? value >= lower : value > lower;
    if (ok) return SM_CORE_OK;
    sm_repr_double(value, v, sizeof v);
    if (has_lower) {
        bound_str(lower, b, sizeof b);
        snprintf(reason, sizeof reason, "must be a finite number %s %s", inclusive ? ">=" : ">", b);
    } else {
        snprintf(reason, sizeof reason, "must be a finite number");
    }
    return sm_param_error(msg, msg_len, NULL, field, v, reason);
}

int sm_require_integer(const char *field, int value, int lower, char *msg, size_t msg_len)
{
    char v[24], reason[64];
    if (value >= lower) return SM_CORE_OK;
    snprintf(v, sizeof v, "%d", value);
    snprintf(reason, sizeof reason, "must be an integer >= %d", lower);
    return sm_param_error(msg, msg_len, NULL, field, v, reason);
}

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

/* Python float() of a stripped cell: decimal or 'nan'/'inf'/'infinity' with a sign.  strtod in
 * the C locale, without its extensions (hex floats, nan(...)); underscores are not accepted. */
static int py_float(const char *s, double *v)
{
    char *end, buf[SM_TABLE_LINE_MAX + 2];
    const char *dp = localeconv()->decimal_point;
    char us[SM_TABLE_LINE_MAX + 2];
    if (*s == '\0') return 0;
    if (strpbrk(s, "xX(") != NULL) return 0;
    if (strchr(s, '_') != NULL) { /* PEP 515: an underscore only between two digits, then dropped */
        size_t i, o = 0;
        for (i = 0; s[i] != '\0' && o + 1 < sizeof us; ++i) {
            if (s[i] == '_') {
                if (i == 0 || !(s[i - 1] >= '0' && s[i - 1] <= '9') || !(s[i + 1] >= '0' && s[i + 1] <= '9'))
                    return 0;
                continue;
            }
            us[o++] = s[i];
        }
        us[o] = '\0';
        s = us;
    }
    if (dp != NULL && dp[0] != '.' && dp[0] != '\0' && dp[1] == '\0') {
        /* a host that set LC_NUMERIC (decimal comma): the file's '.' is strtod's dp[0] */
        size_t i;
        if (strchr(s, dp[0]) != NULL) return 0;
        snprintf(buf, sizeof buf, "%s", s);
        for (i = 0; buf[i] != '\0'; ++i)
            if (buf[i] == '.') buf[i] = dp[0];
        s = buf;
    }
    errno = 0;
    *v = strtod(s, &end);
    return *end == '\0';
}

static int is_space(int ch)
{
    return ch == ' ' || ch == '\t' || ch == '\n' || ch == '\r' || ch == '\v' || ch == '\f'
           || (ch >= 0x1c && ch <= 0x1f);
}

/* length of the UTF-8 encoded non-ASCII Unicode whitespace (str.isspace) starting at s, else 0 */
static size_t uspace_at(const unsigned char *s)
{
    if (s[0] == 0xC2 && (s[1] == 0x85 || s[1] == 0xA0)) return 2;
    if (s[0] == 0xE1 && s[1] == 0x9A && s[2] == 0x80) return 3;
    if (s[0] == 0xE2 && s[1] == 0x80 && ((s[2] >= 0x80 && s[2] <= 0x8A) || s[2] == 0xA8 || s[2] == 0xA9
                                         || s[2] == 0xAF)) return 3;
    if (s[0] == 0xE2 && s[1] == 0x81 && s[2] == 0x9F) return 3;
    if (s[0] == 0xE3 && s[1] == 0x80 && s[2] == 0x80) return 3;
    return 0;
}

/* str.strip() in place on UTF-8: returns the start, cuts the end */
static char *strip(char *s)
{
    size_t l, u;
    for (;;) {
        if (*s != '\0' && is_space((unsigned char)*s)) ++s;
        else if ((u = uspace_at((const unsigned char *)s)) > 0) s += u;
        else break;
    }
    l = strlen(s);
    for (;;) {
        if (l > 0 && is_space((unsigned char)s[l - 1])) s[--l] = '\0';
        else if (l >= 2 && uspace_at((const unsigned char *)s + l - 2) == 2) s[l -= 2] = '\0';
        else if (l >= 3 && uspace_at((const unsigned char *)s + l - 3) == 3) s[l -= 3] = '\0';
        else break;
    }
    return s;
}

#define SM_LINE_QUOTE_MAX 1024

static int bad_line(const char *src, int lineno, const char *line, char *msg, size_t msg_len)
{
    /* Python: ParameterError("table_file", f"line {lineno}: {line.strip()!r}", ...): a repr in a repr */
    /* the line is quoted up to SM_LINE_QUOTE_MAX bytes (a message buffer is shorter anyway) */
    char copy[SM_LINE_QUOTE_MAX + 1], inner[4 * SM_LINE_QUOTE_MAX + 8], val[4 * SM_LINE_QUOTE_MAX + 32];
    char rep[8 * SM_LINE_QUOTE_MAX + 64];
    size_t i = 0;
    while (*line != '\0' && is_space((unsigned char)*line)) ++line;
    for (; i < SM_LINE_QUOTE_MAX && line[i] != '\0'; ++i) copy[i] = line[i];
    copy[i] = '\0';
    sm_repr_str(strip(copy), inner, sizeof inner);
    snprintf(val, sizeof val, "line %d: %s", lineno, inner);
    sm_repr_str(val, rep, sizeof rep);
    return sm_param_error(msg, msg_len, src, "table_file", rep, "must hold two numeric columns i_mu, psi_m");
}

/* one line of the file (TableCurve.from_csv loop body): 0 skip, 1 point, 2 header, <0 error */
static int parse_line(char *line, double *a, double *b)
{
    char *p = line, *hash, *cells[3];
    int nc = 0, i;
    double v[2];
    hash = strchr(p, '#');
    if (hash != NULL) *hash = '\0';
    for (;;) {
        char *comma = strchr(p, ',');
        if (comma != NULL) *comma = '\0';
        if (nc < 3) cells[nc] = strip(p);
        ++nc;
        if (comma == NULL) break;
        p = comma + 1;
    }
    if (nc == 1 && cells[0][0] == '\0') return 0;
    for (i = 0; i < nc && i < 3; ++i) {
        double t;
        if (!py_float(cells[i], &t)) return 2; /* not numeric: the header if first */
        if (i < 2) v[i] = t;
    }
    if (nc != 2) return -1;
    *a = v[0];
    *b = v[1];
    return 1;
}

/* The file decodes as utf-8-sig (Python reads it so before any line): 0, or 1 with the text of
 * Python's UnicodeDecodeError in why (positions counted after a BOM). */
static int utf8_invalid(FILE *fh, char *why, size_t why_len)
{
    long pos = 0;
    int ch, k, need;
    unsigned char head[3];
    size_t nh = fread(head, 1, 3, fh);
    if (!(nh == 3 && head[0] == 0xEF && head[1] == 0xBB && head[2] == 0xBF)) {
        rewind(fh);
    }
    while ((ch = getc(fh)) != EOF) {
        unsigned lo = 0x80, hi = 0xBF;
        const char *reason = NULL;
        if (ch < 0x80) {
            ++pos;
            continue;
        }
        if (ch < 0xC2 || ch > 0xF4) {
            snprintf(why, why_len, "'utf-8' codec can't decode byte 0x%02x in position %ld: invalid start byte",
                     (unsigned)ch, pos);
            return 1;
        }
        need = ch < 0xE0 ? 1 : (ch < 0xF0 ? 2 : 3);
        if (ch == 0xE0) lo = 0xA0;
        else if (ch == 0xED) hi = 0x9F;
        else if (ch == 0xF0) lo = 0x90;
        else if (ch == 0xF4) hi = 0x8F;
        for (k = 1; k <= need; ++k) {
            int c2 = getc(fh);
            if (c2 == EOF) reason = "unexpected end of data";
            else if ((unsigned)c2 < lo || (unsigned)c2 > hi) reason = "invalid continuation byte";
            if (reason != NULL) break;
            lo = 0x80;
            hi = 0xBF;
        }
        if (reason != NULL) {
            if (k == 1)
                snprintf(why, why_len, "'utf-8' codec can't decode byte 0x%02x in position %ld: %s", (unsigned)ch,
                         pos, reason);
            else
                snprintf(why, why_len, "'utf-8' codec can't decode bytes in position %ld-%ld: %s", pos,
                         pos + k - 1, reason);
            return 1;
        }
        pos += need + 1;
    }
    rewind(fh);
    return 0;
}

static int table_from_csv(sm_curve *c, const char *path, char *msg, size_t msg_len)
{
    double xs[SM_TABLE_MAX + 1], ys[SM_TABLE_MAX + 1];
    int lines[SM_TABLE_MAX + 1];
    char line[SM_TABLE_LINE_MAX + 2], work[SM_TABLE_LINE_MAX + 2], rp[1200], reason[1400];
    FILE *fh;
    int rows = 0, header = 0, lineno = 0, ch, eof = 0, first = 1;
    fh = fopen(path, "rb");
    if (fh == NULL) {
        int e = errno;
        char rq[1200];
        snprintf(reason, sizeof reason, "cannot be read: [Errno %d] %s: %s", e, strerror(e),
                 sm_repr_str(path, rq, sizeof rq));
        return sm_param_error(msg, msg_len, NULL, "table_file", sm_repr_str(path, rp, sizeof rp), reason);
    }
    {
        char why[200];
        if (utf8_invalid(fh, why, sizeof why)) {
            fclose(fh);
            snprintf(reason, sizeof reason, "cannot be read: %s", why);
            return sm_param_error(msg, msg_len, NULL, "table_file", sm_repr_str(path, rp, sizeof rp), reason);
        }
    }
    while (!eof) {
        size_t len = 0;
        int nul = 0, any = 0, toolong = 0, st;
        double a, b;
        /* str.splitlines: \n, \r, \r\n, \v, \f, \x1c, \x1d, \x1e, U+0085, U+2028, U+2029 end a line */
        for (;;) {
            ch = getc(fh);
            if (ch == EOF) { eof = 1; break; }
            any = 1;
            if (ch == '\n' || ch == '\v' || ch == '\f' || ch == 0x1c || ch == 0x1d || ch == 0x1e) break;
            if (ch == '\r') {
                int nx = getc(fh);
                if (nx != '\n' && nx != EOF) ungetc(nx, fh);
                break;
            }
            if (ch == 0xC2 || ch == 0xE2) { /* U+0085, U+2028, U+2029 (the file is valid UTF-8) */
                int c2 = getc(fh), c3 = ch == 0xE2 ? getc(fh) : EOF;
                if ((ch == 0xC2 && c2 == 0x85) || (ch == 0xE2 && c2 == 0x80 && (c3 == 0xA8 || c3 == 0xA9)))
                    break;
                if (len + 3 <= SM_TABLE_LINE_MAX) {
                    line[len++] = (char)ch;
                    if (c2 != EOF) line[len++] = (char)c2;
                    if (c3 != EOF) line[len++] = (char)c3;
                } else {
                    toolong = 1;
                }
                continue;
            }
            if (ch == 0) nul = 1;
            if (len < SM_TABLE_LINE_MAX) line[len++] = (char)ch;
            else toolong = 1;
        }
        if (!any) break;
        line[len] = '\0';
        ++lineno;
        if (first) { /* utf-8-sig: drop a BOM */
            first = 0;
            if ((unsigned char)line[0] == 0xEF && (unsigned char)line[1] == 0xBB && (unsigned char)line[2] == 0xBF)
            {
                memmove(line, line + 3, len - 3 + 1);
                len -= 3;
            }
        }
        if (toolong) {
            char val[64];
            fclose(fh);
            snprintf(val, sizeof val, "line %d", lineno);
            snprintf(reason, sizeof reason, "is longer than %d bytes (the native limit SM_TABLE_LINE_MAX)",
                     SM_TABLE_LINE_MAX);
            return sm_param_error(msg, msg_len, path, "table_file", sm_repr_str(val, rp, sizeof rp), reason);
        }
        memcpy(work, line, sizeof work);
        /* a NUL byte: Python's float() fails on the cell, so the line is not numeric */
        st = nul ? 2 : parse_line(work, &a, &b);
        if (st == 0) continue;
        if (st == 2 && rows == 0 && !header) {
            header = 1;
            continue;
        }
        if (st != 1) {
            fclose(fh);
            return bad_line(path, lineno, line, msg, msg_len);
        }
        if (rows > SM_TABLE_MAX) continue; /* counted, rejected below */
        xs[rows] = a;
        ys[rows] = b;
        lines[rows] = lineno;
        ++rows;
    }
    if (ferror(fh)) {
        int e = errno;
        char rq[1200];
        fclose(fh);
        snprintf(reason, sizeof reason, "cannot be read: [Errno %d] %s: %s", e, strerror(e),
                 sm_repr_str(path, rq, sizeof rq));
        return sm_param_error(msg, msg_len, NULL, "table_file", sm_repr_str(path, rp, sizeof rp), reason);
    }
    fclose(fh);
    if (rows == 0)
        return sm_param_error(msg, msg_len, path, "table_file", sm_repr_str(path, rp, sizeof rp),
                              "holds no points i_mu, psi_m");
    if (rows > SM_TABLE_MAX) {
        snprintf(reason, sizeof reason, "has more than %d points (the native limit SM_TABLE_MAX)",
                 SM_TABLE_MAX);
        return sm_param_error(msg, msg_len, path, "table_file", sm_repr_str(path, rp, sizeof rp), reason);
    }
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
        return table_from_csv(c, table_path, msg, msg_len);
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

/* ------------------------------------------------------------------ CPython's math.hypot */

typedef struct { double hi, lo; } sm_dl;

/* exact x*y = hi + lo (Dekker's product with Veltkamp splitting; |x|, |y| < 1 here) */
static sm_dl dl_mul(double x, double y)
{
    const double split = 134217729.0; /* 2**27 + 1 */
    double cx = split * x, cy = split * y;
    double xh = cx - (cx - x), xl = x - xh;
    double yh = cy - (cy - y), yl = y - yh;
    sm_dl r;
    r.hi = x * y;
    r.lo = ((xh * yh - r.hi) + xh * yl + xl * yh) + xl * yl;
    return r;
}

static sm_dl dl_fast_sum(double a, double b)
{
    sm_dl r;
    r.hi = a + b;
    r.lo = (a - r.hi) + b;
    return r;
}

static double vector_norm2(double *vec, double max, int found_nan)
{
    double x, h, scale, csum = 1.0, frac1 = 0.0, frac2 = 0.0;
    sm_dl pr, sm;
    int max_e, i;
    if (isinf(max)) return max;
    if (found_nan) return NAN;
    if (max == 0.0) return max;
    frexp(max, &max_e);
    if (max_e < -1023) {
        for (i = 0; i < 2; ++i) vec[i] /= DBL_MIN;
        return DBL_MIN * vector_norm2(vec, max / DBL_MIN, found_nan);
    }
    scale = ldexp(1.0, -max_e);
    for (i = 0; i < 2; ++i) {
        x = vec[i] * scale;
        pr = dl_mul(x, x);
        sm = dl_fast_sum(csum, pr.hi);
        csum = sm.hi;
        frac1 += pr.lo;
        frac2 += sm.lo;
    }
    h = sqrt(csum - 1.0 + (frac1 + frac2));
    pr = dl_mul(-h, h);
    sm = dl_fast_sum(csum, pr.hi);
    csum = sm.hi;
    frac1 += pr.lo;
    frac2 += sm.lo;
    x = csum - 1.0 + (frac1 + frac2);
    h += x / (2.0 * h);
    return h / scale;
}

double sm_hypot(double x, double y)
{
    double v[2], max = 0.0;
    int found_nan;
    v[0] = fabs(x);
    v[1] = fabs(y);
    found_nan = isnan(v[0]) || isnan(v[1]);
    if (v[0] > max) max = v[0];
    if (v[1] > max) max = v[1];
    return vector_norm2(v, max, found_nan);
}

size_t sm_curve_size(void)
{
    return sizeof(sm_curve);
}

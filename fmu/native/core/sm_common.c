/* The helpers of sm_common.h in C99: Python-style messages (the wording of satmotor/errors.py), CPython's
 * repr of a float or a str and float() of a string, CPython's math.hypot.  No global mutable state. */
#include "sm_common.h"

#include <errno.h>
#include <float.h>
#include <locale.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------ messages and repr */

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

/* ------------------------------------------------------------------ Python's float() of a string */

int sm_parse_float(const char *s, double *v)
{
    char *end, buf[SM_FLOAT_TEXT_MAX + 2];
    const char *dp = localeconv()->decimal_point;
    char us[SM_FLOAT_TEXT_MAX + 2];
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

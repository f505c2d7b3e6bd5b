/* satmotor/control/references.py in C99; the same operations in the same order as the Python. */
#include "sm_references.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

int sm_transition_matrix(double bandwidth, double h, double P[9], char *msg, size_t msg_len)
{
    double w = bandwidth, w2, w3, N[3][3], N2[3][3], e, hh;
    int st, i, j;
    if (P == NULL) return SM_ERR_ARG;
    if ((st = sm_require_number("bandwidth", bandwidth, 1, 0.0, 0, msg, msg_len)) != SM_CORE_OK) return st;
    if ((st = sm_require_number("h", h, 1, 0.0, 0, msg, msg_len)) != SM_CORE_OK) return st;
    w2 = w * w;
    w3 = w * w * w;
    N[0][0] = w;     N[0][1] = 1.0;        N[0][2] = 0.0;
    N[1][0] = 0.0;   N[1][1] = w;          N[1][2] = 1.0;
    N[2][0] = -w3;   N[2][1] = -3.0 * w2;  N[2][2] = -2.0 * w;
    N2[0][0] = w2;        N2[0][1] = 2.0 * w;   N2[0][2] = 1.0;
    N2[1][0] = -w3;       N2[1][1] = -2.0 * w2; N2[1][2] = -w;
    N2[2][0] = w3 * w;    N2[2][1] = 2.0 * w3;  N2[2][2] = w2;
    e = exp(-w * h);
    hh = 0.5 * h * h;
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 3; ++j)
            P[3 * i + j] = e * ((i == j ? 1.0 : 0.0) + h * N[i][j] + hh * N2[i][j]);
    return SM_CORE_OK;
}

/* references._cdf3: 1 - exp(-x)(1 + x + x^2/2) */
static double cdf3(double x)
{
    return 1.0 - exp(-x) * (1.0 + x + 0.5 * x * x);
}

static double solve_cdf3(double level)
{
    double lo = 0.0, hi = 50.0, mid;
    int i;
    for (i = 0; i < 200; ++i) {
        mid = 0.5 * (lo + hi);
        if (cdf3(mid) < level)
            lo = mid;
        else
            hi = mid;
    }
    return 0.5 * (lo + hi);
}

double sm_rise_time_product(void)
{
    return solve_cdf3(0.9) - solve_cdf3(0.1);
}

int sm_shaper_reset(sm_shaper *s, double value, char *msg, size_t msg_len)
{
    int st;
    if (s == NULL) return SM_ERR_ARG;
    if ((st = sm_require_number("value", value, 0, 0.0, 0, msg, msg_len)) != SM_CORE_OK) return st;
    s->z[0] = value;
    s->z[1] = 0.0;
    s->z[2] = 0.0;
    return SM_CORE_OK;
}

int sm_shaper_init(sm_shaper *s, double bandwidth, double initial, char *msg, size_t msg_len)
{
    int st;
    if (s == NULL) return SM_ERR_ARG;
    memset(s, 0, sizeof *s);
    if ((st = sm_require_number("bandwidth", bandwidth, 1, 0.0, 0, msg, msg_len)) != SM_CORE_OK) return st;
    s->bandwidth = bandwidth;
    s->has_h = 0;
    s->h_cached = 0.0;
    return sm_shaper_reset(s, initial, msg, msg_len);
}

int sm_shaper_step(sm_shaper *s, double u, double h, double r[3], char *msg, size_t msg_len)
{
    double e0, r1, r2;
    const double *p;
    int st;
    if (s == NULL) return SM_ERR_ARG;
    if (!(s->has_h && h == s->h_cached)) {
        double P[9];
        if ((st = sm_transition_matrix(s->bandwidth, h, P, msg, msg_len)) != SM_CORE_OK) return st;
        memcpy(s->phi, P, sizeof P);
        s->h_cached = h;
        s->has_h = 1;
    }
    if (!isfinite(u)) return sm_require_number("u", u, 0, 0.0, 0, msg, msg_len);
    p = s->phi;
    e0 = s->z[0] - u;
    r1 = s->z[1];
    r2 = s->z[2];
    s->z[0] = u + (p[0] * e0 + p[1] * r1 + p[2] * r2);
    s->z[1] = p[3] * e0 + p[4] * r1 + p[5] * r2;
    s->z[2] = p[6] * e0 + p[7] * r1 + p[8] * r2;
    if (r != NULL) {
        r[0] = s->z[0];
        r[1] = s->z[1];
        r[2] = s->z[2];
    }
    return SM_CORE_OK;
}

void sm_shaper_get_state(const sm_shaper *s, double z[3])
{
    z[0] = s->z[0];
    z[1] = s->z[1];
    z[2] = s->z[2];
}

int sm_shaper_set_state(sm_shaper *s, const double z[3], char *msg, size_t msg_len)
{
    char v[3][40], tup[140];
    if (s == NULL || z == NULL) return SM_ERR_ARG;
    if (!(isfinite(z[0]) && isfinite(z[1]) && isfinite(z[2]))) {
        sm_repr_double(z[0], v[0], sizeof v[0]);
        sm_repr_double(z[1], v[1], sizeof v[1]);
        sm_repr_double(z[2], v[2], sizeof v[2]);
        snprintf(tup, sizeof tup, "(%s, %s, %s)", v[0], v[1], v[2]);
        return sm_param_error(msg, msg_len, NULL, "state", tup, "must be finite");
    }
    s->z[0] = z[0];
    s->z[1] = z[1];
    s->z[2] = z[2];
    return SM_CORE_OK;
}

/* The arc tangent of the magnetizing curves (satmotor/machine/atan.py, the same operations in the
 * same order, so the same floats; tests/test_atan.py checks both against each other and against the
 * exact value).  C99, no state, no libm call but fabs and copysign (exact).
 *
 * |x| < 2^-28: atan(x) = x (the next term, x^3/3, is below half an ulp of x).
 * |x| < 1/16:  the Taylor polynomial x - x^3/3 + ... - x^15/15 (the next term is below 2^-64 x).
 * |x| <= 4:    c = k/64 the nearest multiple of 1/64, atan(a) = atan(c) + atan(t),
 *              t = (a - c) / (1 + a c), |t| <= 1/128, atan(t) = t - t^3/3 + t^5/5 - t^7/7
 *              (the next term is below 2^-59 t); atan(c) from a table, as the double hi nearest to
 *              it plus the double lo nearest to the rest.
 * |x| > 4:     c = k/64 the nearest multiple of 1/64 to 1/a, atan(a) = pi/2 - atan(c) - atan(t),
 *              t = (1/a - c) / (1 + c/a) = (1 - a c) / (a + c), the same polynomial, and
 *              pi/2 - atan(c) from a second table.
 * |x| > 2^60:  pi/2 (rounded; the exact value is within 2^-60 of it).
 * Scaled by 64 (exact), t = (64 a - 64 c) / (64 + a (64 c)): 64 c is an integer, 64 a - 64 c is
 * exact (Sterbenz), and the rounding of 64 a to the nearest integer is (64 a + 1.5 2^52) - 1.5 2^52.
 * sm_atan2 (atan.py's atan2): C99's special cases, else atan(|y| / |x|), and pi - it for x < 0.
 * Needs IEEE double arithmetic without fused multiply-add or excess precision (sm_common.h). */
#include "sm_atan.h"

#include <math.h>

#include "sm_atan_tables.h" /* ATAN_K64, ACOT_K64, SM_ATAN_C1..7, ...: generated from atan.py */

double sm_atan(double x)
{
    double a = fabs(x), y, n, t, z, w, r;
    int k;
    if (a < SM_ATAN_TINY) return x;
    if (a < 0.0625) {
        z = x * x;
        w = z * z;
        return x + x * z * (((SM_ATAN_C1 + z * SM_ATAN_C2) + w * (SM_ATAN_C3 + z * SM_ATAN_C4))
                            + (w * w) * ((SM_ATAN_C5 + z * SM_ATAN_C6) + w * SM_ATAN_C7));
    }
    if (a <= 4.0) {
        y = a * 64.0;
        n = (y + SM_ATAN_ROUND) - SM_ATAN_ROUND;
        k = (int)n;
        t = (y - n) / (64.0 + a * n);
        z = t * t;
        w = t * z * ((SM_ATAN_C1 + z * SM_ATAN_C2) + (z * z) * SM_ATAN_C3);
        r = ATAN_K64[k][0] + ((t + ATAN_K64[k][1]) + w);
    } else if (a <= SM_ATAN_HUGE) {
        y = 64.0 / a;
        n = (y + SM_ATAN_ROUND) - SM_ATAN_ROUND;
        k = (int)n;
        t = (64.0 - a * n) / (a * 64.0 + n);
        z = t * t;
        w = t * z * ((SM_ATAN_C1 + z * SM_ATAN_C2) + (z * z) * SM_ATAN_C3);
        r = ACOT_K64[k][0] - ((t - ACOT_K64[k][1]) + w);
    } else if (a > SM_ATAN_HUGE) {
        r = ACOT_K64[0][0];
    } else {
        return x + x; /* NaN */
    }
    return x < 0.0 ? -r : r;
}

double sm_atan2(double y, double x)
{
    double ax, ay, z, r;
    if (x != x || y != y) return x + y; /* NaN */
    ax = fabs(x);
    ay = fabs(y);
    if (ay == 0.0) { /* +-0, its sign kept: +-0 for x = +0 or x > 0, +-pi for x = -0 or x < 0 */
        if (copysign(1.0, x) > 0.0) return y;
        r = SM_ATAN2_PI;
    } else if (ax == 0.0) {
        r = SM_ATAN2_PI_2;
    } else if (ay == HUGE_VAL) {
        r = ax < HUGE_VAL ? SM_ATAN2_PI_2 : (x > 0.0 ? SM_ATAN2_PI_4 : SM_ATAN2_PI_3_4);
    } else if (ax == HUGE_VAL) {
        r = x > 0.0 ? 0.0 : SM_ATAN2_PI;
    } else {
        z = sm_atan(ay / ax);
        r = x > 0.0 ? z : SM_ATAN2_PI - (z - SM_ATAN2_PI_LO);
    }
    return copysign(1.0, y) < 0.0 ? -r : r;
}

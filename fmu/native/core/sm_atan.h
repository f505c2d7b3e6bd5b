/* The arc tangent of the magnetizing curves: satmotor/machine/atan.py in C99, the same floats.
 * Used instead of libm's atan so that the curve solve is cheaper and its result does not depend on
 * the platform's libm.  No state. */
#ifndef SM_ATAN_H
#define SM_ATAN_H

/* atan(x) [rad] for every double: below 0.62 ulp from the exact value (tests/test_atan.py),
 * odd (atan(-x) = -atan(x), -0.0 kept), +-pi/2 at +-inf, NaN for NaN. */
double sm_atan(double x);

/* atan2(y, x) [rad] in [-pi, pi], built on sm_atan: satmotor/machine/atan.py's atan2, the same floats
 * on every platform; C99's special cases (zeros, infinities, NaN), within 2 ulp of the exact value. */
double sm_atan2(double y, double x);

#endif

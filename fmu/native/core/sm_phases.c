/* satmotor/machine/phases.py in C99 (see sm_phases.h). */
#include "sm_phases.h"

#include <math.h>

void sm_phase_currents(double i_alpha, double i_beta, double c[3])
{
    double s32 = 0.5 * sqrt(3.0); /* phases.SQRT3_2 */
    c[0] = i_alpha;
    c[1] = -0.5 * i_alpha + s32 * i_beta;
    c[2] = -0.5 * i_alpha - s32 * i_beta;
}

void sm_alpha_beta(double va, double vb, double vc, double *a, double *b)
{
    *a = (2.0 * va - vb - vc) / 3.0;
    *b = (vb - vc) / sqrt(3.0);
}

/* satmotor/machine/losses.py in C (see sm_losses.h). */
#include "sm_losses.h"

#include <math.h>

#include "sm_common.h"

int sm_losses_init(sm_losses *lp, const sm_plant_params *pp, char *msg, size_t msg_len)
{
    const char *names[6] = {"T_fric", "k_wind", "k_stray", "E_sw", "V_sw_ref", "I_sw_ref"};
    double v[6];
    int j;
    v[0] = pp->T_fric;
    v[1] = pp->k_wind;
    v[2] = pp->k_stray;
    v[3] = pp->E_sw;
    v[4] = pp->V_sw_ref;
    v[5] = pp->I_sw_ref;
    for (j = 0; j < 6; ++j) { /* the four losses >= 0, the two references > 0 */
        if (sm_require_number(names[j], v[j], 1, 0.0, j < 4, msg, msg_len)) return SM_ERR_PARAM;
    }
    lp->T_fric = v[0];
    lp->k_wind = v[1];
    lp->k_stray = v[2];
    lp->E_sw = v[3];
    lp->V_sw_ref = v[4];
    lp->I_sw_ref = v[5];
    lp->k_edge = 0.5 * lp->E_sw / (lp->V_sw_ref * lp->I_sw_ref);
    lp->mechanical = lp->T_fric > 0.0 || lp->k_wind > 0.0 || lp->k_stray > 0.0;
    return SM_CORE_OK;
}

double sm_friction_torque(const sm_losses *lp, double w)
{
    const double f = w > 0.0 ? lp->T_fric : w < 0.0 ? -lp->T_fric : 0.0;
    return f + lp->k_wind * w * fabs(w);
}

double sm_loss_torque(const sm_losses *lp, double w, double i2)
{
    return sm_friction_torque(lp, w) + lp->k_stray * i2 * w;
}

double sm_switching_power(const sm_losses *lp, double f_sw, double v_dc, const double cur[3])
{
    return 2.0 * f_sw * lp->k_edge * v_dc * (fabs(cur[0]) + fabs(cur[1]) + fabs(cur[2]));
}
